#include "render/scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace fesim::render {
namespace {

constexpr double kPoseTol_m = 1e-9;  ///< camera positions are closed-form.
constexpr float kColourTol = 1e-6f;  ///< colour interpolation is exact up to float rounding.

double Brightness(const Rgba& c) { return c.r + c.g + c.b; }

TEST(CameraPresetTest, ParsesAndNamesEveryPreset) {
  for (const char* name : {"front", "side", "top", "orbit"}) {
    EXPECT_EQ(CameraPresetName(ParseCameraPreset(name)), name);
  }
}

TEST(CameraPresetTest, UnknownNameIsAClearError) {
  try {
    ParseCameraPreset("diagonal");
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'diagonal'"), std::string::npos) << e.what();
  }
}

TEST(PoseAtTest, FrontSideTopLookFromTheDocumentedDirections) {
  Camera camera;
  camera.target = {0.1, 1.0, 0.2};
  camera.distance_m = 2.0;
  camera.elevation_deg = 0;

  camera.preset = CameraPreset::kFront;
  CameraPose pose = PoseAt(camera, 0);
  EXPECT_NEAR(pose.eye.x, 2.1, kPoseTol_m);  // in front: +X
  EXPECT_NEAR(pose.eye.y, 1.0, kPoseTol_m);
  EXPECT_NEAR(pose.eye.z, 0.2, kPoseTol_m);

  camera.preset = CameraPreset::kSide;
  pose = PoseAt(camera, 0);
  EXPECT_NEAR(pose.eye.x, 0.1, kPoseTol_m);
  EXPECT_NEAR(pose.eye.z, 2.2, kPoseTol_m);  // subject's right: +Z

  camera.preset = CameraPreset::kTop;
  pose = PoseAt(camera, 0);
  EXPECT_NEAR(pose.eye.y, 3.0, kPoseTol_m);
  EXPECT_NEAR(pose.up.x, 1.0, kPoseTol_m);  // anterior at the top of the image
}

TEST(PoseAtTest, ElevationRaisesTheEyeKeepingTheDistance) {
  Camera camera;
  camera.elevation_deg = 30;
  const CameraPose pose = PoseAt(camera, 0);
  const double dx = pose.eye.x - camera.target.x;
  const double dy = pose.eye.y - camera.target.y;
  const double dz = pose.eye.z - camera.target.z;
  EXPECT_NEAR(std::sqrt(dx * dx + dy * dy + dz * dz), camera.distance_m, kPoseTol_m);
  EXPECT_NEAR(dy, camera.distance_m * 0.5, kPoseTol_m);
}

TEST(PoseAtTest, OrbitStartsAtFrontAndReachesTheSideAfterAQuarterPeriod) {
  Camera orbit;
  orbit.preset = CameraPreset::kOrbit;
  orbit.orbit_period_s = 8;
  Camera front = orbit;
  front.preset = CameraPreset::kFront;
  Camera side = orbit;
  side.preset = CameraPreset::kSide;
  for (const auto& [time_s, expected] :
       {std::pair{0.0, front}, std::pair{2.0, side}, std::pair{8.0, front}}) {
    const CameraPose a = PoseAt(orbit, time_s);
    const CameraPose b = PoseAt(expected, 0);
    EXPECT_NEAR(a.eye.x, b.eye.x, 1e-9) << time_s;
    EXPECT_NEAR(a.eye.y, b.eye.y, 1e-9) << time_s;
    EXPECT_NEAR(a.eye.z, b.eye.z, 1e-9) << time_s;
  }
}

TEST(PoseAtTest, RejectsBadCameras) {
  Camera camera;
  camera.distance_m = 0;
  EXPECT_THROW(PoseAt(camera, 0), std::invalid_argument);
  camera = Camera{};
  camera.fov_y_deg = 180;
  EXPECT_THROW(PoseAt(camera, 0), std::invalid_argument);
  camera = Camera{};
  camera.preset = CameraPreset::kOrbit;
  camera.orbit_period_s = 0;
  EXPECT_THROW(PoseAt(camera, 0), std::invalid_argument);
}

TEST(ColourScaleTest, ActivationGoesFromPaleToRedAndClamps) {
  const Rgba rest = ActivationColour(0);
  const Rgba full = ActivationColour(1);
  EXPECT_GT(full.r - full.b, rest.r - rest.b);  // redder
  EXPECT_NEAR(ActivationColour(-1).r, rest.r, kColourTol);
  EXPECT_NEAR(ActivationColour(2).g, full.g, kColourTol);
  EXPECT_NEAR(ActivationColour(std::nan("")).b, rest.b, kColourTol);
}

TEST(ColourScaleTest, PulseWidthBrightensFromZeroTo300us) {
  double previous = -1;
  for (double us = 0; us <= 300; us += 50) {
    const double b = Brightness(PulseWidthColour(us));
    EXPECT_GT(b, previous) << us;
    previous = b;
  }
  EXPECT_NEAR(PulseWidthColour(1000).g, PulseWidthColour(300).g, kColourTol);
  EXPECT_NEAR(PulseWidthColour(std::nan("")).r, PulseWidthColour(0).r, kColourTol);
  EXPECT_FLOAT_EQ(WithAlpha(PulseWidthColour(0), 0.25f).a, 0.25f);
}

TEST(ValidateSceneTest, NamesTheBadItem) {
  Scene scene;
  scene.capsules.resize(3);
  scene.capsules[2].radius_m = 0;
  try {
    ValidateScene(scene);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("capsule 2"), std::string::npos) << e.what();
  }
  scene.capsules[2].radius_m = 0.01;
  EXPECT_NO_THROW(ValidateScene(scene));
  scene.polylines.push_back({{{0, 0, 0}, {std::nan(""), 0, 0}}, 2.0f, {}, false});
  EXPECT_THROW(ValidateScene(scene), std::invalid_argument);
  scene.polylines.clear();
  scene.pads.push_back(Pad{});
  scene.pads[0].normal = {0, 0, 0};
  EXPECT_THROW(ValidateScene(scene), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::render
