#include "render/demo_scene.h"

#include <gtest/gtest.h>

namespace fesim::render {
namespace {

TEST(DemoArmSceneTest, HasTheBenchmarkCounts) {
  const Scene scene = DemoArmScene();
  EXPECT_EQ(scene.capsules.size(), 12u);
  EXPECT_EQ(scene.polylines.size(), 14u);
  EXPECT_EQ(scene.pads.size(), 24u);
  EXPECT_EQ(scene.overlay.channels.size(), 8u);
  EXPECT_EQ(scene.overlay.joint_angles.size(), 4u);
  EXPECT_NO_THROW(ValidateScene(scene));
}

TEST(DemoArmSceneTest, FlexionSwingsTheForearmAnteriorly) {
  DemoArmOptions options;
  options.elbow_flexion_deg = 0;
  const Capsule hanging = DemoArmScene(options).capsules[1];  // ulna
  options.elbow_flexion_deg = 90;
  const Capsule flexed = DemoArmScene(options).capsules[1];
  EXPECT_LT(hanging.p1.y, hanging.p0.y);  // wrist below elbow
  EXPECT_GT(flexed.p1.x, flexed.p0.x);    // wrist in front of elbow
}

TEST(DemoArmSceneTest, GhostAddsTranslucentCapsules) {
  DemoArmOptions options;
  options.ghost_elbow_flexion_deg = 60;
  const Scene scene = DemoArmScene(options);
  ASSERT_EQ(scene.capsules.size(), 24u);
  for (std::size_t i = 12; i < 24; ++i) EXPECT_LT(scene.capsules[i].colour.a, 1.0f);
}

}  // namespace
}  // namespace fesim::render
