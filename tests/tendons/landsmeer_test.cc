#include "tendons/landsmeer.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fesim::tendons {
namespace {

constexpr double kFdStep = 1e-5;    // rad
constexpr double kFdTol = 1e-9;     // m per rad, relative to arms of ~1 cm
constexpr double kSeamTol = 1e-14;  // series vs closed form at the switch point
constexpr double kSwitch = 0.15;    // rad, where landsmeer.cc changes evaluation

TEST(Landsmeer, ShapeMatchesClosedFormAndIsContinuousThroughZero) {
  // Closed form at the switch point versus the series just inside it.
  for (double q : {kSwitch, -kSwitch}) {
    const double s = std::sin(q);
    EXPECT_NEAR(LandsmeerShape(std::nextafter(q, 0.0)), (s - q) / (2 * s * s), kSeamTol);
    EXPECT_NEAR(LandsmeerShapeIntegral(std::nextafter(q, 0.0)),
                0.5 * (q / std::tan(q) - std::log(1 + std::cos(q)) - 1 + std::log(2.0)), kSeamTol);
  }
  EXPECT_EQ(LandsmeerShape(0.0), 0.0);
  EXPECT_EQ(LandsmeerShapeIntegral(0.0), 0.0);
  // Smooth through 0: slope −1/12, symmetric (g odd, G even).
  EXPECT_NEAR((LandsmeerShape(1e-6) - LandsmeerShape(-1e-6)) / 2e-6, -1.0 / 12.0, 1e-12);
  for (double q = 0.01; q < 2.5; q += 0.07) {
    EXPECT_NEAR(LandsmeerShape(-q), -LandsmeerShape(q), 1e-15);
    EXPECT_NEAR(LandsmeerShapeIntegral(-q), LandsmeerShapeIntegral(q), 1e-15);
  }
}

TEST(Landsmeer, CurvatureContinuousAcrossSeam) {
  // A second difference straddling the series/closed-form seam agrees with ones taken wholly on
  // either side (they differ by O(h) times the third derivative, so a jump or kink at the seam
  // would show).
  const double h = 1e-3;
  const auto d2 = [h](double q) {
    return (LandsmeerShape(q - h) - 2 * LandsmeerShape(q) + LandsmeerShape(q + h)) / (h * h);
  };
  for (double q : {kSwitch, -kSwitch}) {
    EXPECT_NEAR(d2(q), d2(q - 2 * h), 1e-3);
    EXPECT_NEAR(d2(q), d2(q + 2 * h), 1e-3);
  }
}

TEST(Landsmeer, MomentArmIsMinusLengthDerivative) {
  const MomentArmParams models[] = {
      {MomentArmParams::Model::kConstant, 0.012, 0.0},
      {MomentArmParams::Model::kLandsmeer, 0.015, -0.08},
      {MomentArmParams::Model::kLandsmeer, -0.008, 0.02},
  };
  for (const auto& p : models) {
    for (double q = -2.5; q <= 2.5; q += 0.01) {
      const double dl =
          (LengthChange(p, q + kFdStep) - LengthChange(p, q - kFdStep)) / (2 * kFdStep);
      EXPECT_NEAR(MomentArm(p, q), -dl, kFdTol) << "q = " << q;
    }
  }
}

}  // namespace
}  // namespace fesim::tendons
