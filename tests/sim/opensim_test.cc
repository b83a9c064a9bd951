#include "sim/opensim.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "sim/default_model.h"

namespace fesim::sim {
namespace {

using Vec = std::array<double, 3>;

/// Every element's text content by tag inside `xml` (first level of matches, in order).
std::vector<std::string> All(const std::string& xml, const std::string& tag) {
  std::vector<std::string> out;
  const std::regex re("<" + tag + "(?: [^>]*)?>([\\s\\S]*?)</" + tag + ">");
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), re); it != std::sregex_iterator();
       ++it) {
    out.push_back((*it)[1]);
  }
  return out;
}

std::string Attribute(const std::string& xml, const std::string& tag) {
  std::smatch m;
  const std::regex re("<" + tag + " name=\"([^\"]*)\"");
  return std::regex_search(xml, m, re) ? std::string(m[1]) : "";
}

Vec ParseVec(const std::string& text) {
  std::istringstream in(text);
  Vec v{};
  in >> v[0] >> v[1] >> v[2];
  return v;
}

/// Whether every opened element is closed in order (a minimal well-formedness check).
bool Nested(const std::string& xml) {
  std::vector<std::string> open;
  const std::regex tag("<(/?)([A-Za-z_][A-Za-z0-9_]*)[^>]*?(/?)>");
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), tag); it != std::sregex_iterator();
       ++it) {
    const std::string name = (*it)[2];
    if ((*it)[3] == "/") continue;
    if ((*it)[1] == "/") {
      if (open.empty() || open.back() != name) return false;
      open.pop_back();
    } else {
      open.push_back(name);
    }
  }
  return open.empty();
}

TEST(OpenSim, TheModelHasTheChainsBodiesJointsAndMusclesWithFesimsNamesAndValues) {
  ModelParams m = DefaultModelParams();
  m.coordinates[kElbowFlexion].mode = CoordinateMode::kLocked;
  const std::string xml = FormatOsimModel(m, "p1");
  ASSERT_TRUE(Nested(xml));
  EXPECT_NE(xml.find("<OpenSimDocument Version=\"40000\">"), std::string::npos);
  // Bodies: the six segments with their mass, plus four frames of kOsimFrameMassKg.
  const std::vector<std::string> bodies = All(xml, "Body");
  ASSERT_EQ(bodies.size(), 10u);
  for (int s = 0; s < kNumSegments; ++s) {
    const std::regex re("<Body name=\"" + SegmentNames()[s] + "\">\\s*<mass>([^<]*)</mass>");
    std::smatch match;
    ASSERT_TRUE(std::regex_search(xml, match, re)) << SegmentNames()[s];
    EXPECT_DOUBLE_EQ(std::stod(match[1]), m.segments[s].mass_kg) << SegmentNames()[s];
  }
  // Joints: one per coordinate, named after it, range and locking as in the model.
  const std::vector<std::string> joints = All(xml, "CustomJoint");
  ASSERT_EQ(joints.size(), static_cast<std::size_t>(kNumCoordinates));
  for (int c = 0; c < kNumCoordinates; ++c) {
    EXPECT_EQ(Attribute(joints[c], "Coordinate"), CoordinateNames()[c]);
    const Vec range = ParseVec(All(joints[c], "range")[0] + " 0");
    EXPECT_DOUBLE_EQ(range[0], m.coordinates[c].passive.min_angle_rad);
    EXPECT_DOUBLE_EQ(range[1], m.coordinates[c].passive.max_angle_rad);
    EXPECT_EQ(All(joints[c], "locked")[0], c == kElbowFlexion ? "true" : "false");
  }
  const std::vector<std::string> muscles = All(xml, "Thelen2003Muscle");
  ASSERT_EQ(muscles.size(), m.muscles.size());
  for (std::size_t k = 0; k < muscles.size(); ++k) {
    EXPECT_DOUBLE_EQ(std::stod(All(muscles[k], "max_isometric_force")[0]),
                     m.muscles[k].hill.max_isometric_force_n);
  }
}

