#include "sim/arm_support.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fesim::sim {
namespace {

constexpr double kFdStep = 1e-7;
constexpr double kFdTol = 1e-5;

TEST(ArmSupport, SlackBandPullsOnlyWhenStretched) {
  BandParams b;
  b.anchor_in_ground_m = {0.0, 2.0, 0.0};
  b.stiffness_n_per_m = 200.0;
  b.slack_length_m = 0.5;
  const Vec3d slack = BandForce(b, {0.0, 1.6, 0.0});  // 0.4 m < slack
  EXPECT_EQ(slack[0], 0.0);
  EXPECT_EQ(slack[1], 0.0);
  EXPECT_EQ(BandPotential(b, {0.0, 1.6, 0.0}), 0.0);
  const Vec3d f = BandForce(b, {0.0, 1.2, 0.0});  // 0.8 m: stretched 0.3 m, pulls up
  EXPECT_NEAR(f[1], 60.0, 1e-12);
  EXPECT_NEAR(f[0], 0.0, 1e-12);
}

TEST(ArmSupport, ForceIsMinusPotentialGradient) {
  BandParams b;
  b.anchor_in_ground_m = {0.1, 1.9, 0.3};
  b.stiffness_n_per_m = 150.0;
  b.slack_length_m = 0.3;
  const Vec3d p = {0.3, 1.2, 0.25};
  const Vec3d f = BandForce(b, p);
  for (int i = 0; i < 3; ++i) {
    Vec3d a = p, c = p;
    a[i] += kFdStep;
    c[i] -= kFdStep;
    EXPECT_NEAR(f[i], -(BandPotential(b, a) - BandPotential(b, c)) / (2 * kFdStep), kFdTol);
  }
}

}  // namespace
}  // namespace fesim::sim
