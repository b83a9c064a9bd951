// Tests of the sim → render adapter (apps/arm_scene.h) on the default participant.
#include "apps/arm_scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "render/renderer.h"
#include "sim/default_model.h"

namespace fesim {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;
/// Image of the silhouette tests, pixels.
constexpr int kWidth = 320;
constexpr int kHeight = 240;
/// Smallest silhouette displacement that counts as "moved", pixels.
constexpr double kMinShiftPx = 15.0;
/// Smallest anterior displacement of the hand's distal end for 0° → 90° elbow flexion, m
/// (forearm + hand ≈ 0.44 m: the true displacement is of that order).
constexpr double kMinHandShift_m = 0.2;

class ArmSceneTest : public ::testing::Test {
 protected:
  ArmSceneTest() : model_(sim::DefaultModelParams()) {}

  /// The initial state with elbow_flexion set (degrees), realised to Position.
  SimTK::State Posed(double elbow_deg) const {
    SimTK::State s = model_.MakeInitialState();
    model_.CoordinateBody(sim::kElbowFlexion).setOneQ(s, 0, elbow_deg * kDeg);
    model_.system().realize(s, SimTK::Stage::Position);
    return s;
  }

  sim::UpperLimbModel model_;
};

/// Only the forearm, hand and phalanx capsules, no floor, overlay, muscles or pads.
render::Scene DistalBones(const render::Scene& full) {
  render::Scene s;
  s.draw_floor = false;
  s.overlay.visible = false;
  for (int k = sim::kForearm; k < sim::kNumSegments; ++k) s.capsules.push_back(full.capsules[k]);
  return s;
}

struct Silhouette {
  long pixels = 0;
  double centroid_x = 0;  ///< px
  int bottom_row = -1;    ///< lowest row with a silhouette pixel
};

Silhouette SilhouetteOf(const render::Image& image, const render::Rgba& background) {
  const auto bg = [](float c) { return static_cast<int>(std::lround(c * 255.0f)); };
  Silhouette out;
  double sum_x = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const std::uint8_t* p = image.At(x, y);
      const int d = std::abs(p[0] - bg(background.r)) + std::abs(p[1] - bg(background.g)) +
                    std::abs(p[2] - bg(background.b));
      if (d <= 6) continue;
      ++out.pixels;
      sum_x += x + 0.5;
      out.bottom_row = y;
    }
  }
  if (out.pixels > 0) out.centroid_x = sum_x / out.pixels;
  return out;
}

render::Camera CameraAt(render::CameraPreset preset, const render::Vec3& target) {
  render::Camera c;
  c.preset = preset;
  c.target = target;
  c.distance_m = 1.4;
  c.elevation_deg = 0;
  return c;
}

TEST_F(ArmSceneTest, DefaultModelAtRestHasSegmentsMusclesAndPads) {
  const SimTK::State s = Posed(81.0);
  const render::Scene scene = ArmScene(model_, s, {});
  EXPECT_GE(scene.capsules.size(), 6u);
  EXPECT_EQ(scene.polylines.size(), 14u);  // default model: no arm support
  EXPECT_EQ(scene.pads.size(), 24u);
  EXPECT_NO_THROW(render::ValidateScene(scene));
  for (const auto& line : scene.polylines) EXPECT_GE(line.points.size(), 3u);
  // Joint centres are shared: each segment starts where its parent ends.
  for (int k = sim::kForearm; k <= sim::kHand; ++k) {
    EXPECT_NEAR(scene.capsules[k].p0.x, scene.capsules[k - 1].p1.x, 1e-12);
    EXPECT_NEAR(scene.capsules[k].p0.y, scene.capsules[k - 1].p1.y, 1e-12);
  }
  EXPECT_EQ(scene.overlay.channels.size(), 6u);
  EXPECT_EQ(scene.overlay.channels[0].label, "ext");
  ASSERT_EQ(scene.overlay.joint_angles.size(), 10u);
  EXPECT_NEAR(scene.overlay.joint_angles[sim::kElbowFlexion].angle_deg, 81.0, 1e-9);
}

