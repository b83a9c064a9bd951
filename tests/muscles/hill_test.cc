#include "muscles/hill.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fesim::muscles {
namespace {

constexpr double kTol = 1e-12;
constexpr double kFdStep = 1e-7;
constexpr double kFdTol = 1e-6;

TEST(Hill, CurveKeyPoints) {
  EXPECT_NEAR(ActiveForceLength(1.0), 1.0, kTol);
  EXPECT_LT(ActiveForceLength(0.5), 0.6);
  EXPECT_NEAR(ActiveForceLength(1.3), ActiveForceLength(0.7), kTol);  // symmetric Gaussian
  EXPECT_NEAR(ForceVelocity(0.0), 1.0, kTol);
  EXPECT_NEAR(ForceVelocity(-1.0), 0.0, kTol);
  EXPECT_GT(ForceVelocity(0.5), 1.0);
  EXPECT_LT(ForceVelocity(100.0), 1.8);
  EXPECT_EQ(PassiveForceLength(0.9), 0.0);
  EXPECT_NEAR(PassiveForceLength(1.6), 1.0, kTol);  // F_max at strain ε₀ = 0.6 (Thelen 2003)
}

TEST(Hill, ForceVelocityIsC1AtZero) {
  const double left = (ForceVelocity(0.0) - ForceVelocity(-kFdStep)) / kFdStep;
  const double right = (ForceVelocity(kFdStep) - ForceVelocity(0.0)) / kFdStep;
  EXPECT_NEAR(left, 5.0, kFdTol * 10);  // 1 + 1/A_f
  EXPECT_NEAR(right, left, kFdTol * 10);
}

TEST(Hill, FibreVelocityIsDerivativeOfFibreLength) {
  HillParams p;
  p.pennation_at_optimal_rad = 0.3;
  const double l_mt = OptimalMusculotendonLength(p) + 0.01;
  const double v_mt = 0.05;
  const auto f = FibreFromMusculotendon(p, l_mt, v_mt);
  const double dl = (FibreFromMusculotendon(p, l_mt + kFdStep, 0).length_m -
                     FibreFromMusculotendon(p, l_mt - kFdStep, 0).length_m) /
                    (2 * kFdStep);
  EXPECT_NEAR(f.velocity_m_s, dl * v_mt, kFdTol);
  EXPECT_FALSE(f.clamped);
}

TEST(Hill, IsometricForceAtOptimalLength) {
  HillParams p;
  p.pennation_at_optimal_rad = 0.2;
  const auto f = FibreFromMusculotendon(p, OptimalMusculotendonLength(p), 0.0);
  EXPECT_NEAR(f.length_m, p.optimal_fibre_length_m, kTol);
  EXPECT_NEAR(HillTendonForce(p, 1.0, f), p.max_isometric_force_n * std::cos(0.2), 1e-9);
  EXPECT_NEAR(HillTendonForce(p, 0.0, f), 0.0, kTol);
}

TEST(Hill, TooShortMusculotendonIsClamped) {
  HillParams p;
  const auto f = FibreFromMusculotendon(p, p.tendon_slack_length_m - 0.01, -0.1);
  EXPECT_TRUE(f.clamped);
  EXPECT_GT(f.length_m, 0.0);
}

}  // namespace
}  // namespace fesim::muscles
