// Tests of foreign/joint.h: the double-exponential elastic moment is conservative, vanishes at the
// rest angle with slope −(k_f + k_e), stiffens exponentially; damping is linear.
#include "foreign/joint.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace fesim::foreign {
namespace {

constexpr double kFdStep = 1e-6;    // rad
constexpr double kFdRelTol = 1e-6;  // relative, central differences
constexpr double kExactTol = 1e-14;

JointParams Wrist() { return {-0.1, 0.5, 3.0, 0.4, 2.5, 0.02}; }

TEST(ForeignJoint, ElasticMomentIsMinusTheGradientOfTheEnergy) {
  const JointParams j = Wrist();
  for (double q = -1.3; q <= 1.3; q += 0.05) {
    const double fd =
        (ElasticEnergy(j, q + kFdStep) - ElasticEnergy(j, q - kFdStep)) / (2 * kFdStep);
    EXPECT_NEAR(ElasticMoment(j, q), -fd, kFdRelTol * (std::abs(fd) + 1e-3)) << q;
    const double fd_k =
        (ElasticMoment(j, q + kFdStep) - ElasticMoment(j, q - kFdStep)) / (2 * kFdStep);
    EXPECT_NEAR(ElasticStiffness(j, q), -fd_k, kFdRelTol * (std::abs(fd_k) + 1e-3)) << q;
    EXPECT_GE(ElasticEnergy(j, q), 0.0);
  }
}

TEST(ForeignJoint, RestAngleIsNeutralWithStiffnessTheSumOfBothSides) {
  const JointParams j = Wrist();
  EXPECT_NEAR(ElasticMoment(j, j.rest_angle_rad), 0.0, kExactTol);
  EXPECT_NEAR(ElasticEnergy(j, j.rest_angle_rad), 0.0, kExactTol);
  EXPECT_NEAR(ElasticStiffness(j, j.rest_angle_rad), 0.9, kExactTol);
  // Restoring on both sides, and exponentially stiffer away from rest.
  EXPECT_LT(ElasticMoment(j, 0.5), 0.0);
  EXPECT_GT(ElasticMoment(j, -0.7), 0.0);
  const double d = 0.8;
  EXPECT_NEAR(ElasticStiffness(j, j.rest_angle_rad + d),
              0.5 * std::exp(3.0 * d) + 0.4 * std::exp(-2.5 * d), 1e-12);
}

TEST(ForeignJoint, DampingIsLinearInVelocity) {
  const JointParams j = Wrist();
  EXPECT_DOUBLE_EQ(DampingMoment(j, 2.0), -0.04);
  EXPECT_DOUBLE_EQ(DampingMoment(j, -1.0), 0.02);
}

TEST(ForeignJoint, ValidationNamesTheField) {
  JointParams j = Wrist();
  j.flexion_stiffening_per_rad = 0.0;
  try {
    ValidateJoint(j, "person.joints.wrist_flexion");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("person.joints.wrist_flexion.flexion_stiffening_per_rad"),
              std::string::npos);
  }
  EXPECT_NO_THROW(ValidateJoint(Wrist(), "w"));
}

}  // namespace
}  // namespace fesim::foreign
