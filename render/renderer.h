// Off-screen renderer: draws a Scene into an RGB image with OSMesa (Mesa's software rasteriser,
// llvmpipe) and legacy fixed-function OpenGL. No display, no GPU.
//
// Drawing order per frame: clear → floor and grid → opaque capsules (lit, smooth-shaded) → pads →
// depth-tested polylines → translucent capsules (alpha < 1), back to front, depth writes off →
// polylines with draw_on_top → glReadPixels, flipped to top-down → overlay (2D, CPU).
// The same scene and camera give the same bytes (deterministic rasterisation, no time or
// randomness inside).
#pragma once

#include <memory>

#include "render/image.h"
#include "render/scene.h"

namespace fesim::render {

/// Largest image side accepted, pixels (OSMesa's maximum viewport is larger; this bounds memory).
inline constexpr int kMaxImageSidePx = 8192;

/// Where a world point lands in an image rendered from a camera pose.
struct ImagePoint {
  double x_px = 0;        ///< column, pixels from the left edge (pixel centres at i + 0.5).
  double y_px = 0;        ///< row, pixels from the top edge (pixel centres at j + 0.5).
  bool in_front = false;  ///< false when the point is at or behind the eye plane (x, y unusable).
};

/// Projects p_WP (m) with the renderer's camera model (perspective, pose.fov_y_deg vertical
/// field of view, square pixels) into a width × height image, top-down rows. For overlays that
/// follow 3D points (labels) and for tests.
ImagePoint ProjectToImage(const CameraPose& pose, int width_px, int height_px, const Vec3& p_WP);

/// Owns one OSMesa context and its framebuffer (RAII, no globals). The context is made current on
/// the calling thread at the start of every Render(), so several renderers can be used one after
/// another on a thread; one renderer must not be used from two threads at once.
class OffscreenRenderer {
 public:
  /// Creates a width × height RGBA context with a 24-bit depth buffer. Throws std::runtime_error
  /// with a one-line message when a side is ≤ 0 or > kMaxImageSidePx, or OSMesa fails.
  OffscreenRenderer(int width_px, int height_px);
  ~OffscreenRenderer();
  /// Movable; a moved-from renderer may only be destroyed or assigned to.
  OffscreenRenderer(OffscreenRenderer&& other) noexcept;
  OffscreenRenderer& operator=(OffscreenRenderer&& other) noexcept;
  OffscreenRenderer(const OffscreenRenderer&) = delete;
  OffscreenRenderer& operator=(const OffscreenRenderer&) = delete;

  int width() const;   ///< pixels.
  int height() const;  ///< pixels.

  /// Renders one frame seen from PoseAt(camera, scene.time_s). Throws std::invalid_argument on an
  /// invalid camera, std::runtime_error if OpenGL reports an error.
  Image Render(const Scene& scene, const Camera& camera);
  /// Same, into an existing image (reuses its storage; for movie loops).
  void Render(const Scene& scene, const Camera& camera, Image* out);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fesim::render
