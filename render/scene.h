// Scene description for the off-screen renderer: plain structs, no Simbody, no OpenGL.
//
// World frame W (OpenSim/Simbody convention): metres, Y up (gravity is −Y), X anterior (the way
// the subject faces), Z to the subject's right. Every point below is p_WX, expressed in W.
//
// The adapter that turns model poses into a Scene (sim/) fills these structs once per frame; the
// renderer (renderer.h) only reads them.
#pragma once

#include <string>
#include <vector>

namespace fesim::render {

/// A point or direction in the world frame W, m (or unitless for directions).
struct Vec3 {
  double x = 0;
  double y = 0;
  double z = 0;
};

/// Colour, each component 0–1 (linear, as sent to OpenGL). alpha < 1 draws translucent.
struct Rgba {
  float r = 0;
  float g = 0;
  float b = 0;
  float a = 1;
};

/// A shaded segment (bone): cylinder from p0 to p1 closed by hemispheres of the same radius.
/// p0 == p1 draws a sphere. alpha < 1 is a translucent "ghost" (the --compare arm), drawn after
/// all opaque geometry, back to front.
struct Capsule {
  Vec3 p0;                 ///< axis start p_WP0, m.
  Vec3 p1;                 ///< axis end p_WP1, m.
  double radius_m = 0.02;  ///< radius, m, > 0.
  Rgba colour{0.85f, 0.82f, 0.75f, 1.0f};
};

/// A line through points in order (muscle path, arm-support band). Unlit, constant width on screen.
struct Polyline {
  std::vector<Vec3> points;  ///< path points p_WPi, m; fewer than 2 points draws nothing.
  float width_px = 3;        ///< line width on screen, pixels, > 0.
  Rgba colour{0.8f, 0.1f, 0.1f, 1.0f};
  /// When true the line is drawn without depth test, over the bones (a muscle path that runs
  /// inside a capsule stays visible). Default: hidden by whatever is in front of it.
  bool draw_on_top = false;
};

/// A flat rectangular electrode pad lying on the skin.
/// Corners: centre ± half_u_m·u ± half_v_m·v with v = normal × u_axis.
struct Pad {
  Vec3 centre;             ///< pad centre p_WC, m.
  Vec3 normal{0, 0, 1};    ///< outward unit normal (away from the limb); normalised on use.
  Vec3 u_axis{1, 0, 0};    ///< in-plane direction of the first half size; made ⟂ normal on use.
  double half_u_m = 0.01;  ///< half size along u_axis, m, > 0.
  double half_v_m = 0.01;  ///< half size along normal × u_axis, m, > 0.
  Rgba colour{0.3f, 0.3f, 0.3f, 1.0f};
};

/// One stimulation channel bar in the overlay.
struct ChannelBar {
  std::string label;          ///< channel name, e.g. "ch3" (ASCII; unknown glyphs draw as '?').
  double pulse_width_us = 0;  ///< pulse width, µs; the bar spans 0–300 µs, values are clamped.
};

/// One joint-angle line in the overlay: "label  12.3°".
struct JointAngle {
  std::string label;     ///< joint name, e.g. "elbow_flexion".
  double angle_deg = 0;  ///< angle, degrees (the overlay is an edge: degrees, not rad).
};

/// 2D text drawn over the image after the 3D pass, with a built-in 5×7 bitmap font.
/// Top left: title and "t = 1.234 s", then one labelled bar per channel (0–300 µs).
/// Top right: one line per joint angle.
struct Overlay {
  bool visible = true;
  std::string title;                     ///< optional first line (e.g. trial name).
  std::vector<ChannelBar> channels;      ///< stimulation per channel.
  std::vector<JointAngle> joint_angles;  ///< joint angles.
};

/// Everything drawn in one frame.
struct Scene {
  double time_s = 0;  ///< frame time, s: shown in the overlay and turns the orbit camera.
  std::vector<Capsule> capsules;
  std::vector<Polyline> polylines;
  std::vector<Pad> pads;
  Overlay overlay;
  bool draw_floor = true;                      ///< floor plane with a grid, for depth.
  double floor_y_m = 0;                        ///< height of the floor plane, m (world Y).
  double grid_step_m = 0.25;                   ///< spacing of the floor grid lines, m, > 0.
  Rgba background{0.93f, 0.94f, 0.96f, 1.0f};  ///< clear colour (alpha ignored).
};

/// Checks a scene before drawing: finite points, capsule radius > 0, polyline width > 0, pad half
/// sizes > 0 and a non-zero normal, grid step > 0. Throws std::invalid_argument naming the item,
/// e.g. "scene: capsule 3: radius_m must be > 0 and finite".
void ValidateScene(const Scene& scene);

/// Camera presets (the CLI's --camera front|side|top|orbit).
///   front: eye on +X of the target (in front of the subject), looking −X; the subject's right
///          (+Z) appears on the image's left, as when facing a person.
///   side:  eye on +Z (the subject's right), looking −Z; anterior (+X) appears on the image right.
///   top:   eye on +Y, looking down; anterior (+X) at the top of the image, +Z on the right.
///   orbit: starts at front and turns about the vertical through the target, counter-clockwise
///          seen from above (front → right side → back → left side), one turn per orbit_period_s.
enum class CameraPreset { kFront, kSide, kTop, kOrbit };

/// Parses "front", "side", "top" or "orbit"; throws std::invalid_argument naming the value.
CameraPreset ParseCameraPreset(const std::string& name);
/// The lower-case name of a preset.
std::string CameraPresetName(CameraPreset preset);

/// A camera aimed at a target point from a distance.
struct Camera {
  CameraPreset preset = CameraPreset::kFront;
  Vec3 target{0, 1.1, 0.2};   ///< point looked at p_WT, m (default: around a right elbow).
  double distance_m = 1.6;    ///< eye–target distance, m, > 0.
  double elevation_deg = 12;  ///< eye raised above the target's horizontal plane, degrees
                              ///< (front, side, orbit; top is always 90°), in (−90, 90).
  double fov_y_deg = 45;      ///< vertical field of view, degrees, in (0, 180).
  double orbit_period_s = 8;  ///< seconds per orbit turn, > 0.
};

/// Where the camera is at one instant.
struct CameraPose {
  Vec3 eye;     ///< eye position p_WE, m.
  Vec3 target;  ///< point looked at p_WT, m.
  Vec3 up;      ///< unit up direction of the image in W.
  double fov_y_deg = 45;
};

/// The camera's pose at time_s (only orbit depends on time). Throws std::invalid_argument on a
/// non-positive distance or period, or fov/elevation out of range.
CameraPose PoseAt(const Camera& camera, double time_s);

/// Muscle activation 0–1 → colour: 0 pale blue-grey, 0.5 orange, 1 saturated red. Clamped; NaN is
/// drawn as 0.
Rgba ActivationColour(double activation);

/// Stimulation pulse width 0–300 µs → pad colour: 0 dark grey, 300 bright yellow. Clamped; NaN is
/// drawn as 0.
Rgba PulseWidthColour(double pulse_width_us);

/// Suggested colour of the --compare ghost arm: translucent blue (alpha 0.35).
inline constexpr Rgba kGhostColour{0.25f, 0.45f, 0.95f, 0.35f};

/// Same colour with another alpha (e.g. kGhostColour.a for a ghost in the bone's own colour).
Rgba WithAlpha(Rgba colour, float alpha);

/// Maximum pulse width shown by the overlay bars and colour scale, µs.
inline constexpr double kMaxPulseWidthUs = 300.0;

}  // namespace fesim::render
