#include "sim/sensors.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fesim::sim {
namespace {

constexpr int kSamples = 200000;
constexpr double kStatTol = 0.01;  // ≈ 4.5 standard errors of the sample std at n = 2e5

TEST(Sensors, NoiseIsSeededAndHasTheRequestedSpread) {
  GaussianNoise a(42), b(42), c(43);
  double sum = 0, sum2 = 0;
  bool differs = false;
  for (int i = 0; i < kSamples; ++i) {
    const double x = a.Sample(2.0);
    EXPECT_EQ(x, b.Sample(2.0));
    differs = differs || x != c.Sample(2.0);
    sum += x;
    sum2 += x * x;
  }
  EXPECT_TRUE(differs);
  const double mean = sum / kSamples;
  EXPECT_NEAR(mean, 0.0, kStatTol * 2);
  EXPECT_NEAR(std::sqrt(sum2 / kSamples - mean * mean), 2.0, kStatTol * 2);
  EXPECT_NE(DeriveSeed(1, 1), DeriveSeed(1, 2));
}

TEST(Sensors, GridsMergeAndFlag) {
  const auto a = SampleTimes(60.0, 1.0);
  const auto b = SampleTimes(100.0, 1.0);
  EXPECT_EQ(a.size(), 61u);
  EXPECT_EQ(b.size(), 101u);
  const auto m = MergeTimes({a, b});
  // Common times are multiples of 1/20 s: 21 of them.
  EXPECT_EQ(m.size(), 61u + 101u - 21u);
  const auto on = OnGrid(m, a);
  int n = 0;
  for (bool x : on) n += x;
  EXPECT_EQ(n, 61);
}

}  // namespace
}  // namespace fesim::sim
