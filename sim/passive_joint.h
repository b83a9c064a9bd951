// Passive joint moments ([Hand Hammerstein] eq. 14; values [Schearer 2014] Table I).
//
//   τ_p(q, q̇) = k (q₀ − q) + k₂ (q₀ − q)² + k₃ (q₀ − q)³ − b q̇ + τ_lim(q) − τ_c(q̇)
//   τ_lim(q)  = (K_L/κ) (e^{−κ (q − q_min)} − e^{−κ (q_max − q)})       (exponential range limits,
//               Riener & Edrich 1999 form; K_L = stiffness at the limit, κ = sharpness)
//   V(q)      = ½ k (q − q₀)² − ⅓ k₂ (q − q₀)³ + ¼ k₃ (q − q₀)⁴
//               + (K_L/κ²)(e^{−κ (q − q_min)} + e^{−κ (q_max − q)}),   τ = −∂V/∂q
//   k₂ (q₀ − q)²: a person's flexion/extension asymmetry of the passive curve (k₂ > 0: stiffer
//               on the extension side q < q₀, softer on the flexion side; the second-order term
//               of a double-exponential passive moment with unequal sides, e.g. Amankwah, Triolo
//               & Kirsch 2004); 0 by default
//   k₃ (q₀ − q)³: a person's mild mid-range stiffening (or softening, k₃ < 0) of the passive
//               curve (the person calibration of diagnosis/person.h); 0 by default
//   τ_c(q̇)   = (F_c + (F_s − F_c) e^{−(q̇/v_s)²}) tanh(q̇ / v_c)   (optional Coulomb friction with
//               Stribeck stiction, [Spagnol 2013], smoothed over v_c; F_s = 0 means F_s = F_c)
//   plus the stretch reflex of mechanisms.h (velocity-dependent resistance above v_th).
// Units: q rad, q̇ rad/s, τ N·m, V J. Sign: positive τ accelerates q positively.
#pragma once

namespace fesim::sim {

/// Passive properties of one coordinate.
struct PassiveJointParams {
  double stiffness_nm_per_rad = 0.0;  ///< k, N·m/rad, ≥ 0.
  /// k₂, N·m/rad² (the stiffness k − 2k₂(q − q₀) + 3k₃(q − q₀)² should stay > 0 in range).
  double quadratic_stiffness_nm_per_rad2 = 0.0;
  double cubic_stiffness_nm_per_rad3 = 0.0;  ///< k₃, N·m/rad³ (k + 3k₃(q − q₀)² should stay > 0).
  double damping_nms_per_rad = 0.0;         ///< b, N·m·s/rad, ≥ 0.
  double rest_angle_rad = 0.0;              ///< q₀, rad.
  double min_angle_rad = -1.5;              ///< q_min, rad.
  double max_angle_rad = 1.5;               ///< q_max, rad, > q_min.
  double limit_stiffness_nm_per_rad = 0.0;  ///< K_L, N·m/rad, ≥ 0 (0 disables the limits).
  double limit_sharpness_per_rad = 20.0;    ///< κ, 1/rad, > 0.
  double coulomb_friction_nm = 0.0;         ///< F_c, N·m, ≥ 0.
  double coulomb_velocity_rad_s = 0.01;     ///< v_c, rad/s, > 0 (smoothing width).
  double static_friction_nm = 0.0;          ///< F_s, N·m; stiction when F_s > F_c (0 = none).
  double stribeck_velocity_rad_s = 0.05;    ///< v_s, rad/s, > 0.
  double reflex_gain_nms_per_rad = 0.0;     ///< G of the stretch reflex, N·m·s/rad, ≥ 0.
  double reflex_threshold_rad_s = 0.5;      ///< v_th, rad/s, ≥ 0.
  /// β of the stretch reflex, [−1, 1]: its gain is G (1 + β) on extension, G (1 − β) on flexion.
  double reflex_direction_bias = 0.0;
};

/// Conservative part: −∂V/∂q (spring + limits), N·m.
double PassiveElasticTorque(const PassiveJointParams& p, double q_rad);
/// Dissipative part: −b q̇ − τ_c(q̇), N·m.
double PassiveDissipativeTorque(const PassiveJointParams& p, double qdot_rad_s);
/// Total passive torque, N·m.
double PassiveJointTorque(const PassiveJointParams& p, double q_rad, double qdot_rad_s);
/// Potential V(q) of the conservative part, J.
double PassiveJointPotential(const PassiveJointParams& p, double q_rad);

}  // namespace fesim::sim
