#include "muscles/recruitment.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fesim::muscles {
namespace {

constexpr double kTol = 1e-12;
constexpr double kFdStep = 1e-4;  // µs
constexpr double kFdTol = 1e-8;

TEST(Recruitment, KeyPoints) {
  const RecruitmentParams p{0.8, 0.04, 30.0};
  EXPECT_EQ(Recruitment(p, 0.0), 0.0);
  EXPECT_EQ(Recruitment(p, -50.0), 0.0);
  EXPECT_NEAR(Recruitment(p, 1e4), p.alpha, kTol);
  // Direct form of eq. (3) at a moderate point.
  const double v = 60.0;
  const double e = std::exp(p.beta_per_us * v);
  EXPECT_NEAR(Recruitment(p, v), p.alpha * (e - 1.0) / (e + p.gamma), kTol);
}

TEST(Recruitment, MonotoneWithConsistentSlope) {
  const RecruitmentParams p{1.0, 0.025, 80.0};
  double prev = 0.0;
  for (double v = 1.0; v <= 300.0; v += 1.0) {
    const double w = Recruitment(p, v);
    EXPECT_GT(w, prev);
    prev = w;
    const double fd = (Recruitment(p, v + kFdStep) - Recruitment(p, v - kFdStep)) / (2 * kFdStep);
    EXPECT_NEAR(RecruitmentSlope(p, v), fd, kFdTol);
  }
}

}  // namespace
}  // namespace fesim::muscles
