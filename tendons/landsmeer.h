// Landsmeer tendon moment arms ([Hand Hammerstein] eq. 8–10; Brook et al. 1995).
//
// Sign convention:   r(q) = −∂l_MT/∂q   (m).
// A positive moment arm shortens the musculotendon unit as q increases, so tendon force f > 0
// produces the joint torque τ = r f in the +q direction (eq. 8: τ = R(y) f).
//
//   model I   (eq. 9):  r(q) = d
//   model II  (eq. 10): r(q) = d + d̃ g(q),   g(q) = (sin q − q) / (2 sin² q)
//
// The length change is the exact integral, so that power balances (−f dl/dt = τ q̇):
//   Δl(q) = l_MT(q) − l_MT(0) = −∫₀^q r = −(d q + d̃ G(q)),
//   G(q) = ∫₀^q g = ½ (q cot q − ln(1 + cos q) − 1 + ln 2).
// g and G have removable singularities at q = 0; near 0 they are evaluated by their Taylor series
// (g = −q/12 − 17q³/720 − …, G = −q²/24 − 17q⁴/2880 − …), elsewhere in closed form. Both are
// singular at q = ±π; joint angles are restricted to |q| < 0.95π.
#pragma once

namespace fesim::tendons {

/// Moment-arm model of one musculotendon unit about one joint.
struct MomentArmParams {
  enum class Model { kConstant, kLandsmeer };
  Model model = Model::kConstant;  ///< eq. (9) or eq. (10).
  double d_m = 0.0;                ///< d (r for eq. 9), m; sign as r = −∂l/∂q.
  double d_tilde_m = 0.0;          ///< d̃, m (eq. 10 only).
};

/// Largest |q| (rad) at which eq. (10) is evaluated.
inline constexpr double kMaxLandsmeerAngle = 0.95 * 3.14159265358979323846;

/// g(q) = (sin q − q)/(2 sin² q), dimensionless, |q| < π.
double LandsmeerShape(double q_rad);
/// G(q) = ∫₀^q g(s) ds, rad.
double LandsmeerShapeIntegral(double q_rad);

/// r(q), m.
double MomentArm(const MomentArmParams& p, double q_rad);
/// Δl(q) = −∫₀^q r(s) ds, m: the musculotendon length change from q = 0.
double LengthChange(const MomentArmParams& p, double q_rad);

}  // namespace fesim::tendons
