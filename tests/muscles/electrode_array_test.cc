#include "muscles/electrode_array.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace fesim::muscles {
namespace {

constexpr double kTol = 1e-12;

TEST(ElectrodeArray, GaussianSpreadFromGeometry) {
  ArrayGeometry g;
  g.pads = PadGrid(4, 6, 0.015, {0.03, -0.0375});
  ASSERT_EQ(g.pads.size(), 24u);
  EXPECT_NEAR(g.pads[7].along_m, 0.045, kTol);     // row 1
  EXPECT_NEAR(g.pads[7].around_m, -0.0225, kTol);  // col 1
  g.channel_pads = {{7}, {7, 8}};
  g.motor_points = {g.pads[7], {0.045 + 0.02, -0.0225}};
  g.spread_m = 0.01;
  const auto a = ArrayFromGeometry(g);
  EXPECT_EQ(a.muscles, 2);
  EXPECT_EQ(a.channels, 2);
  EXPECT_NEAR(a(0, 0), 1.0, kTol);                         // pad on the motor point
  EXPECT_NEAR(a(1, 0), std::exp(-0.0004 / 0.0002), kTol);  // 2 cm away, σ = 1 cm
  const double d8 = 0.015 * 0.015;                         // pad 8 is one pitch around
  EXPECT_NEAR(a(0, 1), 1.0 + std::exp(-d8 / 0.0002), kTol);
  const auto v = ApplyArray(a, {100.0, 0.0});
  EXPECT_NEAR(v[0], 100.0, kTol);
  EXPECT_THROW(ApplyArray(a, {1.0}), std::invalid_argument);
  g.channel_pads = {{24}};
  EXPECT_THROW(ArrayFromGeometry(g), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::muscles
