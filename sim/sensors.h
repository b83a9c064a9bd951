// Sensor models: sample grids and seeded measurement noise (PRODUCT.md "Sensors").
// Each sensor samples at its own rate; a trial's time column is the union of the sensors' grids
// and a column is NaN at the rows where its sensor did not sample.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

namespace fesim::sim {

/// Zero-mean Gaussian noise from a seeded 64-bit Mersenne Twister (whose output sequence the C++
/// standard fixes) through the Box–Muller transform, so the same seed gives the same numbers on
/// every platform (std::normal_distribution is implementation-defined).
class GaussianNoise {
 public:
  explicit GaussianNoise(std::uint64_t seed) : engine_(seed) {}
  /// One sample of N(0, std²).
  double Sample(double std_dev);

 private:
  double Uniform();  // (0, 1)
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

/// t_k = k / rate_hz for k = 0 … while t_k ≤ duration_s (+1e-9 s).
std::vector<double> SampleTimes(double rate_hz, double duration_s);

/// Sorted union of sample grids; times closer than 1e-9 s are merged.
std::vector<double> MergeTimes(const std::vector<std::vector<double>>& grids);

/// Indicator of each merged time belonging to `grid` (same 1e-9 s tolerance).
std::vector<bool> OnGrid(const std::vector<double>& merged, const std::vector<double>& grid);

/// A stream seed derived from a trial seed and a stream id (SplitMix64), so sensors draw
/// independent reproducible noise.
std::uint64_t DeriveSeed(std::uint64_t seed, std::uint64_t stream);

}  // namespace fesim::sim
