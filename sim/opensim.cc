#include "sim/opensim.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace fesim::sim {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

using Vec = std::array<double, 3>;

/// Where a joint's parent offset frame sits in its parent body.
enum class At { kShoulder, kOrigin, kParentSegmentEnd, kIndexMcp };

/// One pin of the chain (upper_limb_model.cc, UpperLimbModel's constructor): the coordinate
/// moves `child` relative to the child body of the coordinate before it (ground for the first)
/// about `axis` (in the parent frame at zero angles).
struct ChainJoint {
  const char* child;  ///< body name: a SegmentNames() entry or a massless frame.
  int segment;        ///< Segment of the child, or −1 for a massless frame.
  Vec axis;
  At at;
};

const std::array<ChainJoint, kNumCoordinates>& Chain() {
  static const std::array<ChainJoint, kNumCoordinates> chain = {{
      {"shoulder_plane_frame", -1, {0, 1, 0}, At::kShoulder},                // shoulder_elv_plane
      {"shoulder_elevation_frame", -1, {-1, 0, 0}, At::kOrigin},             // shoulder_elevation
      {"humerus", kHumerus, {0, 1, 0}, At::kOrigin},                         // shoulder_rotation
      {"forearm", kForearm, {0, 0, 1}, At::kParentSegmentEnd},               // elbow_flexion
      {"radius_frame", -1, {0, 1, 0}, At::kParentSegmentEnd},                // pro_sup
      {"carpal_frame", -1, {1, 0, 0}, At::kOrigin},                          // wrist_flexion
      {"hand", kHand, {0, 0, 1}, At::kOrigin},                               // wrist_deviation
      {"proximal_phalanx", kProximalPhalanx, {1, 0, 0}, At::kIndexMcp},      // mcp_flexion
      {"middle_phalanx", kMiddlePhalanx, {1, 0, 0}, At::kParentSegmentEnd},  // pip_flexion
      {"distal_phalanx", kDistalPhalanx, {1, 0, 0}, At::kParentSegmentEnd},  // dip_flexion
  }};
  return chain;
}

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string Triple(const Vec& v) { return Num(v[0]) + " " + Num(v[1]) + " " + Num(v[2]); }

Vec Cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

/// The child body of the nearest coordinate at or before c (stepping by `step`) that has a
/// segment, or −1.
int SegmentCoordinate(int c, int step) {
  for (; c >= 0 && c < kNumCoordinates; c += step) {
    if (Chain()[c].segment >= 0) return c;
  }
  return -1;
}

/// The parent offset frame of coordinate c in its parent body, m.
Vec ParentOffset(const ModelParams& m, int c) {
  const auto length_of_parent = [&m, c] {
    const int s = c > 0 ? Chain()[c - 1].segment : -1;
    return s >= 0 ? m.segments[s].length_m : 0.0;
  };
  switch (Chain()[c].at) {
    case At::kShoulder:
      return m.shoulder_in_ground_m;
    case At::kOrigin:
      return {0, 0, 0};
    case At::kParentSegmentEnd:
      return {0, -(c == kProSup ? m.segments[kForearm].length_m : length_of_parent()), 0};
    case At::kIndexMcp:
      return {m.index_mcp_offset_m, -m.segments[kHand].length_m, 0};
  }
  return {0, 0, 0};
}

/// Two unit axes completing `a` (unit, along a principal axis or not) to independent rotations.
std::array<Vec, 2> OtherAxes(const Vec& a) {
  const Vec helper = std::abs(a[0]) < 0.9 ? Vec{1, 0, 0} : Vec{0, 1, 0};
  Vec b = Cross(a, helper);
  const double nb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
  for (double& x : b) x /= nb;
  return {b, Cross(a, b)};
}

std::string TransformAxis(const std::string& name, const Vec& axis, const std::string& coordinate) {
  std::string s = "            <TransformAxis name=\"" + name + "\">\n";
  s += "              <coordinates>" + coordinate + "</coordinates>\n";
  s += "              <axis>" + Triple(axis) + "</axis>\n";
  s += coordinate.empty()
           ? "              <function><Constant><value>0</value></Constant></function>\n"
           : "              <function><LinearFunction><coefficients>1 0</coefficients>"
             "</LinearFunction></function>\n";
  return s + "            </TransformAxis>\n";
}

std::string Body(const std::string& name, double mass, const Vec& com, const Vec& inertia) {
  return "        <Body name=\"" + name + "\">\n          <mass>" + Num(mass) +
         "</mass>\n          <mass_center>" + Triple(com) + "</mass_center>\n          <inertia>" +
         Triple(inertia) + " 0 0 0</inertia>\n        </Body>\n";
}

