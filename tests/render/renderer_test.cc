#include "render/renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "render/demo_scene.h"

namespace fesim::render {
namespace {

constexpr int kWidth = 320;
constexpr int kHeight = 240;
/// A pixel is foreground when |r − bg| + |g − bg| + |b − bg| exceeds this (8-bit levels).
constexpr int kForegroundThreshold = 24;
/// A known scene must cover at least this many pixels (the demo arm covers thousands, the
/// foreshortened forearm alone a few hundred).
constexpr int kMinForegroundPixels = 200;
/// Flexing the forearm by 60° must move its silhouette centroid at least this far, pixels.
constexpr double kMinCentroidShift_px = 10;
/// Motion in the flexion plane seen edge-on may shift the centroid sideways at most this, pixels.
constexpr double kMaxSidewaysShift_px = 2;
/// Silhouette centroid vs projected axis midpoint (shading and perspective), pixels.
constexpr double kCentroidVsProjection_px = 3;
/// Alpha blending vs α·lit + (1 − α)·background, 8-bit levels (rasteriser rounding).
constexpr int kBlendTolerance = 3;

const Vec3 kElbow{0.0, 1.1, 0.2};

struct Centroid {
  double x = 0;
  double y = 0;
  int pixels = 0;
};

int Difference(const std::uint8_t* p, const Rgba& bg) {
  const auto level = [](float v) { return static_cast<int>(std::lround(v * 255)); };
  return std::abs(p[0] - level(bg.r)) + std::abs(p[1] - level(bg.g)) + std::abs(p[2] - level(bg.b));
}

Centroid Foreground(const Image& image, const Rgba& bg) {
  Centroid c;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      if (Difference(image.At(x, y), bg) > kForegroundThreshold) {
        c.x += x + 0.5;
        c.y += y + 0.5;
        ++c.pixels;
      }
    }
  }
  if (c.pixels > 0) {
    c.x /= c.pixels;
    c.y /= c.pixels;
  }
  return c;
}

/// Largest image row holding a foreground pixel (the silhouette's lower edge), or −1.
int LowestRow(const Image& image, const Rgba& bg) {
  for (int y = image.height - 1; y >= 0; --y) {
    for (int x = 0; x < image.width; ++x) {
      if (Difference(image.At(x, y), bg) > kForegroundThreshold) return y;
    }
  }
  return -1;
}

/// Only a forearm capsule hinged at kElbow, flexed about +Z (0° = hanging down).
Scene ForearmScene(double flexion_deg) {
  const double t = flexion_deg * 3.14159265358979323846 / 180.0;
  Scene scene;
  scene.draw_floor = false;
  scene.overlay.visible = false;
  const Vec3 wrist{kElbow.x + 0.26 * std::sin(t), kElbow.y - 0.26 * std::cos(t), kElbow.z};
  scene.capsules.push_back({kElbow, wrist, 0.03, Rgba{0.8f, 0.3f, 0.2f, 1.0f}});
  return scene;
}

Camera CameraAtElbow(CameraPreset preset) {
  Camera camera;
  camera.preset = preset;
  camera.target = kElbow;
  camera.distance_m = 1.2;
  camera.elevation_deg = 10;
  return camera;
}

TEST(OffscreenRendererTest, ZeroOrOversizedImageIsAClearError) {
  try {
    OffscreenRenderer renderer(0, 240);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("0x240"), std::string::npos) << e.what();
  }
  EXPECT_THROW(OffscreenRenderer(320, 0), std::runtime_error);
  EXPECT_THROW(OffscreenRenderer(-1, 10), std::runtime_error);
  EXPECT_THROW(OffscreenRenderer(kMaxImageSidePx + 1, 10), std::runtime_error);
}

TEST(OffscreenRendererTest, KnownSceneIsNonEmptyAndDeterministic) {
  DemoArmOptions options;
  options.elbow_flexion_deg = 45;
  options.ghost_elbow_flexion_deg = 70;
  options.time_s = 0.5;
  const Scene scene = DemoArmScene(options);
  const Camera camera;

  OffscreenRenderer renderer(kWidth, kHeight);
  const Image first = renderer.Render(scene, camera);
  ASSERT_EQ(first.width, kWidth);
  ASSERT_EQ(first.height, kHeight);
  ASSERT_EQ(first.rgb.size(), 3u * kWidth * kHeight);
  EXPECT_GT(Foreground(first, scene.background).pixels, kMinForegroundPixels);

  const Image second = renderer.Render(scene, camera);
  EXPECT_TRUE(first.rgb == second.rgb) << "same scene, same renderer: bytes differ";

  // A second renderer, with another one used in between on the same thread: same bytes.
  OffscreenRenderer other(64, 48);
  other.Render(DemoArmScene(), Camera{});
  OffscreenRenderer again(kWidth, kHeight);
  EXPECT_TRUE(again.Render(scene, camera).rgb == first.rgb) << "new renderer: bytes differ";
}

