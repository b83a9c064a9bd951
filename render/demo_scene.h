// A synthetic right-arm scene built from plain geometry (no model): used by the render tests, the
// benchmark and as an example of what the model adapter produces. Not anatomy: proportions only.
#pragma once

#include <optional>

#include "render/scene.h"

namespace fesim::render {

/// Options for DemoArmScene.
struct DemoArmOptions {
  double elbow_flexion_deg = 30;  ///< elbow flexion, degrees: 0 = forearm hanging down (−Y),
                                  ///< 90 = forearm pointing anterior (+X). Flexion is about +Z.
  std::optional<double> ghost_elbow_flexion_deg;  ///< adds a translucent ghost arm at this flexion.
  double time_s = 0;                              ///< frame time, s (overlay and orbit camera).
  double pulse_width_us = 150;  ///< stimulation of the first channel, µs; others scale from it.
};

/// Shoulder centre of the demo arm p_WS, m (the humerus hangs from it along −Y).
inline constexpr Vec3 kDemoShoulder{0.0, 1.40, 0.20};
/// Humerus length (shoulder to elbow), m.
inline constexpr double kDemoHumerusLength_m = 0.30;
/// Forearm length (elbow to wrist), m.
inline constexpr double kDemoForearmLength_m = 0.26;

/// The demo arm: 12 capsules (humerus, ulna, radius, hand, 4 fingers × 2 phalanges), 14 polylines
/// (12 muscles coloured by a made-up activation, 2 arm-support bands), 24 electrode pads (3 rows
/// × 8 around the forearm), an overlay with 8 channels and 4 joint angles; with a ghost, 12 more
/// translucent capsules.
Scene DemoArmScene(const DemoArmOptions& options = {});

}  // namespace fesim::render