std::string Joint(const ModelParams& m, int c) {
  const ChainJoint& j = Chain()[c];
  const std::string name = CoordinateNames()[c];
  const std::string parent = c == 0 ? "/ground" : std::string("/bodyset/") + Chain()[c - 1].child;
  const CoordinateParams& cp = m.coordinates[c];
  const std::array<Vec, 2> others = OtherAxes(j.axis);
  std::string s = "        <CustomJoint name=\"" + name + "\">\n";
  s += "          <socket_parent_frame>" + name + "_parent</socket_parent_frame>\n";
  s += "          <socket_child_frame>" + name + "_child</socket_child_frame>\n";
  s += "          <coordinates>\n            <Coordinate name=\"" + name + "\">\n";
  s += "              <motion_type>rotational</motion_type>\n";
  s += "              <default_value>" + Num(cp.initial_rad) + "</default_value>\n";
  s += "              <range>" + Num(cp.passive.min_angle_rad) + " " +
       Num(cp.passive.max_angle_rad) + "</range>\n";
  s += "              <clamped>false</clamped>\n";
  s += std::string("              <locked>") +
       (cp.mode == CoordinateMode::kLocked ? "true" : "false") + "</locked>\n";
  s += "            </Coordinate>\n          </coordinates>\n          <frames>\n";
  s += "            <PhysicalOffsetFrame name=\"" + name +
       "_parent\">\n              <socket_parent>" + parent +
       "</socket_parent>\n              <translation>" + Triple(ParentOffset(m, c)) +
       "</translation>\n              <orientation>0 0 0</orientation>\n"
       "            </PhysicalOffsetFrame>\n";
  s += "            <PhysicalOffsetFrame name=\"" + name +
       "_child\">\n              <socket_parent>" + "/bodyset/" + j.child +
       "</socket_parent>\n              <translation>0 0 0</translation>\n"
       "              <orientation>0 0 0</orientation>\n            </PhysicalOffsetFrame>\n";
  s += "          </frames>\n          <SpatialTransform>\n";
  s += TransformAxis("rotation1", j.axis, name) + TransformAxis("rotation2", others[0], "") +
       TransformAxis("rotation3", others[1], "");
  s += TransformAxis("translation1", {1, 0, 0}, "") + TransformAxis("translation2", {0, 1, 0}, "") +
       TransformAxis("translation3", {0, 0, 1}, "");
  return s + "          </SpatialTransform>\n        </CustomJoint>\n";
}

std::string Muscle(const ModelParams& m, const MuscleParams& mu) {
  const OsimPathPoints p = MuscleDisplayPath(m, mu);
  const auto point = [&mu](const std::string& suffix, const std::string& body, const Vec& at) {
    return "                <PathPoint name=\"" + mu.name + "-" + suffix +
           "\">\n                  <socket_parent_frame>" +
           (body == "ground" ? std::string("/ground") : "/bodyset/" + body) +
           "</socket_parent_frame>\n                  <location>" + Triple(at) +
           "</location>\n                </PathPoint>\n";
  };
  std::string s = "        <Thelen2003Muscle name=\"" + mu.name + "\">\n";
  s += "          <GeometryPath name=\"path\">\n            <PathPointSet>\n              "
       "<objects>\n";
  s += point("P1", p.origin_body, p.origin_m) + point("P2", p.insertion_body, p.insertion_m);
  s += "              </objects>\n            </PathPointSet>\n          </GeometryPath>\n";
  s += "          <max_isometric_force>" + Num(mu.hill.max_isometric_force_n) +
       "</max_isometric_force>\n";
  s += "          <optimal_fiber_length>" + Num(mu.hill.optimal_fibre_length_m) +
       "</optimal_fiber_length>\n";
  s += "          <tendon_slack_length>" + Num(mu.hill.tendon_slack_length_m) +
       "</tendon_slack_length>\n";
  s += "          <pennation_angle_at_optimal>" + Num(mu.hill.pennation_at_optimal_rad) +
       "</pennation_angle_at_optimal>\n";
  s += "          <max_contraction_velocity>" + Num(mu.hill.max_contraction_velocity) +
       "</max_contraction_velocity>\n";
  return s + "        </Thelen2003Muscle>\n";
}

/// y with NaN samples linearly interpolated in t between their finite neighbours and held at the
/// nearest finite one before the first and after the last; `fallback` everywhere when none is
/// finite.
std::vector<double> FilledGaps(const std::vector<double>& t, const std::vector<double>& y,
                               double fallback) {
  std::vector<double> out(y.size(), fallback);
  bool seen = false;
  std::size_t prev = 0;
  for (std::size_t i = 0; i < y.size(); ++i) {
    if (!std::isfinite(y[i])) continue;
    out[i] = y[i];
    for (std::size_t k = seen ? prev + 1 : 0; k < i; ++k) {
      out[k] = seen ? y[prev] + (t[k] - t[prev]) / (t[i] - t[prev]) * (y[i] - y[prev]) : y[i];
    }
    seen = true;
    prev = i;
  }
  for (std::size_t k = prev + 1; seen && k < y.size(); ++k) out[k] = y[prev];
  return out;
}

}  // namespace

