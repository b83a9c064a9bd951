#include "muscles/activation.h"

#include <cmath>

namespace fesim::muscles {

ActivationState ActivationDerivative(double omega_rad_s, double w, const ActivationState& s) {
  const double om = omega_rad_s;
  return {s.a_dot, om * om * (w - s.a) - 2.0 * om * s.a_dot};
}

ActivationState ActivationStepResponse(double omega_rad_s, double w, double t_s) {
  if (t_s <= 0.0) return {};
  const double e = std::exp(-omega_rad_s * t_s);
  return {w * (1.0 - (1.0 + omega_rad_s * t_s) * e), w * omega_rad_s * omega_rad_s * t_s * e};
}

namespace {

bool IsPositiveZero(double x) { return x == 0.0 && !std::signbit(x); }

}  // namespace

ActivationState ActivationFreeResponse(double omega_rad_s, double w, const ActivationState& initial,
                                       double t_s) {
  const double om = omega_rad_s;
  // A muscle at rest without input stays at rest: with w, a, ȧ all +0 and Ωt ≥ 0 (the exponential
  // ≤ 1) the formula below gives +0 and +0 bit for bit (Activation.FreeResponseAtRestIsRestBits);
  // an unstimulated muscle skips the exponential at every right-hand side.
  if (IsPositiveZero(w) && IsPositiveZero(initial.a) && IsPositiveZero(initial.a_dot) &&
      om * t_s >= 0.0) {
    return {0.0, 0.0};
  }
  const double e0 = initial.a - w;
  const double c = initial.a_dot + om * e0;
  const double decay = std::exp(-om * t_s);
  return {w + (e0 + c * t_s) * decay, (initial.a_dot - om * c * t_s) * decay};
}

double IntervalOmega(double omega_rad_s, double deactivation_ratio, double w,
                     const ActivationState& start) {
  return Deactivating(w, start) ? omega_rad_s * deactivation_ratio : omega_rad_s;
}

}  // namespace fesim::muscles
