// spasticity: a velocity-dependent stretch reflex (Lance 1980; sim/mechanisms.h,
// τ = −G (|q̇| − v_th) sign(q̇) above v_th). Extension at each output joint:
// reflex.gain_nms_per_rad G, reflex.threshold_rad_s v_th. Planted on the wrist: G = 0.4 s T_j,
// v_th = 0.5 rad/s, on pseudo-random steps only (the step grid moves the wrist too slowly: the
// effect stays at 0.2–0.25 × the noise whatever G; planted_test).
#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {
namespace {

Candidate SpasticityAt(const sim::ModelParams& rig, int j) {
  Candidate c;
  c.joint = sim::CoordinateNames()[j];
  const double tj = JointTorqueScale(rig, j);
  c.params.push_back(Sensed(Param("reflex.gain_nms_per_rad", "N*m*s/rad", 0.0, 0.0, 2.0 * tj,
                                  0.05 * tj, [j](double v, sim::ModelParams* p) {
                                    p->coordinates[j].passive.reflex_gain_nms_per_rad = v;
                                  })));
  const double vth = rig.coordinates[j].passive.reflex_threshold_rad_s;
  c.params.push_back(Sensed(Param("reflex.threshold_rad_s", "rad/s", vth, 0.0, 5.0, 0.5,
                                  [j](double v, sim::ModelParams* p) {
                                    p->coordinates[j].passive.reflex_threshold_rad_s = v;
                                  })));
  c.probes = {ProbeAt(c.params, 0, 0.05 * tj)};
  c.one_sided = {true};
  return c;
}

}  // namespace

Mechanism SpasticityMechanism() {
  Mechanism m;
  m.id = "spasticity";
  m.description = "a velocity-dependent stretch reflex (spasticity)";
  m.planted_protocols = {"steps"};
  m.candidates = [](const sim::ModelParams& rig, const LibraryContext& ctx) {
    std::vector<Candidate> out;
    for (int j : OutputJoints(ctx)) out.push_back(SpasticityAt(rig, j));
    return out;
  };
  m.plant = [](const PlantContext& ctx, sim::ModelParams* truth, sim::SensorSuite*,
               std::vector<NamedValue>* planted) {
    const double tj = JointTorqueScale(*truth, sim::kWristFlexion);
    PlantViaCandidate("spasticity", "reflex.gain_nms_per_rad", 0.4 * ctx.scale * tj, ctx.library,
                      truth, planted);
    PlantViaCandidate("spasticity", "reflex.threshold_rad_s", 0.5, ctx.library, truth, planted);
  };
  m.evidence = VelocityEvidence;
  return m;
}

}  // namespace fesim::diagnosis