TEST(OffscreenRendererTest, SilhouetteSitsWhereTheCameraProjectsIt) {
  OffscreenRenderer renderer(kWidth, kHeight);
  const Scene scene = ForearmScene(0);
  const Camera camera = CameraAtElbow(CameraPreset::kSide);
  const Centroid c = Foreground(renderer.Render(scene, camera), scene.background);
  const Capsule& forearm = scene.capsules[0];
  const Vec3 middle{(forearm.p0.x + forearm.p1.x) / 2, (forearm.p0.y + forearm.p1.y) / 2,
                    (forearm.p0.z + forearm.p1.z) / 2};
  const ImagePoint expected = ProjectToImage(PoseAt(camera, 0), kWidth, kHeight, middle);
  ASSERT_TRUE(expected.in_front);
  EXPECT_NEAR(c.x, expected.x_px, kCentroidVsProjection_px);
  EXPECT_NEAR(c.y, expected.y_px, kCentroidVsProjection_px);
}

TEST(OffscreenRendererTest, FrontViewShowsTheSubjectsRightOnTheImageLeft) {
  OffscreenRenderer renderer(kWidth, kHeight);
  const Camera camera = CameraAtElbow(CameraPreset::kFront);
  Scene scene = ForearmScene(0);
  const Vec3 right_of_elbow{kElbow.x, kElbow.y, kElbow.z + 0.15};  // +Z: subject's right
  scene.capsules = {Capsule{right_of_elbow, right_of_elbow, 0.03, Rgba{0.2f, 0.6f, 0.2f, 1.0f}}};
  const Centroid c = Foreground(renderer.Render(scene, camera), scene.background);
  const ImagePoint expected = ProjectToImage(PoseAt(camera, 0), kWidth, kHeight, right_of_elbow);
  EXPECT_LT(expected.x_px, kWidth / 2.0 - kMinCentroidShift_px);
  EXPECT_NEAR(c.x, expected.x_px, kCentroidVsProjection_px);
  EXPECT_NEAR(c.y, expected.y_px, kCentroidVsProjection_px);
}

TEST(OffscreenRendererTest, ElbowFlexionMovesTheForearmUpInTheFrontView) {
  OffscreenRenderer renderer(kWidth, kHeight);
  // Eye level with the elbow: the forearm swings in the sagittal plane towards the camera.
  Camera camera = CameraAtElbow(CameraPreset::kFront);
  camera.elevation_deg = 0;
  const Image hanging_image = renderer.Render(ForearmScene(0), camera);
  const Image flexed_image = renderer.Render(ForearmScene(60), camera);
  const Centroid hanging = Foreground(hanging_image, Scene{}.background);
  const Centroid flexed = Foreground(flexed_image, Scene{}.background);
  ASSERT_GT(hanging.pixels, kMinForegroundPixels);
  ASSERT_GT(flexed.pixels, kMinForegroundPixels);
  // The forearm's image rises (y decreases), its lower edge (the hand end) most of all, and it
  // does not shift sideways.
  EXPECT_LT(flexed.y, hanging.y - kMinCentroidShift_px);
  EXPECT_LT(LowestRow(flexed_image, Scene{}.background),
            LowestRow(hanging_image, Scene{}.background) - kMinCentroidShift_px);
  EXPECT_NEAR(flexed.x, hanging.x, kMaxSidewaysShift_px);
}

TEST(OffscreenRendererTest, ElbowFlexionMovesTheForearmForwardAndUpInTheSideView) {
  OffscreenRenderer renderer(kWidth, kHeight);
  const Camera camera = CameraAtElbow(CameraPreset::kSide);
  const Centroid hanging = Foreground(renderer.Render(ForearmScene(0), camera), Scene{}.background);
  const Centroid flexed = Foreground(renderer.Render(ForearmScene(60), camera), Scene{}.background);
  // Seen from the right side, anterior (+X) is on the image right.
  EXPECT_GT(flexed.x, hanging.x + kMinCentroidShift_px);
  EXPECT_LT(flexed.y, hanging.y - kMinCentroidShift_px);
}

TEST(OffscreenRendererTest, TranslucentGhostBlendsWithTheBackground) {
  OffscreenRenderer renderer(kWidth, kHeight);
  const Camera camera = CameraAtElbow(CameraPreset::kFront);
  Scene opaque = ForearmScene(90);  // pointing at the camera: a disc in the image centre
  opaque.capsules[0].colour = Rgba{0.9f, 0.1f, 0.1f, 1.0f};
  Scene ghost = opaque;
  constexpr float kAlpha = 0.4f;
  ghost.capsules[0].colour.a = kAlpha;
  const Image a = renderer.Render(opaque, camera);
  const Image b = renderer.Render(ghost, camera);
  const ImagePoint centre = ProjectToImage(PoseAt(camera, 0), kWidth, kHeight, kElbow);
  const int x = static_cast<int>(centre.x_px);
  const int y = static_cast<int>(centre.y_px);
  const std::uint8_t* lit = a.At(x, y);
  const std::uint8_t* blended = b.At(x, y);
  const Rgba bg = opaque.background;
  const float bg_levels[3] = {bg.r * 255, bg.g * 255, bg.b * 255};
  for (int k = 0; k < 3; ++k) {
    const double expected = kAlpha * lit[k] + (1 - kAlpha) * bg_levels[k];
    EXPECT_NEAR(blended[k], expected, kBlendTolerance) << "channel " << k;
  }
  // Visibly between the two: neither the lit colour nor the background.
  EXPECT_GT(Difference(blended, bg), kForegroundThreshold);
  EXPECT_GT(std::abs(blended[1] - lit[1]), kForegroundThreshold);
}

