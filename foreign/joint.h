// Passive joint moments of the foreign simulator: a double-exponential elastic moment about a rest
// angle plus linear viscous damping, per generalised coordinate (wrist, MCP, PIP; the DIP's
// passive moment is lumped into the PIP's through the coupling of foreign/body.h).
//
// Form (after the double-exponential passive moment of Amankwah, Triolo & Kirsch 2004, J Rehabil
// Res Dev 41(1), reparameterised so that each term vanishes at the rest angle and its slope there
// is a stiffness): with d = q − q_r,
//   τ_el(q) = −(k_f/κ_f)(e^{κ_f d} − 1) + (k_e/κ_e)(e^{−κ_e d} − 1),       N·m,
//   V_el(q) = (k_f/κ_f²)(e^{κ_f d} − 1 − κ_f d) + (k_e/κ_e²)(e^{−κ_e d} − 1 + κ_e d),  J,
// so τ_el = −dV_el/dq, τ_el(q_r) = 0 and dτ_el/dq(q_r) = −(k_f + k_e). The first term resists
// flexion (grows exponentially for q > q_r), the second resists extension. Damping τ_b = −b q̇.
// Sign: a positive moment drives flexion.
#pragma once

namespace fesim::foreign {

struct JointParams {
  double rest_angle_rad = 0.0;                  ///< q_r, rad, in [−1.5, 1.5].
  double flexion_stiffness_nm_per_rad = 0.0;    ///< k_f, N·m/rad, ≥ 0.
  double flexion_stiffening_per_rad = 1.0;      ///< κ_f, 1/rad, in (0, 20].
  double extension_stiffness_nm_per_rad = 0.0;  ///< k_e, N·m/rad, ≥ 0.
  double extension_stiffening_per_rad = 1.0;    ///< κ_e, 1/rad, in (0, 20].
  double damping_nm_s_per_rad = 0.0;            ///< b, N·m·s/rad, ≥ 0.
};

/// Throws std::invalid_argument naming `prefix`.field and the allowed range.
void ValidateJoint(const JointParams& joint, const char* prefix);

/// τ_el(q), N·m.
double ElasticMoment(const JointParams& joint, double q_rad);

/// −dτ_el/dq at q, N·m/rad (> 0 for a stiffness).
double ElasticStiffness(const JointParams& joint, double q_rad);

/// V_el(q), J (≥ 0, zero at the rest angle).
double ElasticEnergy(const JointParams& joint, double q_rad);

/// τ_b = −b q̇, N·m.
double DampingMoment(const JointParams& joint, double qd_rad_s);

}  // namespace fesim::foreign
