// The mechanism table (mechanism.h): PRODUCT.md's 13 ids in its order, one file each.
#include <algorithm>
#include <stdexcept>

#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {

const std::vector<Mechanism>& Mechanisms() {
  static const std::vector<Mechanism> table = {
      FatigueMechanism(),
      PotentiationMechanism(),
      DelayMechanism(),
      TremorMechanism(),
      CrosstalkMechanism(),
      MomentArmPostureMechanism(),
      ForceLengthVelocityMechanism(),
      UnequalMuscleDynamicsMechanism(),
      PassiveStiffnessNonlinearMechanism(),
      ArmSupportMechanism(),
      StictionMechanism(),
      SpasticityMechanism(),
      SensorDriftMechanism(),
  };
  return table;
}

const std::vector<std::string>& MechanismIds() {
  static const std::vector<std::string> ids = [] {
    std::vector<std::string> out;
    for (const auto& m : Mechanisms()) out.push_back(m.id);
    return out;
  }();
  return ids;
}

const Mechanism& FindMechanism(const std::string& id) {
  for (const auto& m : Mechanisms()) {
    if (m.id == id) return m;
  }
  std::string allowed;
  for (const auto& m : Mechanisms()) allowed += (allowed.empty() ? "" : ", ") + m.id;
  throw std::invalid_argument("unknown mechanism '" + id + "' (allowed: " + allowed + ")");
}

std::vector<Candidate> CandidateLibrary(const sim::ModelParams& rig, const LibraryContext& ctx) {
  std::vector<Candidate> out;
  for (const auto& m : Mechanisms()) {
    for (Candidate c : m.candidates(rig, ctx)) {
      c.id = m.id;
      if (c.label.empty()) c.label = c.joint.empty() ? c.id : c.id + "@" + c.joint;
      if (!ctx.reduced_model.empty() && c.applicable && !m.reduced_model_form) {
        c.applicable = false;
        c.not_applicable_reason =
            "acts inside the musculoskeletal model, which the reduced model " + ctx.reduced_model +
            " does not have (diagnose with --model full)";
      }
      if (c.applicable && !c.start_from_step) SetLinearStart(&c);
      out.push_back(std::move(c));
    }
  }
  return out;
}

}  // namespace fesim::diagnosis
