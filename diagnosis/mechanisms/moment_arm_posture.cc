// moment_arm_posture: moment arms that change with posture. Extension at each output joint:
// momentarm.posture_ratio ρ — every crossing of the joint gets d̃ += ρ d in eq. (10) of
// papers/000_0a6c0de9fc69df7c.txt (constant arms become Landsmeer arms), l_MT at the rest posture
// kept. Planted on the wrist: ρ = 2 s. Near q = 0 the Landsmeer shape is g(q) ≈ −q/12
// (tendons/landsmeer.h), so r ≈ d (1 − ρ q / 12): the range ρ ∈ [−12, 12] is a relative slope of
// the moment arm of up to 1/rad (an arm that doubles or vanishes 1 rad from q = 0). At ±6 (½/rad)
// a foreign person's wrist arms at a relative slope of 0.6/rad (foreign/effects.cc) ended at the
// bound (docs/diagnosis.md, Validation).
#include "diagnosis/mechanisms/library.h"
#include "tendons/tendon_network.h"

namespace fesim::diagnosis {

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
      c.params.push_back(
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
                       })));
      c.probes = {ProbeAt(c.params, 0, 0.5)};
      c.one_sided = {false};
      out.push_back(c);
    }
    return out;
  };
  m.plant = [](const PlantContext& ctx, sim::ModelParams* truth, sim::SensorSuite*,
               std::vector<NamedValue>* planted) {
    PlantViaCandidate("moment_arm_posture", "momentarm.posture_ratio", 2.0 * ctx.scale, ctx.library,
                      truth, planted);
  };
  m.evidence = PostureEvidence;
  return m;
}

}  // namespace fesim::diagnosis
