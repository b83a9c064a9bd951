#include "foreign/sensor.h"

#include <algorithm>
#include <cmath>

#include "foreign/check.h"
#include "foreign/random.h"

namespace fesim::foreign {

void ValidateSensorSpec(const SensorSpec& s) {
  CheckAbove(s.rate_hz, 0.0, 10000.0, "sensor.rate_hz");
  CheckRange(s.noise_std_rad, 0.0, 1.0, "sensor.noise_std_rad");
  CheckRange(s.dropout_probability, 0.0, 0.9, "sensor.dropout_probability");
  CheckRange(s.dropout_mean_samples, 1.0, 10000.0, "sensor.dropout_mean_samples");
  CheckRange(s.time_decimals, 0, 9, "sensor.time_decimals");
  if (std::pow(10.0, -s.time_decimals) >= 1.0 / s.rate_hz) {
    throw std::invalid_argument(
        "foreign: sensor.time_decimals too few for sensor.rate_hz (need 10^-decimals < 1/rate)");
  }
}

std::vector<double> SampleTimes(const SensorSpec& spec, double duration_s) {
  ValidateSensorSpec(spec);
  CheckAbove(duration_s, 0.0, 1e6, "duration_s");
  std::vector<double> t;
  for (std::size_t k = 0;; ++k) {
    const double tk = static_cast<double>(k) / spec.rate_hz;
    if (tk > duration_s + 1e-9) break;
    t.push_back(std::min(tk, duration_s));
  }
  return t;
}

double RoundTime(double t_s, int decimals) {
  const double scale = std::pow(10.0, decimals);
  return std::round(t_s * scale) / scale;
}

std::vector<bool> DropoutMask(std::size_t n, double probability, double mean_samples,
                              std::mt19937_64& rng) {
  CheckRange(probability, 0.0, 0.9, "dropout_probability");
  CheckRange(mean_samples, 1.0, 10000.0, "dropout_mean_samples");
  std::vector<bool> lost(n, false);
  const double recover = 1.0 / mean_samples;
  const double start = std::min(1.0, probability * recover / (1.0 - probability));
  bool state = Uniform01(rng) < probability;
  for (std::size_t i = 0; i < n; ++i) {
    lost[i] = state;
    const double u = Uniform01(rng);
    state = state ? !(u < recover) : (u < start);
  }
  return lost;
}

double NoisyReading(double value, double noise_std, std::mt19937_64& rng) {
  return value + noise_std * StandardNormal(rng);
}

}  // namespace fesim::foreign
