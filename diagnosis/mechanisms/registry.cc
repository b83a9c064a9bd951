// The mechanism table (mechanism.h): PRODUCT.md's 13 ids in its order, one file each; then the
// controls (Mechanism::control).
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

const std::vector<Mechanism>& Controls() {
  static const std::vector<Mechanism> table = {
      PassiveAsymmetryControl(),
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
  for (const auto* table : {&Mechanisms(), &Controls()}) {
    for (const auto& m : *table) {
      if (m.id == id) return m;
    }
  }
  std::string allowed;
  for (const auto* table : {&Mechanisms(), &Controls()}) {
    for (const auto& m : *table) allowed += (allowed.empty() ? "" : ", ") + m.id;
  }
  throw std::invalid_argument("unknown mechanism '" + id + "' (allowed: " + allowed + ")");
}

namespace {

/// Candidate::phase_per_trial: a copy of the free phase per training trial t ≥ 1 (trial 0 keeps
/// the original); the probes set every copy to the probe's phase; the start from a score test
/// whose directions are split per trial (screening.h PerTrialDirections: probes.size() columns
/// per trial) takes each trial's phase from its own block.
void SplitFreePhase(int trials, Candidate* c) {
  const int k = c->free_phase_param;
  if (k < 0 || trials < 2) return;
  c->params[k].trial = 0;
  c->phase_per_trial = {k};
  for (int t = 1; t < trials; ++t) {
    ModelParameter copy = c->params[k];
    copy.name += ".trial" + std::to_string(t + 1);
    copy.trial = t;
    c->phase_per_trial.push_back(static_cast<int>(c->params.size()));
    c->params.push_back(std::move(copy));
  }
  const auto extra = static_cast<Eigen::Index>(trials - 1);
  for (Eigen::VectorXd& probe : c->probes) {
    probe.conservativeResize(probe.size() + extra);
    probe.tail(extra).setConstant(probe(k));
  }
  const auto own_start = c->start_from_step;
  const auto np = static_cast<Eigen::Index>(c->probes.size());
  const std::vector<int> copies = c->phase_per_trial;
  c->start_from_step = [own_start, np, k, copies, extra](const Eigen::VectorXd& theta) {
    const Eigen::VectorXd own = own_start(theta);
    Eigen::VectorXd x(own.size() + extra);
    x << own, Eigen::VectorXd::Constant(extra, own(k));
    const bool split = theta.size() == np * static_cast<Eigen::Index>(copies.size());
    for (std::size_t t = 1; split && t < copies.size(); ++t) {
      x(copies[t]) = own_start(theta.segment(static_cast<Eigen::Index>(t) * np, np))(k);
    }
    return x;
  };
}

}  // namespace

std::vector<Candidate> CandidateLibrary(const sim::ModelParams& rig, const LibraryContext& ctx) {
  std::vector<Candidate> out;
  std::vector<const Mechanism*> table;
  for (const auto& m : Mechanisms()) table.push_back(&m);
  for (const auto& m : Controls()) table.push_back(&m);
  for (const Mechanism* mp : table) {
    const Mechanism& m = *mp;
    for (Candidate c : m.candidates(rig, ctx)) {
      c.id = m.id;
      c.control = m.control;
      c.joint_by_fit = m.joint_by_fit;
      if (c.label.empty()) c.label = c.joint.empty() ? c.id : c.id + "@" + c.joint;
      if (!ctx.reduced_model.empty() && c.applicable && !m.reduced_model_form) {
        c.applicable = false;
        c.not_applicable_reason =
            "acts inside the musculoskeletal model, which the reduced model " + ctx.reduced_model +
            " does not have (diagnose with --model full)";
      }
      if (c.applicable && !c.start_from_step) SetLinearStart(&c);
      if (c.applicable) SplitFreePhase(ctx.training_trials, &c);
      out.push_back(std::move(c));
    }
  }
  return out;
}

}  // namespace fesim::diagnosis
