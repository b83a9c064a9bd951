#include "sim/model_params.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "muscles/electrode_array.h"

namespace fesim::sim {
namespace {

constexpr double kTol = 1e-12;  // A entries are sums of a few products: rounding only.

/// A model of `n` muscles named m0, m1, …, each crossing the joints listed for it, no channels.
ModelParams MusclesCrossing(const std::vector<std::vector<int>>& joints) {
  ModelParams m;
  m.muscles.clear();
  m.channels.clear();
  m.array.motor_points.clear();
  for (std::size_t j = 0; j < joints.size(); ++j) {
    MuscleParams mu;
    mu.name = "m" + std::to_string(j);
    for (int joint : joints[j]) {
      tendons::Crossing c;
      c.joint = joint;
      mu.path.crossings.push_back(c);
    }
    m.muscles.push_back(mu);
  }
  return m;
}

TEST(ModelParams, CoordinateAndSegmentNamesRoundTripThroughTheirIndices) {
  for (int i = 0; i < kNumCoordinates; ++i) EXPECT_EQ(CoordinateIndex(CoordinateNames()[i]), i);
  for (int i = 0; i < kNumSegments; ++i) EXPECT_EQ(SegmentIndex(SegmentNames()[i]), i);
  EXPECT_EQ(CoordinateIndex("wrist_flexion"), kWristFlexion);
  EXPECT_EQ(SegmentIndex("hand"), kHand);
  EXPECT_EQ(CoordinateIndex("wrist"), -1);
  EXPECT_EQ(CoordinateIndex(""), -1);
  EXPECT_EQ(SegmentIndex("ulna"), -1);
}

TEST(ModelParams, ExplicitWeightsAreTheMatrixEntriesWithoutCrosstalk) {
  ModelParams m = MusclesCrossing({{kWristFlexion}, {kWristFlexion}, {kElbowFlexion}});
  m.channels = {{"ext", {}, {{"m0", 0.8}, {"m2", 0.3}}}, {"flex", {}, {{"m1", 0.5}}}};
  const muscles::ArrayMatrix a = BuildElectrodeMatrix(m);
  ASSERT_EQ(a.muscles, 3);
  ASSERT_EQ(a.channels, 2);
  const double expected[3][2] = {{0.8, 0.0}, {0.0, 0.5}, {0.3, 0.0}};
  for (int j = 0; j < 3; ++j) {
    for (int k = 0; k < 2; ++k) EXPECT_NEAR(a(j, k), expected[j][k], kTol) << j << ", " << k;
  }
}

TEST(ModelParams, PadsSplitTheChannelEquallyOverTheArrayGeometry) {
  // One channel on two pads, one motor point: A = ½ (g(p0) + g(p1)) with g the geometric weight.
  ModelParams m = MusclesCrossing({{kWristFlexion}, {kWristFlexion}});
  m.array.rows = 2;
  m.array.cols = 2;
  m.array.motor_points = {{"m1", {0.01, 0.004}}};
  m.channels = {{"ext", {0, 3}, {}}};
  const muscles::ArrayMatrix a = BuildElectrodeMatrix(m);
  muscles::ArrayGeometry single;
  single.pads = muscles::PadGrid(2, 2, m.array.pitch_m, m.array.origin);
  single.spread_m = m.array.spread_m;
  single.motor_points = {{0.01, 0.004}};
  single.channel_pads = {{0}, {3}};
  const muscles::ArrayMatrix g = muscles::ArrayFromGeometry(single);
  EXPECT_NEAR(a(1, 0), 0.5 * (g(0, 0) + g(0, 1)), kTol);
  EXPECT_GT(a(1, 0), 0.0);
  EXPECT_EQ(a(0, 0), 0.0);  // no motor point, no explicit weight
}

TEST(ModelParams, CrosstalkReachesOnlyMusclesThatShareAJointWithTheDrivenOnes) {
  // Channel drives m0 (wrist) with weights 0.6 and m3 (wrist) with 0.9: fraction c of the
  // largest weight (0.9) goes to m1 (wrist and MCP), none to m2 (elbow only).
  ModelParams m = MusclesCrossing(
      {{kWristFlexion}, {kWristFlexion, kMcpFlexion}, {kElbowFlexion}, {kWristFlexion}});
  m.channels = {{"ext", {}, {{"m0", 0.6}, {"m3", 0.9}}}};
  m.mechanisms.crosstalk.fraction = 0.1;
  const muscles::ArrayMatrix a = BuildElectrodeMatrix(m);
  EXPECT_NEAR(a(0, 0), 0.6, kTol);
  EXPECT_NEAR(a(1, 0), 0.1 * 0.9, kTol);
  EXPECT_EQ(a(2, 0), 0.0);
  EXPECT_NEAR(a(3, 0), 0.9, kTol);
}

TEST(ModelParams, UnknownMuscleIsNamedInTheError) {
  ModelParams m = MusclesCrossing({{kWristFlexion}});
  m.channels = {{"ext", {}, {{"ECX", 1.0}}}};
  try {
    BuildElectrodeMatrix(m);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "electrodes: unknown muscle 'ECX'");
  }
  ModelParams p = MusclesCrossing({{kWristFlexion}});
  p.array.motor_points = {{"FCX", {0.0, 0.0}}};
  EXPECT_THROW(BuildElectrodeMatrix(p), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::sim
