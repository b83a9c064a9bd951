// Tests of foreign/random.h: ranges, moments, determinism and independent derived seeds.
#include "foreign/random.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>

namespace fesim::foreign {
namespace {

constexpr int kDraws = 200000;
constexpr double kMomentTol = 0.01;  // |sample moment − exact| for 2·10⁵ draws (≈ 4σ)

TEST(ForeignRandom, UniformIsInsideTheOpenIntervalWithMeanAndVarianceOfU01) {
  std::mt19937_64 rng(7);
  double sum = 0.0, sum2 = 0.0;
  for (int i = 0; i < kDraws; ++i) {
    const double u = Uniform01(rng);
    ASSERT_GT(u, 0.0);
    ASSERT_LT(u, 1.0);
    sum += u;
    sum2 += u * u;
  }
  const double mean = sum / kDraws;
  EXPECT_NEAR(mean, 0.5, kMomentTol);
  EXPECT_NEAR(sum2 / kDraws - mean * mean, 1.0 / 12.0, kMomentTol);
}

TEST(ForeignRandom, UniformInMapsToTheRange) {
  std::mt19937_64 rng(1);
  for (int i = 0; i < 1000; ++i) {
    const double u = UniformIn(rng, -2.0, 3.0);
    ASSERT_GE(u, -2.0);
    ASSERT_LT(u, 3.0);
  }
  EXPECT_EQ(UniformIn(rng, 4.0, 4.0), 4.0);
}

TEST(ForeignRandom, NormalHasZeroMeanUnitVarianceAndSymmetricTails) {
  std::mt19937_64 rng(11);
  double sum = 0.0, sum2 = 0.0, sum4 = 0.0;
  for (int i = 0; i < kDraws; ++i) {
    const double z = StandardNormal(rng);
    sum += z;
    sum2 += z * z;
    sum4 += z * z * z * z;
  }
  EXPECT_NEAR(sum / kDraws, 0.0, kMomentTol);
  EXPECT_NEAR(sum2 / kDraws, 1.0, 2 * kMomentTol);
  EXPECT_NEAR(sum4 / kDraws, 3.0, 0.05);  // kurtosis of the normal
}

TEST(ForeignRandom, SignIsBalanced) {
  std::mt19937_64 rng(3);
  int plus = 0;
  for (int i = 0; i < kDraws; ++i) {
    const double s = RandomSign(rng);
    ASSERT_TRUE(s == 1.0 || s == -1.0);
    plus += s > 0 ? 1 : 0;
  }
  EXPECT_NEAR(static_cast<double>(plus) / kDraws, 0.5, kMomentTol);
}

TEST(ForeignRandom, SameSeedSameStreamOnEveryCall) {
  std::mt19937_64 a(42), b(42);
  for (int i = 0; i < 100; ++i) ASSERT_EQ(StandardNormal(a), StandardNormal(b));
  // The raw engine output is fixed by the standard: the 10000th draw of the default seed.
  std::mt19937_64 ref;
  ref.discard(9999);
  EXPECT_EQ(ref(), 9981545732273789042ull);
}

TEST(ForeignRandom, DerivedSeedsDependOnSeedAndLabel) {
  std::set<std::uint64_t> seen;
  for (std::uint64_t s = 0; s < 50; ++s) {
    for (const char* label : {"sensor", "effect:tremor", "effect:slip", ""}) {
      EXPECT_TRUE(seen.insert(DeriveSeed(s, label)).second) << s << ' ' << label;
    }
  }
  EXPECT_EQ(DeriveSeed(5, "sensor"), DeriveSeed(5, "sensor"));
}

}  // namespace
}  // namespace fesim::foreign
