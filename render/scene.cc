#include "render/scene.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace fesim::render {
namespace {

constexpr double kPi = 3.14159265358979323846;

double Clamp01(double v) {
  if (!(v > 0)) return 0;  // also NaN
  return v > 1 ? 1 : v;
}

Rgba Lerp(const Rgba& a, const Rgba& b, double t) {
  const auto mix = [t](float x, float y) { return static_cast<float>(x + (y - x) * t); };
  return Rgba{mix(a.r, b.r), mix(a.g, b.g), mix(a.b, b.b), mix(a.a, b.a)};
}

}  // namespace

namespace {

bool Finite(const Vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

[[noreturn]] void Fail(const std::string& item, std::size_t index, const std::string& what) {
  throw std::invalid_argument("scene: " + item + " " + std::to_string(index) + ": " + what);
}

}  // namespace

void ValidateScene(const Scene& scene) {
  for (std::size_t i = 0; i < scene.capsules.size(); ++i) {
    const Capsule& c = scene.capsules[i];
    if (!Finite(c.p0) || !Finite(c.p1)) Fail("capsule", i, "p0 and p1 must be finite");
    if (!(c.radius_m > 0) || !std::isfinite(c.radius_m)) {
      Fail("capsule", i, "radius_m must be > 0 and finite");
    }
  }
  for (std::size_t i = 0; i < scene.polylines.size(); ++i) {
    const Polyline& l = scene.polylines[i];
    if (!(l.width_px > 0) || !std::isfinite(l.width_px)) {
      Fail("polyline", i, "width_px must be > 0 and finite");
    }
    for (const Vec3& p : l.points) {
      if (!Finite(p)) Fail("polyline", i, "points must be finite");
    }
  }
  for (std::size_t i = 0; i < scene.pads.size(); ++i) {
    const Pad& p = scene.pads[i];
    if (!Finite(p.centre) || !Finite(p.normal) || !Finite(p.u_axis)) {
      Fail("pad", i, "centre, normal and u_axis must be finite");
    }
    if (p.normal.x == 0 && p.normal.y == 0 && p.normal.z == 0) Fail("pad", i, "normal is zero");
    if (!(p.half_u_m > 0) || !(p.half_v_m > 0) || !std::isfinite(p.half_u_m) ||
        !std::isfinite(p.half_v_m)) {
      Fail("pad", i, "half_u_m and half_v_m must be > 0 and finite");
    }
  }
  if (scene.draw_floor && (!(scene.grid_step_m > 0) || !std::isfinite(scene.grid_step_m) ||
                           !std::isfinite(scene.floor_y_m))) {
    throw std::invalid_argument("scene: grid_step_m must be > 0 and floor_y_m finite");
  }
}

CameraPreset ParseCameraPreset(const std::string& name) {
  if (name == "front") return CameraPreset::kFront;
  if (name == "side") return CameraPreset::kSide;
  if (name == "top") return CameraPreset::kTop;
  if (name == "orbit") return CameraPreset::kOrbit;
  throw std::invalid_argument("camera: unknown preset '" + name +
                              "' (expected front, side, top or orbit)");
}

std::string CameraPresetName(CameraPreset preset) {
  switch (preset) {
    case CameraPreset::kFront:
      return "front";
    case CameraPreset::kSide:
      return "side";
    case CameraPreset::kTop:
      return "top";
    case CameraPreset::kOrbit:
      return "orbit";
  }
  return "front";
}

CameraPose PoseAt(const Camera& camera, double time_s) {
  if (!(camera.distance_m > 0) || !std::isfinite(camera.distance_m)) {
    throw std::invalid_argument("camera: distance_m must be > 0");
  }
  if (!(camera.fov_y_deg > 0 && camera.fov_y_deg < 180)) {
    throw std::invalid_argument("camera: fov_y_deg must be in (0, 180)");
  }
  if (!(camera.elevation_deg > -90 && camera.elevation_deg < 90)) {
    throw std::invalid_argument("camera: elevation_deg must be in (-90, 90)");
  }
  if (camera.preset == CameraPreset::kOrbit &&
      (!(camera.orbit_period_s > 0) || !std::isfinite(camera.orbit_period_s))) {
    throw std::invalid_argument("camera: orbit_period_s must be > 0");
  }
  const double d = camera.distance_m;
  const double el = camera.elevation_deg * kPi / 180.0;
  CameraPose pose;
  pose.target = camera.target;
  pose.fov_y_deg = camera.fov_y_deg;
  pose.up = Vec3{0, 1, 0};
  double azimuth = 0;  // φ: eye direction (cos φ, ·, sin φ) in (X, Z).
  switch (camera.preset) {
    case CameraPreset::kFront:
      azimuth = 0;
      break;
    case CameraPreset::kSide:
      azimuth = kPi / 2;
      break;
    case CameraPreset::kOrbit: {
      const double turns = time_s / camera.orbit_period_s;
      azimuth = 2 * kPi * (turns - std::floor(turns));
      break;
    }
    case CameraPreset::kTop:
      pose.eye = Vec3{camera.target.x, camera.target.y + d, camera.target.z};
      pose.up = Vec3{1, 0, 0};
      return pose;
  }
  const double horizontal = d * std::cos(el);
  pose.eye =
      Vec3{camera.target.x + horizontal * std::cos(azimuth), camera.target.y + d * std::sin(el),
           camera.target.z + horizontal * std::sin(azimuth)};
  return pose;
}

Rgba ActivationColour(double activation) {
  const double a = Clamp01(activation);
  const Rgba rest{0.55f, 0.62f, 0.75f, 1.0f};
  const Rgba mid{0.98f, 0.55f, 0.10f, 1.0f};
  const Rgba full{0.85f, 0.05f, 0.05f, 1.0f};
  return a < 0.5 ? Lerp(rest, mid, a / 0.5) : Lerp(mid, full, (a - 0.5) / 0.5);
}

Rgba PulseWidthColour(double pulse_width_us) {
  const double t = Clamp01(pulse_width_us / kMaxPulseWidthUs);
  const Rgba off{0.25f, 0.25f, 0.28f, 1.0f};
  const Rgba mid{0.95f, 0.45f, 0.05f, 1.0f};
  const Rgba full{1.0f, 0.95f, 0.20f, 1.0f};
  return t < 0.5 ? Lerp(off, mid, t / 0.5) : Lerp(mid, full, (t - 0.5) / 0.5);
}

Rgba WithAlpha(Rgba colour, float alpha) {
  colour.a = std::clamp(alpha, 0.0f, 1.0f);
  return colour;
}

}  // namespace fesim::render
