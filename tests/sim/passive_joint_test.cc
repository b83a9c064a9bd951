#include "sim/passive_joint.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fesim::sim {
namespace {

constexpr double kFdStep = 1e-6;
constexpr double kFdTol = 1e-6;

PassiveJointParams Joint() {
  PassiveJointParams p;
  p.stiffness_nm_per_rad = 2.3;
  p.damping_nms_per_rad = 0.5;
  p.rest_angle_rad = 1.4;
  p.min_angle_rad = 0.0;
  p.max_angle_rad = 2.6;
  p.limit_stiffness_nm_per_rad = 10.0;
  p.limit_sharpness_per_rad = 20.0;
  return p;
}

TEST(PassiveJoint, ElasticTorqueIsMinusPotentialGradient) {
  const PassiveJointParams p = Joint();
  for (double q = -0.3; q <= 2.9; q += 0.05) {
    const double dv =
        (PassiveJointPotential(p, q + kFdStep) - PassiveJointPotential(p, q - kFdStep)) /
        (2 * kFdStep);
    EXPECT_NEAR(PassiveElasticTorque(p, q), -dv, kFdTol * (1 + std::abs(dv)));
  }
}

TEST(PassiveJoint, CubicStiffeningIsMinusTheGradientOfItsQuarticPotential) {
  PassiveJointParams p = Joint();
  p.cubic_stiffness_nm_per_rad3 = 3.0;
  for (double q = 0.2; q <= 2.4; q += 0.1) {
    const double dv =
        (PassiveJointPotential(p, q + kFdStep) - PassiveJointPotential(p, q - kFdStep)) /
        (2 * kFdStep);
    EXPECT_NEAR(PassiveElasticTorque(p, q), -dv, kFdTol * (1 + std::abs(dv)));
  }
  // Mid-range the cubic term adds k₃ (q₀ − q)³ to the linear moment.
  const double d = 1.4 - 0.9;
  EXPECT_NEAR(PassiveElasticTorque(p, 0.9), 2.3 * d + 3.0 * d * d * d, 1e-8);
}

TEST(PassiveJoint, QuadraticAsymmetryIsMinusTheGradientOfItsCubicPotential) {
  PassiveJointParams p = Joint();
  p.quadratic_stiffness_nm_per_rad2 = 1.5;
  for (double q = 0.2; q <= 2.4; q += 0.1) {
    const double dv =
        (PassiveJointPotential(p, q + kFdStep) - PassiveJointPotential(p, q - kFdStep)) /
        (2 * kFdStep);
    EXPECT_NEAR(PassiveElasticTorque(p, q), -dv, kFdTol * (1 + std::abs(dv)));
  }
  // k₂ (q₀ − q)² adds the same moment on both sides of the rest angle q₀ = 1.4: more restoring
  // on the extension side, less on the flexion side (the range limits add < 1e-6 N·m here).
  const double d = 0.5;
  EXPECT_NEAR(PassiveElasticTorque(p, 1.4 - d), 2.3 * d + 1.5 * d * d, 1e-6);
  EXPECT_NEAR(PassiveElasticTorque(p, 1.4 + d), -2.3 * d + 1.5 * d * d, 1e-6);
}

TEST(PassiveJoint, LinearInsideRangeExponentialBeyond) {
  const PassiveJointParams p = Joint();
  // Mid-range: eq. (14) of [Hand Hammerstein], limit moments below 1e-8 N·m.
  EXPECT_NEAR(PassiveJointTorque(p, 1.0, 0.2), 2.3 * (1.4 - 1.0) - 0.5 * 0.2, 1e-8);
  // At the upper limit the limit stiffness adds K_L; beyond it the moment grows exponentially.
  const double at = PassiveElasticTorque(p, 2.6) - 2.3 * (1.4 - 2.6);
  EXPECT_NEAR(at, -10.0 / 20.0, 1e-9);
  const double beyond = PassiveElasticTorque(p, 2.7) - 2.3 * (1.4 - 2.7);
  EXPECT_NEAR(beyond / at, std::exp(20.0 * 0.1), 1e-6);
  EXPECT_GT(PassiveElasticTorque(p, -0.1), 0.0);  // pushes back into range
}

TEST(PassiveJoint, CoulombFrictionOpposesMotion) {
  PassiveJointParams p;
  p.coulomb_friction_nm = 0.3;
  EXPECT_NEAR(PassiveDissipativeTorque(p, 1.0), -0.3, 1e-12);
  EXPECT_NEAR(PassiveDissipativeTorque(p, -1.0), 0.3, 1e-12);
  EXPECT_EQ(PassiveDissipativeTorque(p, 0.0), 0.0);
}

}  // namespace
}  // namespace fesim::sim
