#include "apps/arm_scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "muscles/electrode_array.h"
#include "tendons/landsmeer.h"

namespace fesim {
namespace {

using SimTK::Vec3;

constexpr double kPi = 3.14159265358979323846;
/// |â × d̂| below this: the pin turns about the segment's own axis (no lateral offset).
constexpr double kAxialCrossNorm = 0.2;
/// Joint of each coordinate: 0 shoulder, 1 elbow, 2 wrist (pro/supination sits at the wrist in
/// this model), 3 MCP, 4 PIP, 5 DIP. Joint k moves segment k (sim::Segment order).
constexpr std::array<int, sim::kNumCoordinates> kJointOfCoordinate = {0, 0, 0, 1, 2, 2, 2, 3, 4, 5};
constexpr int kNumJoints = sim::kNumSegments;
/// Where a muscle's origin sits on its proximal segment, fraction of its length from the
/// segment's proximal joint (humerus, forearm, hand, proximal, middle, distal phalanx).
constexpr std::array<double, sim::kNumSegments> kOriginFraction = {0.55, 0.12, 0.35, 0.3, 0.3, 0.3};
/// Where a muscle's insertion sits on its distal segment, fraction of its length.
constexpr std::array<double, sim::kNumSegments> kInsertionFraction = {0.45, 0.2, 0.3,
                                                                      0.5,  0.5, 0.6};
/// Height of a thorax origin above the shoulder centre, m.
constexpr double kThoraxOriginHeight_m = 0.05;
/// Gap between a segment's capsule and the ring drawn for an arm-support cuff, m.
constexpr double kCuffRingGap_m = 0.006;
/// Length of the line drawn for a weight-compensation cable, m.
constexpr double kCableLength_m = 0.3;
constexpr int kRingPoints = 16;
/// Samples per polyline piece when testing whether a muscle path runs inside a capsule.
constexpr int kInsideSamples = 8;

render::Vec3 ToRender(const Vec3& v) { return {v[0], v[1], v[2]}; }

Vec3 UnitOrZero(const Vec3& v) {
  const double n = v.norm();
  return n > 1e-12 ? Vec3(v / n) : Vec3(0);
}

/// unit(a × d), or zero when the pin turns about the segment's own axis.
Vec3 SideOf(const Vec3& axis, const Vec3& dir) {
  const Vec3 c = SimTK::cross(axis, dir);
  return c.norm() < kAxialCrossNorm ? Vec3(0) : Vec3(c / c.norm());
}

/// Distance from p to the segment [a, b], m.
double DistanceToSegment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double len2 = ab.normSqr();
  const double t = len2 > 0 ? std::clamp(SimTK::dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
  return (p - (a + t * ab)).norm();
}

struct SegmentPose {
  Vec3 proximal;  ///< p_G of the body origin (proximal joint centre), m.
  Vec3 distal;    ///< p_G of (0, −length, 0), m.
  Vec3 dir;       ///< unit direction proximal → distal in G.
  double radius_m = 0;
};

std::array<SegmentPose, sim::kNumSegments> SegmentPoses(const sim::UpperLimbModel& model,
                                                        const SimTK::State& s) {
  std::array<SegmentPose, sim::kNumSegments> out;
  for (int k = 0; k < sim::kNumSegments; ++k) {
    const auto& body = model.SegmentBody(k);
    const double length = model.params().segments[k].length_m;
    out[k].proximal = body.findStationLocationInGround(s, Vec3(0));
    out[k].distal = body.findStationLocationInGround(s, Vec3(0, -length, 0));
    out[k].dir = body.expressVectorInGroundFrame(s, Vec3(0, -1, 0));
    out[k].radius_m = ArmSegmentRadius(model.params(), k);
  }
  return out;
}

/// Pin axis of a coordinate in G (a Pin turns about the common Z of its inboard and outboard
/// frames).
Vec3 AxisInGround(const sim::UpperLimbModel& model, const SimTK::State& s, int coordinate) {
  const auto& body = model.CoordinateBody(coordinate);
  return body.getBodyRotation(s) * body.getOutboardFrame(s).R().z();
}

bool IsAxial(int coordinate) {
  return coordinate == sim::kShoulderRotation || coordinate == sim::kProSup;
}

struct Capsule3 {
  Vec3 p0, p1;
  double radius_m;
};

/// The muscle path of one muscle (see arm_scene.h).
std::vector<Vec3> MusclePath(const sim::ModelParams& params, const std::vector<double>& q,
                             const std::array<SegmentPose, sim::kNumSegments>& seg,
                             const std::array<Vec3, sim::kNumCoordinates>& axes,
                             const tendons::MusclePath& path) {
  std::array<bool, kNumJoints> crossed{};
  bool any_lateral = false;
  for (const auto& c : path.crossings) any_lateral = any_lateral || !IsAxial(c.joint);
  for (const auto& c : path.crossings) {
    if (c.joint < 0 || c.joint >= sim::kNumCoordinates) continue;
    if (any_lateral && IsAxial(c.joint)) continue;
    crossed[kJointOfCoordinate[c.joint]] = true;
  }
  // Signed offsets at each joint, with the proximal and the distal segment's direction.
  std::array<Vec3, kNumJoints> v_prox, v_dist;
  v_prox.fill(Vec3(0));
  v_dist.fill(Vec3(0));
  for (const auto& c : path.crossings) {
    if (c.joint < 0 || c.joint >= sim::kNumCoordinates) continue;
    const int k = kJointOfCoordinate[c.joint];
    const double r = tendons::MomentArm(c.arm, q[c.joint]);
    const Vec3 d_prox = k == 0 ? Vec3(0, -1, 0) : seg[k - 1].dir;
    v_prox[k] += r * SideOf(axes[c.joint], d_prox);
    v_dist[k] += r * SideOf(axes[c.joint], seg[k].dir);
  }
  int first = -1, last = -1;
  for (int k = 0; k < kNumJoints; ++k) {
    if (!crossed[k]) continue;
    if (first < 0) first = k;
    last = k;
  }
  std::vector<Vec3> points;
  if (first < 0) return points;

  // Origin on the proximal segment of the first joint (the thorax for the shoulder).
  const Vec3 side_origin =
      UnitOrZero(v_prox[first]).norm() > 0 ? UnitOrZero(v_prox[first]) : UnitOrZero(v_dist[first]);
  if (first == 0) {
    const double r = seg[sim::kHumerus].radius_m + kMuscleClearance_m;
    points.push_back(seg[sim::kHumerus].proximal + Vec3(0, kThoraxOriginHeight_m, 0) +
                     r * side_origin);
  } else {
    const int p = first - 1;
    const double along = kOriginFraction[p] * params.segments[p].length_m;
    points.push_back(seg[p].proximal + along * seg[p].dir +
                     (seg[p].radius_m + kMuscleClearance_m) * side_origin);
  }
  // One via point per crossed joint.
  for (int k = first; k <= last; ++k) {
    if (!crossed[k]) continue;
    const double joint_radius = std::max(seg[k].radius_m, k > 0 ? seg[k - 1].radius_m : 0.0);
    Vec3 side = UnitOrZero(UnitOrZero(v_prox[k]) + UnitOrZero(v_dist[k]));
    if (side.norm() == 0) side = UnitOrZero(v_dist[k]);
    const double size = std::max(v_dist[k].norm(), joint_radius + kMuscleClearance_m);
    points.push_back(seg[k].proximal + (side.norm() > 0 ? size : 0.0) * side);
  }
  // Insertion on the distal segment of the last joint.
  const Vec3 side_insertion =
      UnitOrZero(v_dist[last]).norm() > 0 ? UnitOrZero(v_dist[last]) : UnitOrZero(v_prox[last]);
  const double along = kInsertionFraction[last] * params.segments[last].length_m;
  points.push_back(seg[last].proximal + along * seg[last].dir +
                   (seg[last].radius_m + kMuscleClearance_m) * side_insertion);
  return points;
}

bool RunsInside(const std::vector<Vec3>& points, const std::vector<Capsule3>& capsules) {
  for (std::size_t i = 0; i + 1 < points.size(); ++i) {
    for (int k = 0; k <= kInsideSamples; ++k) {
      const double t = static_cast<double>(k) / kInsideSamples;
      const Vec3 p = points[i] + t * (points[i + 1] - points[i]);
      for (const auto& c : capsules) {
        if (DistanceToSegment(p, c.p0, c.p1) < c.radius_m) return true;
      }
    }
  }
  return false;
}

/// Ring around segment `segment` at the height of a cuff point p_B.
render::Polyline CuffRing(const sim::UpperLimbModel& model, const SimTK::State& s, int segment,
                          const Vec3& cuff_B) {
  render::Polyline ring;
  ring.width_px = 4;
  ring.colour = kSupportColour;
  const double r = ArmSegmentRadius(model.params(), segment) + kCuffRingGap_m;
  const auto& body = model.SegmentBody(segment);
  for (int k = 0; k <= kRingPoints; ++k) {
    const double a = 2 * kPi * k / kRingPoints;
    ring.points.push_back(ToRender(
        body.findStationLocationInGround(s, Vec3(r * std::cos(a), cuff_B[1], r * std::sin(a)))));
  }
  return ring;
}

Vec3 ToVec3(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

}  // namespace

double ArmSegmentRadius(const sim::ModelParams& params, int segment) {
  const auto& s = params.segments;
  switch (segment) {
    case sim::kHumerus:
      return 0.10 * s[sim::kHumerus].length_m;
    case sim::kForearm:
      return 0.11 * s[sim::kForearm].length_m;
    case sim::kHand:
      return 0.13 * s[sim::kHand].length_m;
    case sim::kProximalPhalanx:
      return 0.050 * s[sim::kHand].length_m;
    case sim::kMiddlePhalanx:
      return 0.045 * s[sim::kHand].length_m;
    case sim::kDistalPhalanx:
      return 0.040 * s[sim::kHand].length_m;
    default:
      throw std::invalid_argument("ArmSegmentRadius: segment " + std::to_string(segment) +
                                  " is outside [0, " + std::to_string(sim::kNumSegments - 1) + "]");
  }
}

render::Scene ArmScene(const sim::UpperLimbModel& model, const SimTK::State& posed,
                       const ArmSceneInputs& inputs) {
  const sim::ModelParams& params = model.params();
  const int nc = model.num_channels();
  const int nm = model.num_muscles();
  const auto check_size = [](const char* what, std::size_t n, int expected, const char* per) {
    if (n != 0 && n != static_cast<std::size_t>(expected)) {
      throw std::invalid_argument(std::string("ArmScene: ") + what + " has " + std::to_string(n) +
                                  " entries, the model has " + std::to_string(expected) + " " +
                                  per);
    }
  };
  check_size("stimulation_us", inputs.stimulation_us.size(), nc, "channels");
  check_size("channel_names", inputs.channel_names.size(), nc, "channels");
  check_size("activation", inputs.activation.size(), nm, "muscles");

  render::Scene scene;
  scene.time_s = inputs.time_s;
  const auto seg = SegmentPoses(model, posed);

  // Segments, then the thorax.
  std::vector<Capsule3> solid;
  for (int k = 0; k < sim::kNumSegments; ++k) {
    scene.capsules.push_back(
        {ToRender(seg[k].proximal), ToRender(seg[k].distal), seg[k].radius_m, kBoneColour});
    solid.push_back({seg[k].proximal, seg[k].distal, seg[k].radius_m});
  }
  const Vec3 shoulder = ToVec3(params.shoulder_in_ground_m);
  const double thorax_radius = 0.6 * std::abs(shoulder[2]);
  const Vec3 thorax_top(shoulder[0] - 0.02, shoulder[1] - 0.05, 0.0);
  const Vec3 thorax_bottom(shoulder[0] - 0.02, shoulder[1] - 0.5, 0.0);
  if (thorax_radius > 0) {
    scene.capsules.push_back(
        {ToRender(thorax_bottom), ToRender(thorax_top), thorax_radius, kThoraxColour});
    solid.push_back({thorax_bottom, thorax_top, thorax_radius});
  }
  if (inputs.ghost != nullptr) {
    const auto ghost = SegmentPoses(model, *inputs.ghost);
    for (int k = 0; k < sim::kNumSegments; ++k) {
      scene.capsules.push_back({ToRender(ghost[k].proximal), ToRender(ghost[k].distal),
                                ghost[k].radius_m, render::kGhostColour});
    }
  }

  // Muscles.
  const std::vector<double> q = model.GetQs(posed);
  std::array<Vec3, sim::kNumCoordinates> axes;
  for (int i = 0; i < sim::kNumCoordinates; ++i) axes[i] = AxisInGround(model, posed, i);
  for (int j = 0; j < nm; ++j) {
    const std::vector<Vec3> path = MusclePath(params, q, seg, axes, params.muscles[j].path);
    render::Polyline line;
    for (const auto& p : path) line.points.push_back(ToRender(p));
    line.width_px = 3;
    const double a = inputs.activation.empty() ? std::nan("") : inputs.activation[j];
    line.colour = std::isfinite(a) ? render::ActivationColour(a) : kNeutralMuscleColour;
    line.draw_on_top = RunsInside(path, solid);
    scene.polylines.push_back(std::move(line));
  }

  // Arm support.
  for (const auto& band : params.bands) {
    const Vec3 cuff_B = ToVec3(band.cuff_in_segment_m);
    const Vec3 cuff = model.SegmentBody(band.segment).findStationLocationInGround(posed, cuff_B);
    scene.polylines.push_back(
        {{ToRender(cuff), ToRender(ToVec3(band.anchor_in_ground_m))}, 4, kSupportColour, false});
    scene.polylines.push_back(CuffRing(model, posed, band.segment, cuff_B));
  }
  const Vec3 g = ToVec3(params.gravity_m_s2);
  const Vec3 up = g.norm() > 0 ? Vec3(-g / g.norm()) : Vec3(0, 1, 0);
  for (const auto& w : params.weight_compensation) {
    const Vec3 cuff_B = ToVec3(w.cuff_in_segment_m);
    const Vec3 cuff = model.SegmentBody(w.segment).findStationLocationInGround(posed, cuff_B);
    scene.polylines.push_back(
        {{ToRender(cuff), ToRender(cuff + kCableLength_m * up)}, 4, kSupportColour, false});
    scene.polylines.push_back(CuffRing(model, posed, w.segment, cuff_B));
  }

  // Electrode array on the forearm surface.
  const auto& array = params.array;
  const std::vector<muscles::SkinPoint> pads =
      muscles::PadGrid(array.rows, array.cols, array.pitch_m, array.origin);
  std::vector<double> pad_us(pads.size(), 0.0);
  for (int k = 0; k < nc && !inputs.stimulation_us.empty(); ++k) {
    const double u = inputs.stimulation_us[k];
    for (int p : params.channels[k].pads) {
      if (p >= 0 && p < static_cast<int>(pads.size()) && std::isfinite(u)) {
        pad_us[p] = std::max(pad_us[p], u);
      }
    }
  }
  const auto& forearm = model.SegmentBody(sim::kForearm);
  const double skin_r = seg[sim::kForearm].radius_m + kPadLift_m;
  for (std::size_t p = 0; p < pads.size(); ++p) {
    const double phi = pads[p].around_m / skin_r;
    const Vec3 n_B(std::cos(phi), 0, std::sin(phi));
    render::Pad pad;
    pad.centre = ToRender(forearm.findStationLocationInGround(
        posed, Vec3(skin_r * n_B[0], -pads[p].along_m, skin_r * n_B[2])));
    pad.normal = ToRender(forearm.expressVectorInGroundFrame(posed, n_B));
    pad.u_axis = ToRender(forearm.expressVectorInGroundFrame(posed, Vec3(0, -1, 0)));
    pad.half_u_m = 0.42 * array.pitch_m;
    pad.half_v_m = 0.42 * array.pitch_m;
    pad.colour = render::PulseWidthColour(pad_us[p]);
    scene.pads.push_back(pad);
  }

  // Overlay.
  scene.overlay.title = inputs.title;
  for (int k = 0; k < nc; ++k) {
    scene.overlay.channels.push_back(
        {inputs.channel_names.empty() ? params.channels[k].name : inputs.channel_names[k],
         inputs.stimulation_us.empty() ? 0.0 : inputs.stimulation_us[k]});
  }
  for (int i = 0; i < sim::kNumCoordinates; ++i) {
    scene.overlay.joint_angles.push_back({sim::CoordinateNames()[i], q[i] * 180.0 / kPi});
  }

  // Floor below the fully extended, hanging arm.
  double reach = 0;
  for (const auto& s : params.segments) reach += s.length_m;
  scene.floor_y_m = shoulder[1] - reach - 0.05;
  return scene;
}

render::Vec3 ArmCameraTarget(const sim::UpperLimbModel& model, const SimTK::State& state) {
  const Vec3 s = model.SegmentBody(sim::kHumerus).findStationLocationInGround(state, Vec3(0));
  const Vec3 w = model.SegmentBody(sim::kHand).findStationLocationInGround(state, Vec3(0));
  return ToRender(0.5 * (s + w));
}

PoseColumns FindPoseColumns(const Trial& trial, const std::string& source) {
  std::string allowed;
  for (const auto& n : sim::CoordinateNames()) allowed += (allowed.empty() ? "" : ", ") + n;
  PoseColumns out;
  for (std::size_t c = 0; c < trial.names.size(); ++c) {
    const std::string& name = trial.names[c];
    if (name.rfind("q.", 0) != 0) continue;
    const int i = sim::CoordinateIndex(name.substr(2));
    if (i < 0) {
      throw std::runtime_error(source + ": column " + name +
                               " is not a model coordinate (allowed: " + allowed + ")");
    }
    out.column.push_back(static_cast<int>(c));
    out.coordinate.push_back(i);
  }
  if (out.column.empty()) {
    throw std::runtime_error(source + ": no q.<coordinate> column (expected one or more of " +
                             allowed + ")");
  }
  return out;
}

void SetPoseFromTrialRow(const sim::UpperLimbModel& model, const Trial& trial,
                         const PoseColumns& columns, std::size_t row, SimTK::State* state) {
  if (row >= trial.size()) {
    throw std::invalid_argument("SetPoseFromTrialRow: row " + std::to_string(row) +
                                " is outside a trial of " + std::to_string(trial.size()));
  }
  for (std::size_t k = 0; k < columns.column.size(); ++k) {
    const double v = trial.columns.at(columns.column[k])[row];
    if (std::isfinite(v)) model.CoordinateBody(columns.coordinate[k]).setOneQ(*state, 0, v);
  }
  model.system().realize(*state, SimTK::Stage::Position);
}

Trial ResampleTrial(const Trial& trial, const std::vector<double>& times) {
  const std::size_t n = trial.size();
  if (n == 0) throw std::invalid_argument("ResampleTrial: the trial has no samples");
  for (std::size_t i = 1; i < times.size(); ++i) {
    if (times[i] < times[i - 1]) throw std::invalid_argument("ResampleTrial: decreasing times");
  }
  Trial out;
  out.metadata = trial.metadata;
  out.time = times;
  out.names = trial.names;
  out.columns.resize(trial.columns.size());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t c = 0; c < trial.columns.size(); ++c) {
    const std::vector<double>& v = trial.columns[c];
    // last_valid[i]: index of the last finite value at or before sample i, or −1.
    std::vector<long> last_valid(n, -1);
    long first_valid = -1;
    for (std::size_t i = 0; i < n; ++i) {
      const bool ok = std::isfinite(v[i]);
      last_valid[i] = ok ? static_cast<long>(i) : (i > 0 ? last_valid[i - 1] : -1);
      if (ok && first_valid < 0) first_valid = static_cast<long>(i);
    }
    std::vector<double>& out_col = out.columns[c];
    out_col.resize(times.size(), nan);
    std::size_t j = 0;  // last sample with time ≤ t (frames are non-decreasing)
    for (std::size_t f = 0; f < times.size(); ++f) {
      const double t = times[f];
      if (first_valid < 0) continue;
      if (t <= trial.time[0]) {
        out_col[f] = std::isfinite(v[0]) ? v[0] : v[first_valid];
        continue;
      }
      while (j + 1 < n && trial.time[j + 1] <= t) ++j;
      if (j + 1 < n && std::isfinite(v[j]) && std::isfinite(v[j + 1])) {
        const double w = (t - trial.time[j]) / (trial.time[j + 1] - trial.time[j]);
        out_col[f] = v[j] + w * (v[j + 1] - v[j]);
      } else if (last_valid[j] >= 0) {
        out_col[f] = v[last_valid[j]];
      } else {
        out_col[f] = v[first_valid];
      }
    }
  }
  return out;
}

}  // namespace fesim
