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

ActivationState ActivationFreeResponse(double omega_rad_s, double w, const ActivationState& initial,
                                       double t_s) {
  const double om = omega_rad_s;
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