TEST_F(ArmSceneTest, FlexorsRunAnteriorAndExtensorsPosteriorAtTheElbow) {
  const SimTK::State s = Posed(0.0);
  const render::Scene scene = ArmScene(model_, s, {});
  const auto& names = sim::DefaultMuscleNames();
  const auto index = [&names](const std::string& n) {
    for (std::size_t j = 0; j < names.size(); ++j) {
      if (names[j] == n) return j;
    }
    return names.size();
  };
  const render::Vec3 elbow = scene.capsules[sim::kForearm].p0;
  // BRA crosses only the elbow: origin, elbow via point, insertion. Via point index 1.
  const auto& bra = scene.polylines[index("BRA")].points;
  const auto& tri = scene.polylines[index("TRI")].points;
  ASSERT_EQ(bra.size(), 3u);
  EXPECT_GT(bra[1].x - elbow.x, 0.02);  // anterior of the elbow
  // TRI: thorax origin, shoulder, elbow, insertion: passes behind the elbow (olecranon side).
  ASSERT_EQ(tri.size(), 4u);
  EXPECT_LT(tri[2].x - elbow.x, -0.02);
  EXPECT_LT(tri[3].x - elbow.x, -0.02);
}

TEST_F(ArmSceneTest, FlexingTheElbowMovesTheHandAnteriorly) {
  const render::Scene extended = ArmScene(model_, Posed(0.0), {});
  const render::Scene flexed = ArmScene(model_, Posed(90.0), {});
  const render::Vec3 a = extended.capsules[sim::kHand].p1;
  const render::Vec3 b = flexed.capsules[sim::kHand].p1;
  EXPECT_GT(b.x - a.x, kMinHandShift_m);
  EXPECT_GT(b.y - a.y, kMinHandShift_m);  // and up
  // The humerus does not move.
  EXPECT_NEAR(extended.capsules[sim::kHumerus].p1.x, flexed.capsules[sim::kHumerus].p1.x, 1e-12);
}

TEST_F(ArmSceneTest, FlexingTheElbowMovesTheForearmSilhouetteTheRightWay) {
  const SimTK::State rest = Posed(0.0);
  const render::Scene s0 = ArmScene(model_, rest, {});
  const render::Scene s90 = ArmScene(model_, Posed(90.0), {});
  const render::Vec3 elbow = s0.capsules[sim::kForearm].p0;
  render::OffscreenRenderer renderer(kWidth, kHeight);
  const render::Rgba bg = render::Scene{}.background;

  // Side view (eye on the subject's right): anterior is the image's right.
  const auto side = CameraAt(render::CameraPreset::kSide, elbow);
  const Silhouette side0 = SilhouetteOf(renderer.Render(DistalBones(s0), side), bg);
  const Silhouette side90 = SilhouetteOf(renderer.Render(DistalBones(s90), side), bg);
  ASSERT_GT(side0.pixels, 200);
  ASSERT_GT(side90.pixels, 200);
  EXPECT_GT(side90.centroid_x - side0.centroid_x, kMinShiftPx);
  // The flexed forearm lies right of the elbow's image column.
  const double elbow_x =
      render::ProjectToImage(render::PoseAt(side, 0), kWidth, kHeight, elbow).x_px;
  EXPECT_GT(side90.centroid_x, elbow_x + kMinShiftPx);

  // Front view: the forearm turns towards the camera, so the hanging hand's lowest pixel rises.
  const auto front = CameraAt(render::CameraPreset::kFront, elbow);
  const Silhouette front0 = SilhouetteOf(renderer.Render(DistalBones(s0), front), bg);
  const Silhouette front90 = SilhouetteOf(renderer.Render(DistalBones(s90), front), bg);
  ASSERT_GT(front0.pixels, 200);
  ASSERT_GT(front90.pixels, 200);
  EXPECT_LT(front90.bottom_row, front0.bottom_row - kMinShiftPx);
}

TEST_F(ArmSceneTest, SamePoseRendersToTheSameBytesTwice) {
  ArmSceneInputs in;
  in.time_s = 1.25;
  in.title = "determinism";
  in.stimulation_us = {150, 0, 80, 0, 0, 0};
  in.activation.assign(model_.num_muscles(), 0.4);
  const render::Camera camera =
      CameraAt(render::CameraPreset::kFront, ArmCameraTarget(model_, Posed(60.0)));
  render::OffscreenRenderer r1(kWidth, kHeight);
  const render::Image a = r1.Render(ArmScene(model_, Posed(60.0), in), camera);
  render::OffscreenRenderer r2(kWidth, kHeight);
  const render::Image b = r2.Render(ArmScene(model_, Posed(60.0), in), camera);
  EXPECT_TRUE(a.rgb == b.rgb);
  // Not empty: a good part of the image differs from the background.
  const Silhouette sil = SilhouetteOf(a, render::Scene{}.background);
  EXPECT_GT(sil.pixels, kWidth * kHeight / 50);
  // A different pose gives different bytes.
  const render::Image c = r1.Render(ArmScene(model_, Posed(20.0), in), camera);
  EXPECT_FALSE(a.rgb == c.rgb);
}

