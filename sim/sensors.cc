#include "sim/sensors.h"

#include <algorithm>
#include <cmath>

namespace fesim::sim {
namespace {
constexpr double kTimeTol = 1e-9;  // s
constexpr double kTwoPi = 6.283185307179586476925;
}  // namespace

double GaussianNoise::Uniform() {
  // 53 random bits → (0, 1), never 0 so that log() is finite.
  return (static_cast<double>(engine_() >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}

double GaussianNoise::Sample(double std_dev) {
  if (has_spare_) {
    has_spare_ = false;
    return std_dev * spare_;
  }
  const double r = std::sqrt(-2.0 * std::log(Uniform()));
  const double theta = kTwoPi * Uniform();
  spare_ = r * std::sin(theta);
  has_spare_ = true;
  return std_dev * r * std::cos(theta);
}

std::vector<double> SampleTimes(double rate_hz, double duration_s) {
  std::vector<double> t;
  const long n = static_cast<long>(std::floor(duration_s * rate_hz + 1e-6));
  t.reserve(static_cast<std::size_t>(n) + 1);
  for (long k = 0; k <= n; ++k) t.push_back(static_cast<double>(k) / rate_hz);
  return t;
}

std::vector<double> MergeTimes(const std::vector<std::vector<double>>& grids) {
  std::vector<double> all;
  for (const auto& g : grids) all.insert(all.end(), g.begin(), g.end());
  std::sort(all.begin(), all.end());
  std::vector<double> out;
  for (double t : all) {
    if (out.empty() || t - out.back() > kTimeTol) out.push_back(t);
  }
  return out;
}

std::vector<bool> OnGrid(const std::vector<double>& merged, const std::vector<double>& grid) {
  std::vector<bool> on(merged.size(), false);
  std::size_t j = 0;
  for (std::size_t i = 0; i < merged.size(); ++i) {
    while (j < grid.size() && grid[j] < merged[i] - kTimeTol) ++j;
    on[i] = j < grid.size() && std::abs(grid[j] - merged[i]) <= kTimeTol;
  }
  return on;
}

std::uint64_t DeriveSeed(std::uint64_t seed, std::uint64_t stream) {
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ull * (stream + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

}  // namespace fesim::sim
