#include "sim/passive_joint.h"

#include <cmath>

namespace fesim::sim {

double PassiveElasticTorque(const PassiveJointParams& p, double q) {
  double tau = p.stiffness_nm_per_rad * (p.rest_angle_rad - q);
  if (p.limit_stiffness_nm_per_rad > 0.0) {
    const double kappa = p.limit_sharpness_per_rad;
    tau += p.limit_stiffness_nm_per_rad / kappa *
           (std::exp(-kappa * (q - p.min_angle_rad)) - std::exp(-kappa * (p.max_angle_rad - q)));
  }
  return tau;
}

double PassiveDissipativeTorque(const PassiveJointParams& p, double qdot) {
  double tau = -p.damping_nms_per_rad * qdot;
  if (p.coulomb_friction_nm > 0.0) {
    tau -= p.coulomb_friction_nm * std::tanh(qdot / p.coulomb_velocity_rad_s);
  }
  return tau;
}

double PassiveJointTorque(const PassiveJointParams& p, double q, double qdot) {
  return PassiveElasticTorque(p, q) + PassiveDissipativeTorque(p, qdot);
}

double PassiveJointPotential(const PassiveJointParams& p, double q) {
  const double dq = q - p.rest_angle_rad;
  double v = 0.5 * p.stiffness_nm_per_rad * dq * dq;
  if (p.limit_stiffness_nm_per_rad > 0.0) {
    const double kappa = p.limit_sharpness_per_rad;
    v += p.limit_stiffness_nm_per_rad / (kappa * kappa) *
         (std::exp(-kappa * (q - p.min_angle_rad)) + std::exp(-kappa * (p.max_angle_rad - q)));
  }
  return v;
}

}  // namespace fesim::sim