// The display path's moment arm about its first crossed joint at zero angles, from the file
// alone (joint offsets, axes and path points, every frame parallel to ground there): r = −∂l/∂q
// by central differences, against the crossing's d — the offset rule of MuscleDisplayPath, to
// 1 %.
TEST(OpenSim, EachDisplayPathHasTheFirstCrossingsMomentArmAboutItsAxis) {
  const ModelParams m = DefaultModelParams();
  const std::string xml = FormatOsimModel(m, "p1");
  std::map<std::string, Vec> body_origin = {{"ground", {0, 0, 0}}};
  std::map<std::string, Vec> joint_centre, joint_axis;
  for (const std::string& j : All(xml, "CustomJoint")) {
    const std::vector<std::string> frames = All(j, "PhysicalOffsetFrame");
    std::string parent = All(frames[0], "socket_parent")[0];
    parent = parent.substr(parent.find_last_of('/') + 1);
    std::string child = All(frames[1], "socket_parent")[0];
    child = child.substr(child.find_last_of('/') + 1);
    const Vec t = ParseVec(All(frames[0], "translation")[0]);
    const Vec& p = body_origin.at(parent);
    const Vec centre = {p[0] + t[0], p[1] + t[1], p[2] + t[2]};
    body_origin[child] = centre;
    const std::string name = Attribute(j, "Coordinate");
    joint_centre[name] = centre;
    joint_axis[name] = ParseVec(All(All(j, "TransformAxis")[0], "axis")[0]);
  }
  int checked = 0;
  const std::vector<std::string> muscles = All(xml, "Thelen2003Muscle");
  for (std::size_t k = 0; k < m.muscles.size(); ++k) {
    const auto& crossings = m.muscles[k].path.crossings;
    if (crossings.empty()) continue;
    const tendons::Crossing* first = &crossings[0];
    for (const auto& c : crossings) {
      if (c.joint < first->joint) first = &c;
    }
    const Vec a = joint_axis.at(CoordinateNames()[first->joint]);
    if (std::abs(a[1]) > 0.5) continue;  // an axis along the segments: no offset matches it
    std::vector<Vec> points;
    for (const std::string& pp : All(muscles[k], "PathPoint")) {
      std::string body = All(pp, "socket_parent_frame")[0];
      body = body.substr(body.find_last_of('/') + 1);
      const Vec o = body_origin.at(body), l = ParseVec(All(pp, "location")[0]);
      points.push_back({o[0] + l[0], o[1] + l[1], o[2] + l[2]});
    }
    ASSERT_EQ(points.size(), 2u);
    const Vec c = joint_centre.at(CoordinateNames()[first->joint]);
    const auto length = [&](double q) {  // insertion rotated by q about a through c (Rodrigues)
      Vec x = {points[1][0] - c[0], points[1][1] - c[1], points[1][2] - c[2]};
      const Vec axx = {a[1] * x[2] - a[2] * x[1], a[2] * x[0] - a[0] * x[2],
                       a[0] * x[1] - a[1] * x[0]};
      const double adx = a[0] * x[0] + a[1] * x[1] + a[2] * x[2];
      double d2 = 0.0;
      for (int i = 0; i < 3; ++i) {
        const double xi =
            x[i] * std::cos(q) + axx[i] * std::sin(q) + a[i] * adx * (1 - std::cos(q));
        d2 += (c[i] + xi - points[0][i]) * (c[i] + xi - points[0][i]);
      }
      return std::sqrt(d2);
    };
    const double h = 1e-6;
    const double r = -(length(h) - length(-h)) / (2 * h);
    // d exactly when the two points lie on one line along the segments; an insertion beyond the
    // index MCP's lateral offset tilts the path and scales r by its cosine (> 0.99 here).
    EXPECT_NEAR(r, first->arm.d_m, 0.01 * std::abs(first->arm.d_m)) << m.muscles[k].name;
    ++checked;
  }
  EXPECT_GE(checked, 8);
}

TEST(OpenSim, TheMotionIsEveryCoordinateInDegreesWithGapsInterpolated) {
  ModelParams m = DefaultModelParams();
  m.coordinates[kElbowFlexion].initial_rad = 1.2;
  Trial t;
  t.time = {0.0, 0.1, 0.2, 0.3};
  t.AddColumn("q.wrist_flexion", {0.1, NAN, 0.3, NAN});
  t.AddColumn("q.mcp_flexion", {NAN, NAN, NAN, NAN});
  const std::string mot = FormatOsimMotion(t, m, "trial");
  std::istringstream in(mot);
  std::string line;
  std::vector<std::string> header;
  while (std::getline(in, line) && line != "endheader") header.push_back(line);
  EXPECT_EQ(header, (std::vector<std::string>{"trial", "version=1", "nRows=4", "nColumns=11",
                                              "inDegrees=yes"}));
  std::getline(in, line);
  std::string expected = "time";
  for (const auto& name : CoordinateNames()) expected += "\t" + name;
  EXPECT_EQ(line, expected);
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    std::istringstream r(line);
    std::vector<double> v;
    for (double x; r >> x;) v.push_back(x);
    rows.push_back(v);
  }
  ASSERT_EQ(rows.size(), 4u);
  const double deg = 180.0 / 3.14159265358979323846;
  const int wrist = 1 + kWristFlexion, mcp = 1 + kMcpFlexion, elbow = 1 + kElbowFlexion;
  EXPECT_NEAR(rows[1][wrist], 0.2 * deg, 1e-7);  // interpolated
  EXPECT_NEAR(rows[3][wrist], 0.3 * deg, 1e-7);  // held after the last finite sample
  EXPECT_NEAR(rows[2][mcp], m.coordinates[kMcpFlexion].initial_rad * deg, 1e-7);
  EXPECT_NEAR(rows[0][elbow], 1.2 * deg, 1e-7);  // not in the trial: the initial angle
}

}  // namespace
}  // namespace fesim::sim
