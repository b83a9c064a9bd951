// Tests of foreign/sensor.h: sample times, time rounding, noise level, dropout fraction and burst
// length.
#include "foreign/sensor.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

namespace fesim::foreign {
namespace {

constexpr std::size_t kNoiseSamples = 10000;
constexpr double kNoiseStdRelTol = 0.05;  // brief: within 5 % over 10⁴ samples
constexpr std::size_t kDropoutSamples = 200000;
constexpr double kDropoutRelTol = 0.1;  // fraction of lost samples within 10 % of p

TEST(ForeignSensor, SampleTimesAreMultiplesOfThePeriodUpToTheDuration) {
  SensorSpec s;
  const auto t = SampleTimes(s, 2.0);
  ASSERT_EQ(t.size(), 121u);
  EXPECT_EQ(t.front(), 0.0);
  EXPECT_NEAR(t[7], 7.0 / 60.0, 1e-15);
  EXPECT_DOUBLE_EQ(t.back(), 2.0);
}

TEST(ForeignSensor, TimeIsRoundedToTheDecimals) {
  EXPECT_EQ(RoundTime(1.0 / 60.0, 4), 0.0167);
  EXPECT_EQ(RoundTime(0.123449, 4), 0.1234);
  EXPECT_EQ(RoundTime(2.0, 0), 2.0);
}

TEST(ForeignSensor, NoiseStandardDeviationMatchesTheSpec) {
  std::mt19937_64 rng(12);
  const double sigma = 0.01;
  double sum = 0.0, sum2 = 0.0;
  for (std::size_t i = 0; i < kNoiseSamples; ++i) {
    const double e = NoisyReading(0.3, sigma, rng) - 0.3;
    sum += e;
    sum2 += e * e;
  }
  const double mean = sum / kNoiseSamples;
  const double std = std::sqrt(sum2 / kNoiseSamples - mean * mean);
  EXPECT_NEAR(std, sigma, kNoiseStdRelTol * sigma);
  EXPECT_NEAR(mean, 0.0, 4 * sigma / std::sqrt(kNoiseSamples));
}

TEST(ForeignSensor, DropoutsComeInBurstsAtTheSetProbability) {
  for (double p : {0.02, 0.1}) {
    for (double len : {1.0, 4.0, 10.0}) {
      std::mt19937_64 rng(3);
      const auto lost = DropoutMask(kDropoutSamples, p, len, rng);
      std::size_t n_lost = 0, bursts = 0;
      for (std::size_t i = 0; i < lost.size(); ++i) {
        n_lost += lost[i] ? 1 : 0;
        if (lost[i] && (i == 0 || !lost[i - 1])) ++bursts;
      }
      EXPECT_NEAR(static_cast<double>(n_lost) / kDropoutSamples, p, kDropoutRelTol * p) << len;
      EXPECT_NEAR(static_cast<double>(n_lost) / bursts, len, kDropoutRelTol * len) << p;
    }
  }
  std::mt19937_64 rng(1);
  const auto none = DropoutMask(1000, 0.0, 4.0, rng);
  for (bool b : none) EXPECT_FALSE(b);
}

TEST(ForeignSensor, ValidationNamesTheField) {
  SensorSpec s;
  s.time_decimals = 1;  // 0.1 s ≥ 1/60 s: consecutive stamps would collide
  EXPECT_THROW(ValidateSensorSpec(s), std::invalid_argument);
  s = SensorSpec{};
  s.dropout_probability = 0.95;
  try {
    ValidateSensorSpec(s);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("sensor.dropout_probability"), std::string::npos);
  }
}

}  // namespace
}  // namespace fesim::foreign
