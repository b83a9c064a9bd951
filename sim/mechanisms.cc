#include "sim/mechanisms.h"

#include <cmath>

#include "muscles/activation.h"

namespace fesim::sim {
namespace {
constexpr double kTwoPi = 6.283185307179586476925;
constexpr double kReflexRampSmoothingPerS = 0.05;  // ε of the stretch reflex's ramp (header)
}  // namespace

double FitnessDerivative(const FatigueParams& p, double a, double fitness) {
  return (p.min_fitness - fitness) * a / p.fatigue_time_s +
         (1.0 - fitness) * (1.0 - a) / p.recovery_time_s;
}

double PotentiationDerivative(const PotentiationParams& p, double a, double state) {
  return a * (1.0 - state) / p.rise_time_s - state / p.decay_time_s;
}

StateRatePartials FitnessDerivativePartials(const FatigueParams& p, double a, double fitness) {
  return {(p.min_fitness - fitness) / p.fatigue_time_s - (1.0 - fitness) / p.recovery_time_s,
          -a / p.fatigue_time_s - (1.0 - a) / p.recovery_time_s};
}

StateRatePartials PotentiationDerivativePartials(const PotentiationParams& p, double a,
                                                 double state) {
  return {(1.0 - state) / p.rise_time_s, -a / p.rise_time_s - 1.0 / p.decay_time_s};
}

double ActiveForceGain(const MechanismParams& m, double fitness, double potentiation) {
  double gain = 1.0;
  if (m.fatigue.enabled) gain *= fitness;
  if (m.potentiation.enabled) gain *= 1.0 + m.potentiation.gain * potentiation;
  return gain;
}

double TremorTorque(const TremorParams& p, double t) {
  if (!p.enabled) return 0.0;
  const double envelope = 1.0 + p.amplitude_modulation * std::sin(kTwoPi * p.modulation_hz * t);
  const double phase = kTwoPi * (p.frequency_hz * t + 0.5 * p.frequency_drift_hz_per_s * t * t);
  return p.amplitude_nm * envelope * std::sin(phase + p.phase_rad);
}

bool HasMechanismStates(const MechanismParams& m) {
  return m.fatigue.enabled || m.potentiation.enabled || m.stretch_reflex.enabled();
}

double StretchReflexDrive(const StretchReflexParams& p, double stretch_per_s) {
  const double x = stretch_per_s - p.threshold_per_s;
  const double eps = kReflexRampSmoothingPerS;
  return p.gain * 0.5 * (x + std::sqrt(x * x + eps * eps));
}

std::array<double, 3> StretchReflexDerivative(const StretchReflexParams& p, double omega,
                                              double drive, const std::array<double, 3>& s) {
  const auto act = muscles::ActivationDerivative(omega, s[0], {s[1], s[2]});
  return {(drive - s[0]) / p.loop_delay_s, act.a, act.a_dot};
}

double ReflexTorque(double gain, double threshold, double qdot, double direction_bias) {
  const double excess = std::abs(qdot) - threshold;
  if (gain <= 0.0 || excess <= 0.0) return 0.0;
  const double g = gain * (qdot > 0.0 ? 1.0 - direction_bias : 1.0 + direction_bias);
  return -g * excess * (qdot > 0.0 ? 1.0 : -1.0);
}

}  // namespace fesim::sim
