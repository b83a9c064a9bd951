// spasticity: a velocity-dependent stretch reflex (Lance 1980; sim/mechanisms.h,
// τ = −G_d (|q̇| − v_th) sign(q̇) above v_th, G_d = G (1 ± β) by direction). Extension at each
// output joint: reflex.gain_nms_per_rad G, reflex.threshold_rad_s v_th, reflex.direction_bias β
// ∈ [−1, 1] (1: the flexors' reflex alone, resisting extension; −1: the extensors'). A spastic
// person's reflex is often one group's (flexors after stroke), which a symmetric reflex fitted at
// "off" points away from: the score test probes each direction one-sided. Planted on the wrist:
// G = 0.4 s T_j, v_th = 0.5 rad/s, β = 0, on pseudo-random steps only (the step grid moves the
// wrist too slowly: the effect stays at 0.2–0.25 × the noise whatever G; planted_test).
#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {
namespace {

Candidate SpasticityAt(const sim::ModelParams& rig, int j) {
  Candidate c;
  c.joint = sim::CoordinateNames()[j];
  const double tj = JointTorqueScale(rig, j);
  c.params.push_back(Param("reflex.gain_nms_per_rad", "N*m*s/rad", 0.0, 0.0, 2.0 * tj, 0.05 * tj,
                           [j](double v, sim::ModelParams* p) {
                             p->coordinates[j].passive.reflex_gain_nms_per_rad = v;
                           }));
  const double vth = rig.coordinates[j].passive.reflex_threshold_rad_s;
  c.params.push_back(Param("reflex.threshold_rad_s", "rad/s", vth, 0.0, 5.0, 0.5,
                           [j](double v, sim::ModelParams* p) {
                             p->coordinates[j].passive.reflex_threshold_rad_s = v;
                           }));
  c.params.push_back(Param(
      "reflex.direction_bias", "1", 0.0, -1.0, 1.0, 0.5,
      [j](double v, sim::ModelParams* p) { p->coordinates[j].passive.reflex_direction_bias = v; }));
  c.params.back().range_is_plausible = false;  // ±1: one group's reflex alone
  // v_th = 0: a reflex from any stretch velocity (a foreign flexor reflex of threshold 0.1 l_opt/s
  // was fitted there); 5 rad/s: no reflex in these movements. Physical limits, not implausible.
  c.params[1].range_is_plausible = false;
  // Probes: the flexors' reflex alone (β = 1) and the extensors' (β = −1), each at gain 2g on
  // its side. Coefficients θ₁, θ₂ on them are side gains 2gθ₁ (extension) and 2gθ₂ (flexion):
  // G = g (θ₁ + θ₂), β = (θ₁ − θ₂)/(θ₁ + θ₂).
  const double g = 0.05 * tj;
  Eigen::VectorXd flexors = ProbeAt(c.params, 0, g), extensors = flexors;
  flexors(2) = 1.0;
  extensors(2) = -1.0;
  c.probes = {flexors, extensors};
  c.one_sided = {true, true};
  const std::vector<ModelParameter> params = c.params;
  c.start_from_step = [params, g](const Eigen::VectorXd& theta) {
    Eigen::VectorXd x = Starts(params);
    const double t1 = std::max(0.0, theta(0)), t2 = std::max(0.0, theta(1));
    x(0) = std::clamp(g * (t1 + t2), params[0].lower, params[0].upper);
    if (t1 + t2 > 0.0) x(2) = (t1 - t2) / (t1 + t2);
    return x;
  };
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