TEST_F(ArmSceneTest, PadColourFollowsTheDrivingChannelsPulseWidth) {
  ArmSceneInputs in;
  in.stimulation_us = {300, 0, 0, 0, 0, 0};  // ext at 300 µs, flex off
  const render::Scene scene = ArmScene(model_, Posed(81.0), in);
  const auto& ext_pad = scene.pads[model_.params().channels[0].pads[0]];
  const auto& flex_pad = scene.pads[model_.params().channels[1].pads[0]];
  const render::Rgba on = render::PulseWidthColour(300);
  const render::Rgba off = render::PulseWidthColour(0);
  EXPECT_FLOAT_EQ(ext_pad.colour.r, on.r);
  EXPECT_FLOAT_EQ(ext_pad.colour.b, on.b);
  EXPECT_FLOAT_EQ(flex_pad.colour.r, off.r);
  EXPECT_FLOAT_EQ(flex_pad.colour.b, off.b);
  EXPECT_NE(ext_pad.colour.r, flex_pad.colour.r);
  // Pads lie on the forearm surface, extensor pads dorsal (+Z at neutral) of flexor pads.
  const render::Vec3 e = scene.capsules[sim::kForearm].p0;
  const render::Vec3 w = scene.capsules[sim::kForearm].p1;
  const double r = ArmSegmentRadius(model_.params(), sim::kForearm) + kPadLift_m;
  for (const auto& pad : scene.pads) {
    // distance of the centre from the forearm axis
    const double ax = w.x - e.x, ay = w.y - e.y, az = w.z - e.z;
    const double px = pad.centre.x - e.x, py = pad.centre.y - e.y, pz = pad.centre.z - e.z;
    const double len = std::sqrt(ax * ax + ay * ay + az * az);
    const double t = (px * ax + py * ay + pz * az) / len;
    const double d2 = px * px + py * py + pz * pz - t * t;
    EXPECT_NEAR(std::sqrt(d2), r, 1e-9);
  }
}

TEST_F(ArmSceneTest, MusclesAreColouredByActivationOrNeutralWithout) {
  const SimTK::State s = Posed(81.0);
  const render::Scene none = ArmScene(model_, s, {});
  for (const auto& line : none.polylines) EXPECT_FLOAT_EQ(line.colour.r, kNeutralMuscleColour.r);
  ArmSceneInputs in;
  in.activation.assign(model_.num_muscles(), std::numeric_limits<double>::quiet_NaN());
  in.activation[0] = 1.0;
  const render::Scene some = ArmScene(model_, s, in);
  EXPECT_FLOAT_EQ(some.polylines[0].colour.r, render::ActivationColour(1.0).r);
  EXPECT_FLOAT_EQ(some.polylines[0].colour.g, render::ActivationColour(1.0).g);
  EXPECT_FLOAT_EQ(some.polylines[1].colour.g, kNeutralMuscleColour.g);
  in.activation.pop_back();
  EXPECT_THROW(ArmScene(model_, s, in), std::invalid_argument);
}

TEST(ArmSceneSupportTest, BandsGoFromCuffToAnchorAndGhostAddsTranslucentSegments) {
  sim::ModelParams p = sim::DefaultModelParams();
  sim::BandParams band;
  band.segment = sim::kHumerus;
  band.cuff_in_segment_m = {0, -0.2, 0};
  band.anchor_in_ground_m = {0.15, 1.9, 0.35};
  band.stiffness_n_per_m = 100;
  p.bands.push_back(band);
  const sim::UpperLimbModel model(p);
  SimTK::State s = model.MakeInitialState();
  SimTK::State ghost = model.MakeInitialState();
  model.CoordinateBody(sim::kElbowFlexion).setOneQ(ghost, 0, 10 * kDeg);
  model.system().realize(ghost, SimTK::Stage::Position);
  ArmSceneInputs in;
  in.ghost = &ghost;
  const render::Scene scene = ArmScene(model, s, in);
  ASSERT_EQ(scene.polylines.size(), 14u + 2u);
  const auto& line = scene.polylines[14].points;
  ASSERT_EQ(line.size(), 2u);
  const SimTK::Vec3 cuff =
      model.SegmentBody(sim::kHumerus).findStationLocationInGround(s, SimTK::Vec3(0, -0.2, 0));
  EXPECT_NEAR(line[0].x, cuff[0], 1e-12);
  EXPECT_NEAR(line[0].y, cuff[1], 1e-12);
  EXPECT_NEAR(line[1].y, 1.9, 1e-12);
  ASSERT_EQ(scene.capsules.size(), 7u + 6u);
  for (std::size_t k = 7; k < scene.capsules.size(); ++k) {
    EXPECT_LT(scene.capsules[k].colour.a, 1.0f);
  }
  EXPECT_GT(scene.capsules[7 + sim::kHand].p1.y, scene.capsules[sim::kHand].p1.y - 1.0);
  EXPECT_NE(scene.capsules[7 + sim::kHand].p1.x, scene.capsules[sim::kHand].p1.x);
}