TEST(OffscreenRendererTest, OnTopPolylineShowsThroughABoneOtherwiseHidden) {
  OffscreenRenderer renderer(kWidth, kHeight);
  const Camera camera = CameraAtElbow(CameraPreset::kFront);
  Scene scene = ForearmScene(90);
  // A green line behind the forearm on the view ray through the elbow, crossing the view left
  // to right (along Z, perpendicular to that ray).
  const CameraPose pose = PoseAt(camera, 0);
  const Vec3 behind{kElbow.x + 0.3 * (kElbow.x - pose.eye.x),
                    kElbow.y + 0.3 * (kElbow.y - pose.eye.y), kElbow.z};
  scene.polylines.push_back(
      {{{behind.x, behind.y, behind.z - 0.3}, {behind.x, behind.y, behind.z + 0.3}},
       3.0f,
       Rgba{0, 1, 0, 1},
       false});
  const ImagePoint centre = ProjectToImage(pose, kWidth, kHeight, kElbow);
  const int x = static_cast<int>(centre.x_px);
  const int y = static_cast<int>(centre.y_px);
  const auto is_green = [](const std::uint8_t* p) { return p[1] > 200 && p[0] < 60 && p[2] < 60; };
  EXPECT_FALSE(is_green(renderer.Render(scene, camera).At(x, y)));
  scene.polylines[0].draw_on_top = true;
  EXPECT_TRUE(is_green(renderer.Render(scene, camera).At(x, y)));
}

TEST(OffscreenRendererTest, PadFacingTheCameraShowsItsColour) {
  OffscreenRenderer renderer(kWidth, kHeight);
  const Camera camera = CameraAtElbow(CameraPreset::kFront);
  Scene scene;
  scene.draw_floor = false;
  Pad pad;
  pad.centre = kElbow;
  pad.normal = {1, 0, 0};  // towards the front camera
  pad.u_axis = {0, 1, 0};
  pad.half_u_m = 0.03;
  pad.half_v_m = 0.02;
  pad.colour = Rgba{0.1f, 0.2f, 1.0f, 1.0f};
  scene.pads.push_back(pad);
  const ImagePoint centre = ProjectToImage(PoseAt(camera, 0), kWidth, kHeight, kElbow);
  const Image image = renderer.Render(scene, camera);
  const std::uint8_t* p = image.At(static_cast<int>(centre.x_px), static_cast<int>(centre.y_px));
  EXPECT_GT(p[2], p[0] + 100);
}

TEST(OffscreenRendererTest, FloorFillsTheTopView) {
  OffscreenRenderer renderer(kWidth, kHeight);
  Scene scene;
  scene.overlay.visible = false;
  Camera camera;
  camera.preset = CameraPreset::kTop;
  const Centroid floor = Foreground(renderer.Render(scene, camera), scene.background);
  EXPECT_GT(floor.pixels, kWidth * kHeight * 9 / 10);
  scene.draw_floor = false;
  EXPECT_EQ(Foreground(renderer.Render(scene, camera), scene.background).pixels, 0);
}

TEST(OffscreenRendererTest, OrbitCameraTurnsWithTime) {
  OffscreenRenderer renderer(kWidth, kHeight);
  Camera orbit;
  orbit.preset = CameraPreset::kOrbit;
  Camera front = orbit;
  front.preset = CameraPreset::kFront;
  Scene scene = DemoArmScene();
  scene.overlay.visible = false;
  const Image at_start = renderer.Render(scene, orbit);
  EXPECT_TRUE(at_start.rgb == renderer.Render(scene, front).rgb);
  scene.time_s = orbit.orbit_period_s / 4;
  EXPECT_FALSE(at_start.rgb == renderer.Render(scene, orbit).rgb);
}

TEST(OffscreenRendererTest, InvalidSceneIsRejected) {
  OffscreenRenderer renderer(32, 32);
  Scene scene;
  scene.capsules.push_back(Capsule{});
  scene.capsules[0].radius_m = -1;
  EXPECT_THROW(renderer.Render(scene, Camera{}), std::invalid_argument);
}

TEST(OffscreenRendererTest, MovedRendererStillRenders) {
  OffscreenRenderer a(kWidth, kHeight);
  const Image before = a.Render(DemoArmScene(), Camera{});
  OffscreenRenderer b = std::move(a);
  EXPECT_EQ(b.width(), kWidth);
  EXPECT_TRUE(b.Render(DemoArmScene(), Camera{}).rgb == before.rgb);
}

}  // namespace
}  // namespace fesim::render
