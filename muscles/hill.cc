#include "muscles/hill.h"

#include <algorithm>
#include <cmath>

namespace fesim::muscles {
namespace {

constexpr double kGammaL = 0.45;    // Thelen 2003 shape factor of f_L
constexpr double kPassiveK = 4.0;   // Thelen 2003 k_PE
constexpr double kPassiveE0 = 0.6;  // Thelen 2003 ε₀ (passive strain at F_max)
constexpr double kAf = 0.25;        // Hill hyperbola shape A_f
constexpr double kFEcc = 1.8;       // eccentric force plateau
constexpr double kEccC = (kFEcc - 1.0) / (1.0 + 1.0 / kAf);  // C¹ continuity at ṽ = 0
constexpr double kMinProjection = 0.05;                      // minimum (l_MT − l_ts) / l_opt

}  // namespace

double ActiveForceLength(double l) { return std::exp(-(l - 1.0) * (l - 1.0) / kGammaL); }

double PassiveForceLength(double l) {
  if (l <= 1.0) return 0.0;
  return (std::exp(kPassiveK * (l - 1.0) / kPassiveE0) - 1.0) / (std::exp(kPassiveK) - 1.0);
}

double ForceVelocity(double v) {
  if (v <= -1.0) return 0.0;
  if (v <= 0.0) return (1.0 + v) / (1.0 - v / kAf);
  return (kFEcc * v + kEccC) / (v + kEccC);
}

FibreKinematics FibreFromMusculotendon(const HillParams& p, double l_mt_m, double v_mt_m_s) {
  FibreKinematics f;
  const double height = p.optimal_fibre_length_m * std::sin(p.pennation_at_optimal_rad);
  double x = l_mt_m - p.tendon_slack_length_m;
  const double x_min = kMinProjection * p.optimal_fibre_length_m;
  if (x < x_min) {
    x = x_min;
    f.clamped = true;
  }
  f.length_m = std::sqrt(x * x + height * height);
  f.cos_pennation = x / f.length_m;
  f.velocity_m_s = f.clamped ? 0.0 : v_mt_m_s * f.cos_pennation;
  return f;
}

double HillTendonForce(const HillParams& p, double activation, const FibreKinematics& fibre,
                       double active_gain) {
  const double l = fibre.length_m / p.optimal_fibre_length_m;
  const double v = fibre.velocity_m_s / (p.max_contraction_velocity * p.optimal_fibre_length_m);
  const double a = std::clamp(activation, 0.0, 1.0);
  const double fibre_force =
      p.max_isometric_force_n *
      (active_gain * a * ActiveForceLength(l) * ForceVelocity(v) + PassiveForceLength(l));
  return fibre_force * fibre.cos_pennation;
}

double OptimalMusculotendonLength(const HillParams& p) {
  return p.tendon_slack_length_m + p.optimal_fibre_length_m * std::cos(p.pennation_at_optimal_rad);
}

}  // namespace fesim::muscles