Trial MakeTrial(const std::vector<std::string>& names) {
  Trial t;
  t.time = {0.0, 1.0};
  for (const auto& n : names) t.AddColumn(n, {0.1, 0.2});
  return t;
}

TEST(PoseColumnsTest, NoQColumnOrUnknownCoordinateIsAnError) {
  try {
    FindPoseColumns(MakeTrial({"u.ext"}), "t.csv");
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("t.csv: no q.<coordinate> column"), std::string::npos)
        << e.what();
  }
  try {
    FindPoseColumns(MakeTrial({"q.elbow_flexion", "q.knee"}), "t.csv");
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("q.knee is not a model coordinate"), std::string::npos)
        << e.what();
  }
  const PoseColumns ok = FindPoseColumns(MakeTrial({"u.ext", "q.wrist_flexion"}), "t.csv");
  ASSERT_EQ(ok.column.size(), 1u);
  EXPECT_EQ(ok.column[0], 1);
  EXPECT_EQ(ok.coordinate[0], sim::kWristFlexion);
}

TEST(PoseColumnsTest, AbsentCoordinatesKeepTheirInitialValue) {
  const sim::UpperLimbModel model(sim::DefaultModelParams());
  const Trial t = MakeTrial({"q.wrist_flexion"});
  SimTK::State s = model.MakeInitialState();
  const double elbow0 = model.GetQ(s, sim::kElbowFlexion);
  SetPoseFromTrialRow(model, t, FindPoseColumns(t, "t"), 1, &s);
  EXPECT_DOUBLE_EQ(model.GetQ(s, sim::kWristFlexion), 0.2);
  EXPECT_DOUBLE_EQ(model.GetQ(s, sim::kElbowFlexion), elbow0);
  EXPECT_GE(s.getSystemStage(), SimTK::Stage::Position);
}

TEST(ResampleTrialTest, LinearBetweenSamplesAndNanGapsHoldTheLastValidValue) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Trial t;
  t.time = {0.0, 1.0, 2.0, 3.0, 4.0};
  t.AddColumn("q.elbow_flexion", {0.0, 1.0, nan, nan, 4.0});
  t.AddColumn("q.wrist_flexion", {nan, 2.0, 2.0, 2.0, 2.0});
  t.AddColumn("a.BIC", {nan, nan, nan, nan, nan});
  const Trial r = ResampleTrial(t, {0.0, 0.5, 1.5, 2.5, 3.5, 4.0, 5.0});
  const auto& e = r.Column("q.elbow_flexion");
  EXPECT_DOUBLE_EQ(e[0], 0.0);
  EXPECT_DOUBLE_EQ(e[1], 0.5);
  EXPECT_DOUBLE_EQ(e[2], 1.0);  // next sample NaN: hold
  EXPECT_DOUBLE_EQ(e[3], 1.0);
  EXPECT_DOUBLE_EQ(e[4], 1.0);
  EXPECT_DOUBLE_EQ(e[5], 4.0);
  EXPECT_DOUBLE_EQ(e[6], 4.0);                            // after the end: last value
  EXPECT_DOUBLE_EQ(r.Column("q.wrist_flexion")[0], 2.0);  // leading NaN: first valid value
  EXPECT_TRUE(std::isnan(r.Column("a.BIC")[3]));
  EXPECT_THROW(ResampleTrial(t, {1.0, 0.5}), std::invalid_argument);
}

}  // namespace
}  // namespace fesim
