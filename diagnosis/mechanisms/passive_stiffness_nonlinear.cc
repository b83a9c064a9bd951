// passive_stiffness_nonlinear: joint stiffness rising nonlinearly with the angle — the
// exponential range limits of eq. (14) of papers/000_0a6c0de9fc69df7c.txt (sim/passive_joint.h)
// larger and broader. Extension at each output joint: passive.limit_scale (K_L × s, s ≥ 1),
// passive.sharpness_per_rad κ (≤ the joint's: broader). Planted on the wrist: K_L × (1 + 20 s),
// κ = 5/rad. Both one-sided: the mechanism only adds passive torque. A fit that weakens or
// sharpens the person's range limits is soaking up the person's own passive curve (a clean
// foreign person, BM_DiagnoseClean3x60s: K_L × 0.13, κ 20 → 19/rad at the PIP joint, accepted
// at a 5.5 % held-out gain), not stiffening.
#include <algorithm>

#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {
namespace {

/// κ of the broad passive-nonlinearity probe, 1/rad.
constexpr double kBroadSharpness = 5.0;

Candidate PassiveAt(const sim::ModelParams& rig, int j) {
  Candidate c;
  c.joint = sim::CoordinateNames()[j];
  const auto& pj = rig.coordinates[j].passive;
  const double kl = std::max(pj.limit_stiffness_nm_per_rad, 0.1 * JointTorqueScale(rig, j));
  c.params.push_back(Sensed(Param("passive.limit_scale", "1", 1.0, 1.0, 100.0, 1.0,
                                  [j, kl](double v, sim::ModelParams* p) {
                                    p->coordinates[j].passive.limit_stiffness_nm_per_rad = v * kl;
                                  })));
  const double kappa = pj.limit_sharpness_per_rad;
  const double sharpest = std::max(kappa, kBroadSharpness);
  c.params.push_back(Sensed(Param("passive.sharpness_per_rad", "1/rad", kappa, 2.0, sharpest, kappa,
                                  [j](double v, sim::ModelParams* p) {
                                    p->coordinates[j].passive.limit_sharpness_per_rad = v;
                                  })));
  // Probe 1: a broad extra nonlinearity (κ = 5/rad, K_L × 5), felt across the range of motion
  // rather than only at its ends (with the wrist within ±25° a κ = 8/rad limit torque is
  // e^{−8·0.95} ≈ 5e-4 of K_L/κ); probe 2: the nominal shape made broader. The start takes probe
  // 1's shape when its coefficient is positive (the torque is linear in K_L at a fixed κ), else
  // the linear map.
  Eigen::VectorXd broad = Starts(c.params);
  broad << 5.0, kBroadSharpness;
  c.probes = {broad, ProbeAt(c.params, 1, 0.7 * kappa)};
  c.one_sided = {true, true};
  const std::vector<ModelParameter> params = c.params;
  c.start_from_step = [params, kappa](const Eigen::VectorXd& theta) {
    Eigen::VectorXd x(2);
    if (theta(0) > 0.2) {
      x << 1.0 + 4.0 * theta(0), kBroadSharpness;
    } else {
      x << 1.0 + 4.0 * theta(0), kappa - 0.3 * kappa * theta(1);
    }
    for (int k = 0; k < 2; ++k) x(k) = std::clamp(x(k), params[k].lower, params[k].upper);
    return x;
  };
  return c;
}

}  // namespace

Mechanism PassiveStiffnessNonlinearMechanism() {
  Mechanism m;
  m.id = "passive_stiffness_nonlinear";
  m.description = "nonlinear passive joint stiffness";
  m.candidates = [](const sim::ModelParams& rig, const LibraryContext& ctx) {
    std::vector<Candidate> out;
    for (int j : OutputJoints(ctx)) out.push_back(PassiveAt(rig, j));
    return out;
  };
  m.plant = [](const PlantContext& ctx, sim::ModelParams* truth, sim::SensorSuite*,
               std::vector<NamedValue>* planted) {
    const std::string id = "passive_stiffness_nonlinear";
    PlantViaCandidate(id, "passive.limit_scale", 1.0 + 20.0 * ctx.scale, ctx.library, truth,
                      planted);
    PlantViaCandidate(id, "passive.sharpness_per_rad", 5.0, ctx.library, truth, planted);
  };
  m.evidence = PostureEvidence;
  m.mimics_joint_person = true;  // a stiffening passive curve: k and k₃ to first order
  return m;
}

}  // namespace fesim::diagnosis
