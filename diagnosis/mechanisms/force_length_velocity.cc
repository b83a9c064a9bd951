// force_length_velocity: a different force–velocity property of the forearm muscles (eq. 7 of
// papers/000_0a6c0de9fc69df7c.txt, muscles/hill.h). Extension: hill.vmax_scale s, v_max × s,
// slower only (s ≤ 1, one-sided score test): a faster fit took up generic misfit on clean persons
// (docs/diagnosis.md, "Why force–velocity is slower only"). Planted: v_max × 1/(1 + 2 s).
#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {

Mechanism ForceLengthVelocityMechanism() {
  Mechanism m;
  m.id = "force_length_velocity";
  m.description = "a different muscle force-velocity property";
  m.candidates = [](const sim::ModelParams& rig, const LibraryContext&) {
    Candidate c;
    std::vector<int> forearm = WristGroup(rig, true);
    const std::vector<int> flex = WristGroup(rig, false);
    forearm.insert(forearm.end(), flex.begin(), flex.end());
    std::vector<double> vmax;
    vmax.reserve(forearm.size());
    for (int k : forearm) vmax.push_back(rig.muscles[k].hill.max_contraction_velocity);
    c.params.push_back(Sensed(Param("hill.vmax_scale", "1", 1.0, 0.05, 1.0, 1.0,
                                    [forearm, vmax](double v, sim::ModelParams* p) {
                                      for (std::size_t i = 0; i < forearm.size(); ++i) {
                                        p->muscles[forearm[i]].hill.max_contraction_velocity =
                                            v * vmax[i];
                                      }
                                    })));
    c.probes = {ProbeAt(c.params, 0, 0.5)};
    c.one_sided = {true};
    return std::vector<Candidate>{c};
  };
  m.plant = [](const PlantContext& ctx, sim::ModelParams* truth, sim::SensorSuite*,
               std::vector<NamedValue>* planted) {
    PlantViaCandidate("force_length_velocity", "hill.vmax_scale", 1.0 / (1.0 + 2.0 * ctx.scale),
                      ctx.library, truth, planted);
  };
  m.evidence = InputLagEvidence;
  return m;
}

}  // namespace fesim::diagnosis