OsimPathPoints MuscleDisplayPath(const ModelParams& m, const MuscleParams& mu) {
  int first = kNumCoordinates, last = -1;
  double d_first = 0.0;
  for (const auto& cr : mu.path.crossings) {
    if (cr.joint < first) {
      first = cr.joint;
      d_first = cr.arm.d_m;
    }
    last = std::max(last, cr.joint);
  }
  OsimPathPoints p;
  if (last < 0) {  // crosses nothing: a point pair on the forearm
    p.origin_body = p.insertion_body = Chain()[kElbowFlexion].child;
    p.insertion_m = {0, -m.segments[kForearm].length_m, 0};
    return p;
  }
  const Vec a = Chain()[first].axis;
  Vec n = Cross(a, {0, 1, 0});
  const double nn = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  if (nn < 1e-9) {
    n = {1, 0, 0};  // an axis along the segment: no display offset reproduces its arm
    d_first = 0.0;
  } else {
    for (double& x : n) x /= nn;
  }
  // A point at x relative to the joint moves by dq (a × x); with both points along −Y of the
  // segments and the offset s·n, n = a × Y, dl/dq ≈ s, so s = −d gives r = −∂l/∂q = d.
  const Vec off = {-d_first * n[0], -d_first * n[1], -d_first * n[2]};
  const int o = SegmentCoordinate(first - 1, -1);
  if (o < 0) {
    p.origin_body = "ground";
    const Vec& sh = m.shoulder_in_ground_m;
    p.origin_m = {sh[0] + off[0], sh[1] + 0.1 + off[1], sh[2] + off[2]};
  } else {
    p.origin_body = Chain()[o].child;
    p.origin_m = {off[0], -0.5 * m.segments[Chain()[o].segment].length_m + off[1], off[2]};
  }
  int i = SegmentCoordinate(last, +1);
  if (i < 0) i = SegmentCoordinate(last, -1);
  p.insertion_body = Chain()[i].child;
  p.insertion_m = {off[0], -m.segments[Chain()[i].segment].length_m / 3.0 + off[1], off[2]};
  return p;
}

std::string FormatOsimModel(const ModelParams& m, const std::string& name) {
  std::string s = "<?xml version=\"1.0\" encoding=\"UTF-8\" ?>\n";
  s += "<OpenSimDocument Version=\"40000\">\n  <Model name=\"" + name + "\">\n";
  s += "    <credits>fesim (README \"OpenSim\"): the participant of a scenario; muscle paths for "
       "display only</credits>\n";
  s += "    <length_units>meters</length_units>\n    <force_units>N</force_units>\n";
  s += "    <gravity>" + Triple(m.gravity_m_s2) + "</gravity>\n";
  s += "    <ground name=\"ground\" />\n";
  s += "    <BodySet name=\"bodyset\">\n      <objects>\n";
  for (const ChainJoint& j : Chain()) {
    if (j.segment < 0) {
      s += Body(j.child, kOsimFrameMassKg, {0, 0, 0}, {1e-9, 1e-9, 1e-9});
    } else {
      const SegmentParams& seg = m.segments[j.segment];
      s += Body(j.child, seg.mass_kg, seg.com_in_body_m, seg.inertia_about_com_kg_m2);
    }
  }
  s += "      </objects>\n    </BodySet>\n    <JointSet name=\"jointset\">\n      <objects>\n";
  for (int c = 0; c < kNumCoordinates; ++c) s += Joint(m, c);
  s += "      </objects>\n    </JointSet>\n    <ForceSet name=\"forceset\">\n      <objects>\n";
  for (const MuscleParams& mu : m.muscles) s += Muscle(m, mu);
  s += "      </objects>\n    </ForceSet>\n  </Model>\n</OpenSimDocument>\n";
  return s;
}

std::string FormatOsimMotion(const Trial& trial, const ModelParams& m, const std::string& name) {
  std::vector<std::vector<double>> deg(kNumCoordinates);
  for (int c = 0; c < kNumCoordinates; ++c) {
    const std::string column = "q." + CoordinateNames()[c];
    const std::vector<double> q =
        trial.Has(column)
            ? FilledGaps(trial.time, trial.Column(column), m.coordinates[c].initial_rad)
            : std::vector<double>(trial.size(), m.coordinates[c].initial_rad);
    deg[c].resize(q.size());
    for (std::size_t i = 0; i < q.size(); ++i) deg[c][i] = q[i] * kRadToDeg;
  }
  std::string s = name + "\nversion=1\nnRows=" + std::to_string(trial.size()) +
                  "\nnColumns=" + std::to_string(kNumCoordinates + 1) +
                  "\ninDegrees=yes\nendheader\ntime";
  for (int c = 0; c < kNumCoordinates; ++c) s += "\t" + CoordinateNames()[c];
  s += "\n";
  // printf's "%.10g" through std::to_chars: its general format with a precision is specified as
  // printf's in the C locale (the same characters), at a tenth of snprintf's instructions.
  char buf[40];
  const auto append = [&s, &buf](double v) {
    s.append(buf, std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, 10).ptr);
  };
  for (std::size_t i = 0; i < trial.size(); ++i) {
    append(trial.time[i]);
    for (int c = 0; c < kNumCoordinates; ++c) {
      s += '\t';
      append(deg[c][i]);
    }
    s += '\n';
  }
  return s;
}

}  // namespace fesim::sim
