#include "foreign/muscle.h"

#include <algorithm>
#include <cmath>

#include "foreign/check.h"

namespace fesim::foreign {

void ValidateMuscle(const MuscleParams& m, const std::string& prefix) {
  for (int j = 0; j < kNumCrossings; ++j) {
    const MomentArmPoly& p = m.moment_arms[j];
    const std::string f = prefix + ".moment_arms." + kCrossingNames[j] + ".";
    const double lim = p.crosses ? 0.05 : 0.0;
    CheckRange(p.r0_m, -lim, lim, f + "r0_m");
    CheckRange(p.r1_m_per_rad, -lim, lim, f + "r1_m_per_rad");
    CheckRange(p.r2_m_per_rad2, -lim, lim, f + "r2_m_per_rad2");
  }
  const RecruitmentParams& r = m.recruitment;
  CheckRange(r.threshold_us, 0.0, 999.0, prefix + ".recruitment.threshold_us");
  CheckAbove(r.saturation_us, r.threshold_us, 2000.0, prefix + ".recruitment.saturation_us");
  CheckAbove(r.max_fraction, 0.0, 1.0, prefix + ".recruitment.max_fraction");
  const ActivationParams& a = m.activation;
  CheckAbove(a.coupling_activation_tau_s, 0.0, 2.0,
             prefix + ".activation.coupling_activation_tau_s");
  CheckAbove(a.coupling_deactivation_tau_s, 0.0, 2.0,
             prefix + ".activation.coupling_deactivation_tau_s");
  CheckAbove(a.force_activation_tau_s, 0.0, 2.0, prefix + ".activation.force_activation_tau_s");
  CheckAbove(a.force_deactivation_tau_s, 0.0, 2.0, prefix + ".activation.force_deactivation_tau_s");
  const ContractionParams& c = m.contraction;
  const std::string f = prefix + ".contraction.";
  CheckRange(c.max_force_n, 0.0, 1e4, f + "max_force_n");
  CheckAbove(c.optimal_fibre_length_m, 0.0, 0.5, f + "optimal_fibre_length_m");
  CheckRange(c.tendon_slack_length_m, 0.0, 1.0, f + "tendon_slack_length_m");
  CheckAbove(c.mt_length_at_zero_m, c.tendon_slack_length_m, 2.0, f + "mt_length_at_zero_m");
  CheckAbove(c.fl_width, 0.1, 2.0, f + "fl_width");
  CheckAbove(c.max_velocity_lopt_per_s, 0.0, 100.0, f + "max_velocity_lopt_per_s");
  CheckAbove(c.hill_curvature, 0.05, 2.0, f + "hill_curvature");
  CheckAbove(c.eccentric_plateau, 1.0, 3.0, f + "eccentric_plateau");
  CheckRange(c.passive_coefficient, 0.0, 100.0, f + "passive_coefficient");
}

double MomentArm(const MomentArmPoly& p, double angle_rad) {
  return p.r0_m + angle_rad * (p.r1_m_per_rad + angle_rad * p.r2_m_per_rad2);
}

double MomentArmIntegral(const MomentArmPoly& p, double angle_rad) {
  const double t = angle_rad;
  return t * (p.r0_m + t * (p.r1_m_per_rad / 2.0 + t * p.r2_m_per_rad2 / 3.0));
}

std::array<double, kNumCrossings> CrossingAngles(const Eigen::Vector3d& q, double dip_pip_ratio) {
  return {q[0], q[1], q[2], dip_pip_ratio * q[2]};
}

double MusculotendonLength(const MuscleParams& muscle, const Eigen::Vector3d& q,
                           double dip_pip_ratio) {
  const auto theta = CrossingAngles(q, dip_pip_ratio);
  double l = muscle.contraction.mt_length_at_zero_m;
  for (int j = 0; j < kNumCrossings; ++j) l -= MomentArmIntegral(muscle.moment_arms[j], theta[j]);
  return l;
}

Eigen::Vector3d GeneralisedMomentArms(const MuscleParams& muscle, const Eigen::Vector3d& q,
                                      double dip_pip_ratio) {
  const auto theta = CrossingAngles(q, dip_pip_ratio);
  const auto& r = muscle.moment_arms;
  return {
      MomentArm(r[kWristCrossing], theta[0]), MomentArm(r[kMcpCrossing], theta[1]),
      MomentArm(r[kPipCrossing], theta[2]) + dip_pip_ratio * MomentArm(r[kDipCrossing], theta[3])};
}

double Recruitment(const RecruitmentParams& p, double pulse_width_us) {
  const double x =
      std::clamp((pulse_width_us - p.threshold_us) / (p.saturation_us - p.threshold_us), 0.0, 1.0);
  return p.max_fraction * x * x * (3.0 - 2.0 * x);
}

double FirstOrderRate(double input, double state, double tau_up_s, double tau_down_s) {
  return (input - state) / (input > state ? tau_up_s : tau_down_s);
}

double ForceLength(double norm_length, double width) {
  const double z = (norm_length - 1.0) / width;
  return std::max(0.0, 1.0 - z * z);
}

double ForceVelocity(double norm_velocity, double curvature, double eccentric_plateau) {
  const double k = curvature;
  if (norm_velocity <= 0.0) {
    const double x = -norm_velocity;
    return std::max(0.0, (1.0 - x) / (1.0 + x / k));
  }
  const double beta = (eccentric_plateau - 1.0) * k / (1.0 + k);
  return eccentric_plateau - (eccentric_plateau - 1.0) * beta / (beta + norm_velocity);
}

double ForceVelocityMaxSlope(double curvature) { return (1.0 + curvature) / curvature; }

double PassiveFibreForce(double norm_length, double coefficient) {
  const double s = norm_length - 1.0;
  return s > 0.0 ? coefficient * s * s : 0.0;
}

double MuscleForce(const ContractionParams& p, double activation, double capacity,
                   double fibre_length_m, double fibre_velocity_m_s) {
  const double lt = fibre_length_m / p.optimal_fibre_length_m;
  const double vt = fibre_velocity_m_s / (p.max_velocity_lopt_per_s * p.optimal_fibre_length_m);
  const double active = capacity * activation * ForceLength(lt, p.fl_width) *
                        ForceVelocity(vt, p.hill_curvature, p.eccentric_plateau);
  return p.max_force_n * (active + PassiveFibreForce(lt, p.passive_coefficient));
}

double PassiveFibreEnergy(const ContractionParams& p, double fibre_length_m) {
  const double s = fibre_length_m / p.optimal_fibre_length_m - 1.0;
  return s > 0.0
             ? p.max_force_n * p.passive_coefficient * p.optimal_fibre_length_m * s * s * s / 3.0
             : 0.0;
}

}  // namespace fesim::foreign
