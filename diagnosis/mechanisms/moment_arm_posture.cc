// moment_arm_posture: moment arms that change with posture. Extension at each output joint:
// momentarm.posture_ratio ρ — every crossing of the joint gets d̃ += ρ d in eq. (10) of
// papers/000_0a6c0de9fc69df7c.txt (constant arms become Landsmeer arms), l_MT at the rest posture
// kept. Near q = 0 the Landsmeer shape is g(q) ≈ −q/12 (tendons/landsmeer.h), so
// r ≈ d (1 − ρ q / 12): the range ρ ∈ [−12, 12] is a relative slope of the moment arm of up to
// 1/rad (an arm that doubles or vanishes 1 rad from q = 0). At ±6 (½/rad) a foreign person's
// wrist arms at a relative slope of 0.6/rad (foreign/effects.cc) ended at the bound
// (docs/diagnosis.md, Validation).
//
// Normal variation: |ρ| ≤ 3, a relative slope up to ¼/rad — an arm that changes by a quarter over
// the wrist's ±1 rad, the ±25 % spread of moment arms between persons (docs/diagnosis.md,
// Validation: the in-family persons' spread); a clean foreign person, whose wrist arms change
// by ≈ 0.15/rad (foreign/person.cc), fits at ρ = −1.6 … −2.6, a planted one (0.6/rad more) at
// −4.4. A fit inside the band is a normal person (ModelParameter::normal_half_width). Planted
// beyond it: ρ = 4 s on the wrist.
#include "diagnosis/mechanisms/library.h"
#include "tendons/tendon_network.h"

namespace fesim::diagnosis {
namespace {
constexpr double kNormalRatio = 3.0;  ///< |ρ| of a normal person (see above).
}  // namespace

Mechanism MomentArmPostureMechanism() {
  Mechanism m;
  m.id = "moment_arm_posture";
  m.description = "posture-dependent moment arms";
  m.candidates = [](const sim::ModelParams& rig, const LibraryContext& ctx) {
    std::vector<Candidate> out;
    const std::vector<double> rest = RestPosture(rig);
    for (int j : OutputJoints(ctx)) {
      Candidate c;
      c.joint = sim::CoordinateNames()[j];
      ModelParameter rho =
          Sensed(Param("momentarm.posture_ratio", "1", 0.0, -12.0, 12.0, 1.0,
                       [j, rest](double v, sim::ModelParams* p) {
                         for (auto& muscle : p->muscles) {
                           const double before = tendons::MusculotendonLength(muscle.path, rest);
                           bool changed = false;
                           for (auto& cr : muscle.path.crossings) {
                             if (cr.joint != j || cr.arm.d_m == 0.0) continue;
                             cr.arm.model = tendons::MomentArmParams::Model::kLandsmeer;
                             cr.arm.d_tilde_m += v * cr.arm.d_m;
                             changed = true;
                           }
                           if (changed) {
                             muscle.path.length_at_ref_m +=
                                 before - tendons::MusculotendonLength(muscle.path, rest);
                           }
                         }
                       }));
      rho.normal_half_width = kNormalRatio;
      c.params.push_back(rho);
      c.probes = {ProbeAt(c.params, 0, 0.5)};
      c.one_sided = {false};
      out.push_back(c);
    }
    return out;
  };
  m.plant = [](const PlantContext& ctx, sim::ModelParams* truth, sim::SensorSuite*,
               std::vector<NamedValue>* planted) {
    PlantViaCandidate("moment_arm_posture", "momentarm.posture_ratio", 4.0 * ctx.scale, ctx.library,
                      truth, planted);
  };
  m.evidence = PostureEvidence;
  m.mimics_joint_person = true;  // a posture-dependent arm: the arm scales to first order
  return m;
}

}  // namespace fesim::diagnosis
