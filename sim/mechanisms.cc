#include "sim/mechanisms.h"

#include <cmath>

namespace fesim::sim {
namespace {
constexpr double kTwoPi = 6.283185307179586476925;
}  // namespace

double FitnessDerivative(const FatigueParams& p, double a, double fitness) {
  return (p.min_fitness - fitness) * a / p.fatigue_time_s +
         (1.0 - fitness) * (1.0 - a) / p.recovery_time_s;
}

double PotentiationDerivative(const PotentiationParams& p, double a, double state) {
  return a * (1.0 - state) / p.rise_time_s - state / p.decay_time_s;
}

double TremorTorque(const TremorParams& p, double t) {
  if (!p.enabled) return 0.0;
  const double envelope = 1.0 + p.amplitude_modulation * std::sin(kTwoPi * p.modulation_hz * t);
  const double phase = kTwoPi * (p.frequency_hz * t + 0.5 * p.frequency_drift_hz_per_s * t * t);
  return p.amplitude_nm * envelope * std::sin(phase + p.phase_rad);
}

double ReflexTorque(double gain, double threshold, double qdot, double direction_bias) {
  const double excess = std::abs(qdot) - threshold;
  if (gain <= 0.0 || excess <= 0.0) return 0.0;
  const double g = gain * (qdot > 0.0 ? 1.0 - direction_bias : 1.0 + direction_bias);
  return -g * excess * (qdot > 0.0 ? 1.0 : -1.0);
}

}  // namespace fesim::sim
