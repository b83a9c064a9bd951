#include "sim/passive_joint.h"

#include <algorithm>
#include <cmath>

#include "sim/mechanisms.h"

namespace fesim::sim {

double PassiveElasticTorque(const PassiveJointParams& p, double q) {
  const double d = p.rest_angle_rad - q;
  double tau = p.stiffness_nm_per_rad * d + p.quadratic_stiffness_nm_per_rad2 * d * d +
               p.cubic_stiffness_nm_per_rad3 * d * d * d;
  if (p.limit_stiffness_nm_per_rad > 0.0) {
    const double kappa = p.limit_sharpness_per_rad;
    tau += p.limit_stiffness_nm_per_rad / kappa *
           (std::exp(-kappa * (q - p.min_angle_rad)) - std::exp(-kappa * (p.max_angle_rad - q)));
  }
  return tau;
}

double PassiveDissipativeTorque(const PassiveJointParams& p, double qdot) {
  double tau = -p.damping_nms_per_rad * qdot;
  const double fs = std::max(p.static_friction_nm, p.coulomb_friction_nm);
  if (fs > 0.0) {
    const double vs = qdot / p.stribeck_velocity_rad_s;
    const double level = p.coulomb_friction_nm + (fs - p.coulomb_friction_nm) * std::exp(-vs * vs);
    tau -= level * std::tanh(qdot / p.coulomb_velocity_rad_s);
  }
  return tau + ReflexTorque(p.reflex_gain_nms_per_rad, p.reflex_threshold_rad_s, qdot,
                            p.reflex_direction_bias);
}

double PassiveJointTorque(const PassiveJointParams& p, double q, double qdot) {
  return PassiveElasticTorque(p, q) + PassiveDissipativeTorque(p, qdot);
}

double PassiveJointPotential(const PassiveJointParams& p, double q) {
  const double dq = q - p.rest_angle_rad;
  double v = 0.5 * p.stiffness_nm_per_rad * dq * dq -
             p.quadratic_stiffness_nm_per_rad2 * dq * dq * dq / 3.0 +
             0.25 * p.cubic_stiffness_nm_per_rad3 * dq * dq * dq * dq;
  if (p.limit_stiffness_nm_per_rad > 0.0) {
    const double kappa = p.limit_sharpness_per_rad;
    v += p.limit_stiffness_nm_per_rad / (kappa * kappa) *
         (std::exp(-kappa * (q - p.min_angle_rad)) + std::exp(-kappa * (p.max_angle_rad - q)));
  }
  return v;
}

}  // namespace fesim::sim
