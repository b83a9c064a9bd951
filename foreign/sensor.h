// The hand tracker of the foreign simulator: joint angles sampled at a fixed rate with additive
// Gaussian noise, NaN bursts where the tracker loses the hand, and time stamps written rounded.
//
// Dropouts are a two-state Markov chain over samples: from "tracking" a burst starts with
// probability α, from "lost" the tracker recovers with probability β = 1/L (burst lengths are
// geometric with mean L = dropout_mean_samples). With α = p β/(1 − p) the stationary fraction of
// lost samples is α/(α + β) = p = dropout_probability (exact while α ≤ 1, i.e.
// p ≤ 1/(1 + β); α is clipped to 1 beyond). The chain starts in its stationary law.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

namespace fesim::foreign {

struct SensorSpec {
  double rate_hz = 60;                ///< sample rate, Hz, in (0, 10000].
  double noise_std_rad = 0.01;        ///< σ of the additive noise, rad, in [0, 1].
  double dropout_probability = 0.02;  ///< p, fraction of lost samples, in [0, 0.9].
  double dropout_mean_samples = 4;    ///< L, mean burst length, samples, in [1, 10000].
  int time_decimals = 4;              ///< digits kept in the written time, in [0, 9], with
                                      ///< 10^−decimals < 1/rate_hz.
};

/// Throws std::invalid_argument naming the field and its range.
void ValidateSensorSpec(const SensorSpec& spec);

/// k / rate_hz for k = 0, 1, … while ≤ duration_s (+1e-9 s), s.
std::vector<double> SampleTimes(const SensorSpec& spec, double duration_s);

/// t rounded to `decimals` digits (half away from zero), s.
double RoundTime(double t_s, int decimals);

/// The dropout mask of n samples (true = lost) from the Markov chain of the file comment.
std::vector<bool> DropoutMask(std::size_t n, double probability, double mean_samples,
                              std::mt19937_64& rng);

/// One noisy reading: value + σ·N(0, 1).
double NoisyReading(double value, double noise_std, std::mt19937_64& rng);

}  // namespace fesim::foreign
