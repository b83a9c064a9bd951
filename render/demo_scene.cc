#include "render/demo_scene.h"

#include <cmath>
#include <string>

namespace fesim::render {
namespace {

constexpr double kPi = 3.14159265358979323846;

Vec3 Add(const Vec3& a, const Vec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec3 Scale(const Vec3& a, double s) { return {a.x * s, a.y * s, a.z * s}; }

/// Frame of the forearm: elbow position, axis d (elbow → wrist), in-plane normal p, and Z.
struct ForearmFrame {
  Vec3 elbow;
  Vec3 d;
  Vec3 p;
  Vec3 z{0, 0, 1};
  /// elbow + a·d + b·p + c·z
  Vec3 At(double a, double b, double c) const {
    return Add(elbow, Add(Scale(d, a), Add(Scale(p, b), Scale(z, c))));
  }
};

ForearmFrame MakeForearm(double flexion_deg) {
  const double t = flexion_deg * kPi / 180.0;
  ForearmFrame f;
  f.elbow = Vec3{kDemoShoulder.x, kDemoShoulder.y - kDemoHumerusLength_m, kDemoShoulder.z};
  f.d = Vec3{std::sin(t), -std::cos(t), 0};  // rotation of −Y about +Z by t
  f.p = Vec3{std::cos(t), std::sin(t), 0};   // rotation of +X about +Z by t (anterior side)
  return f;
}

void AddArmCapsules(const ForearmFrame& f, const Rgba& bone, std::vector<Capsule>* out) {
  const double L = kDemoForearmLength_m;
  out->push_back({kDemoShoulder, f.elbow, 0.032, bone});                           // humerus
  out->push_back({f.At(0.0, -0.005, -0.012), f.At(L, 0.0, -0.012), 0.018, bone});  // ulna
  out->push_back({f.At(0.02, 0.005, 0.012), f.At(L, 0.0, 0.012), 0.018, bone});    // radius
  out->push_back({f.At(L + 0.03, 0, 0), f.At(L + 0.08, 0, 0), 0.026, bone});       // hand
  for (int k = 0; k < 4; ++k) {  // fingers, 2 phalanges each, slightly curled
    const double c = -0.027 + 0.018 * k;
    const Vec3 base = f.At(L + 0.11, 0.0, c);
    const Vec3 mid = f.At(L + 0.145, 0.006, c);
    const Vec3 tip = f.At(L + 0.17, 0.02, c);
    out->push_back({base, mid, 0.008, bone});
    out->push_back({mid, tip, 0.007, bone});
  }
}

}  // namespace

Scene DemoArmScene(const DemoArmOptions& options) {
  Scene scene;
  scene.time_s = options.time_s;
  const ForearmFrame f = MakeForearm(options.elbow_flexion_deg);
  const double L = kDemoForearmLength_m;
  AddArmCapsules(f, Rgba{0.88f, 0.84f, 0.76f, 1.0f}, &scene.capsules);

  // Muscles: origin on the shoulder or humerus, insertion on the forearm.
  const Vec3 s = kDemoShoulder;
  const auto humerus = [&s](double down, double x, double z) {
    return Vec3{s.x + x, s.y - down, s.z + z};
  };
  const std::vector<std::vector<Vec3>> paths = {
      {humerus(0.0, 0.045, 0.0), humerus(0.2, 0.05, 0.0), f.At(0.05, 0.03, 0.01)},   // biceps
      {humerus(0.15, 0.035, -0.01), f.At(0.04, 0.03, -0.01)},                        // brachialis
      {humerus(0.2, 0.02, 0.035), f.At(0.08, 0.03, 0.03), f.At(0.24, 0.01, 0.025)},  // brachiorad.
      {humerus(0.0, -0.045, 0.0), humerus(0.2, -0.05, 0.0), f.At(-0.02, -0.03, 0.0)},   // tri long
      {humerus(0.08, -0.04, 0.02), f.At(-0.02, -0.03, 0.01)},                           // tri lat
      {humerus(0.12, -0.035, -0.02), f.At(-0.02, -0.03, -0.01)},                        // tri med
      {humerus(0.28, -0.02, 0.03), f.At(0.04, -0.025, 0.015)},                          // anconeus
      {humerus(0.29, 0.01, -0.035), f.At(0.12, 0.028, -0.02), f.At(L, 0.02, -0.015)},   // FCR
      {humerus(0.29, 0.0, -0.04), f.At(0.12, 0.015, -0.035), f.At(L, 0.01, -0.03)},     // FCU
      {humerus(0.26, 0.01, 0.04), f.At(0.12, -0.02, 0.03), f.At(L, -0.02, 0.02)},       // ECR
      {humerus(0.28, -0.01, 0.04), f.At(0.12, -0.03, 0.0), f.At(L, -0.025, -0.01)},     // ECU
      {humerus(0.29, 0.01, -0.03), f.At(0.13, 0.032, 0.0), f.At(L + 0.1, 0.015, 0.0)},  // FDS
  };
  for (std::size_t i = 0; i < paths.size(); ++i) {
    const double activation = 0.5 + 0.5 * std::sin(options.time_s * 2.0 + 0.7 * i);
    scene.polylines.push_back({paths[i], 3.0f, ActivationColour(activation), true});
  }
  // Arm-support bands: a loop around the upper arm and one around the forearm.
  for (int band = 0; band < 2; ++band) {
    Polyline loop;
    loop.width_px = 4.0f;
    loop.colour = Rgba{0.15f, 0.35f, 0.75f, 1.0f};
    for (int k = 0; k <= 16; ++k) {
      const double a = 2 * kPi * k / 16;
      if (band == 0) {
        loop.points.push_back(humerus(0.15, 0.04 * std::cos(a), 0.04 * std::sin(a)));
      } else {
        loop.points.push_back(f.At(0.1, 0.04 * std::cos(a), 0.04 * std::sin(a)));
      }
    }
    scene.polylines.push_back(loop);
  }

  // Electrode array: 3 rows along the forearm × 8 pads around it.
  for (int row = 0; row < 3; ++row) {
    for (int k = 0; k < 8; ++k) {
      const double a = 2 * kPi * (k + 0.5) / 8;
      const Vec3 n = Add(Scale(f.p, std::cos(a)), Scale(f.z, std::sin(a)));
      const int channel = (row * 8 + k) % 8;
      const double us = options.pulse_width_us * (1.0 - 0.12 * channel);
      Pad pad;
      pad.centre = Add(f.At(0.12 + 0.045 * row, 0, 0), Scale(n, 0.036));
      pad.normal = n;
      pad.u_axis = f.d;
      pad.half_u_m = 0.018;
      pad.half_v_m = 0.011;
      pad.colour = PulseWidthColour(us);
      scene.pads.push_back(pad);
    }
  }

  if (options.ghost_elbow_flexion_deg) {
    AddArmCapsules(MakeForearm(*options.ghost_elbow_flexion_deg), kGhostColour, &scene.capsules);
  }

  scene.overlay.title = "demo arm";
  for (int c = 0; c < 8; ++c) {
    scene.overlay.channels.push_back(
        {"ch" + std::to_string(c + 1), options.pulse_width_us * (1.0 - 0.12 * c)});
  }
  scene.overlay.joint_angles = {{"shoulder_elevation", 0.0},
                                {"elbow_flexion", options.elbow_flexion_deg},
                                {"pro_sup", 10.0},
                                {"wrist_flexion", -5.0}};
  return scene;
}

}  // namespace fesim::render
