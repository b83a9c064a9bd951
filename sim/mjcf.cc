#include "sim/mjcf.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "muscles/activation.h"
#include "sim/upper_limb_model.h"
#include "tendons/tendon_network.h"

namespace fesim::sim {
namespace {

using Vec = std::array<double, 3>;

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string Triple(const Vec& v) { return Num(v[0]) + " " + Num(v[1]) + " " + Num(v[2]); }

/// One hinge as MJCF writes it: axis in its body's frame and ref (the joint value at which the
/// body has the orientation its <body> element gives it; the rotation applied is q − ref).
struct Hinge {
  Vec axis;
  double ref_rad = 0.0;
};

/// The hinges of upper_limb_model.cc's pins. Simbody's shoulder is Y(q₁)·(−X)(q₂)·Y(q₃); MuJoCo's
/// compiler computes constants (dof_invweight0, which scales the softness of the joint limits) at
/// qpos0 = ref, where the Y–X–Y sequence must not be singular (elevation 0: plane and rotation
/// share an axis). So the humerus body is written at elevation kShoulderRefElevationRad: body
/// orientation E = (−X)(e), plane axis Eᵀŷ = (0, cos e, sin e), elevation ref = e. Then
/// E·(Eᵀŷ)(q₁)·(−X)(q₂ − e)·Y(q₃) = Y(q₁)·(−X)(e)·(−X)(q₂ − e)·Y(q₃) = Simbody's, for every q.
const std::array<Hinge, kNumCoordinates>& Hinges() {
  static const std::array<Hinge, kNumCoordinates> hinges = {{
      {{0, std::cos(kShoulderRefElevationRad), std::sin(kShoulderRefElevationRad)},
       0.0},                                   // shoulder_elv_plane: Eᵀŷ
      {{-1, 0, 0}, kShoulderRefElevationRad},  // shoulder_elevation
      {{0, 1, 0}, 0.0},                        // shoulder_rotation
      {{0, 0, 1}, 0.0},                        // elbow_flexion
      {{0, 1, 0}, 0.0},                        // pro_sup
      {{1, 0, 0}, 0.0},                        // wrist_flexion
      {{0, 0, 1}, 0.0},                        // wrist_deviation
      {{1, 0, 0}, 0.0},                        // mcp_flexion
      {{1, 0, 0}, 0.0},                        // pip_flexion
      {{1, 0, 0}, 0.0},                        // dip_flexion
  }};
  return hinges;
}

/// The coordinates whose hinges sit in each segment's MuJoCo body, in chain order.
std::vector<int> JointsOfSegment(int segment) {
  switch (segment) {
    case kHumerus:
      return {kShoulderElvPlane, kShoulderElevation, kShoulderRotation};
    case kForearm:
      return {kElbowFlexion};
    case kHand:
      return {kProSup, kWristFlexion, kWristDeviation};
    case kProximalPhalanx:
      return {kMcpFlexion};
    case kMiddlePhalanx:
      return {kPipFlexion};
    default:
      return {kDipFlexion};
  }
}

/// A name written into an XML attribute: non-empty, without the characters XML would need
/// escaped there.
void CheckName(const std::string& what, const std::string& name) {
  if (name.empty() || name.find_first_of("\"<>&'") != std::string::npos) {
    throw std::invalid_argument("WriteMjcf: " + what + " \"" + name +
                                "\" must be non-empty and without \" < > & '");
  }
}

/// Rejects what the MJCF cannot express (mjcf.h) with a one-line reason.
void CheckRepresentable(const ModelParams& p, const MjcfOptions& options) {
  CheckName("model name", options.model_name);
  for (const auto& m : p.muscles) CheckName("muscle name", m.name);
  if (!(options.timestep_s > 0.0) || !std::isfinite(options.timestep_s)) {
    throw std::invalid_argument("WriteMjcf: timestep_s must be > 0, got " +
                                Num(options.timestep_s));
  }
  for (int i = 0; i < kNumCoordinates; ++i) {
    const auto& c = p.coordinates[i];
    const std::string where = "WriteMjcf: coordinate " + CoordinateNames()[i] + ": ";
    if (c.mode != CoordinateMode::kFree) {
      throw std::invalid_argument(where + "only free coordinates are written (locked/prescribed)");
    }
    const auto& j = c.passive;
    if (j.quadratic_stiffness_nm_per_rad2 != 0.0 || j.cubic_stiffness_nm_per_rad3 != 0.0) {
      throw std::invalid_argument(where + "nonlinear passive stiffness (k2, k3) has no MJCF form");
    }
    if (j.coulomb_friction_nm != 0.0 || j.static_friction_nm != 0.0) {
      throw std::invalid_argument(where + "Coulomb/static friction is not written");
    }
    if (j.reflex_gain_nms_per_rad != 0.0) {
      throw std::invalid_argument(where + "the stretch reflex has no MJCF form");
    }
    if (!(j.max_angle_rad > j.min_angle_rad)) {
      throw std::invalid_argument(where + "max_angle_rad must exceed min_angle_rad");
    }
  }
  const MechanismParams& m = p.mechanisms;
  if (HasMechanismStates(m) || m.tremor.enabled || m.electromechanical_delay_s != 0.0) {
    throw std::invalid_argument(
        "WriteMjcf: fatigue, potentiation, the stretch reflex, tremor and electromechanical delay "
        "are not written");
  }
  for (const auto& b : p.bands) {
    if (b.segment < 0 || b.segment >= kNumSegments) {
      throw std::invalid_argument("WriteMjcf: band segment " + std::to_string(b.segment));
    }
  }
  for (const auto& w : p.weight_compensation) {
    if (w.segment < 0 || w.segment >= kNumSegments) {
      throw std::invalid_argument("WriteMjcf: weight compensation segment " +
                                  std::to_string(w.segment));
    }
  }
}

/// Unit vector opposite to gravity (+Y without gravity, as ArmSupportForce).
Vec Up(const ModelParams& p) {
  const Vec& g = p.gravity_m_s2;
  const double n = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
  if (n == 0.0) return {0, 1, 0};
  return {-g[0] / n, -g[1] / n, -g[2] / n};
}

/// Position (m) of a segment's body origin in its parent body (the world for the humerus).
Vec SegmentOffset(const ModelParams& p, int segment) {
  const auto& seg = p.segments;
  switch (segment) {
    case kHumerus:
      return p.shoulder_in_ground_m;
    case kProximalPhalanx:
      return {p.index_mcp_offset_m, -seg[kHand].length_m, 0.0};
    default:
      return {0.0, -seg[segment - 1].length_m, 0.0};
  }
}

/// Ground position (m) of a point fixed in a segment with every coordinate at its initial angle
/// — used only to place the far site above a weight-compensation cuff; rotations composed as
/// MuJoCo composes a body's hinges (each about the body's current axes).
Vec InitialPointInGround(const ModelParams& p, int segment, const Vec& point) {
  using Mat = std::array<double, 9>;
  const auto mul = [](const Mat& a, const Mat& b) {
    Mat c{};
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k)
        for (int s = 0; s < 3; ++s) c[3 * r + k] += a[3 * r + s] * b[3 * s + k];
    return c;
  };
  const auto apply = [](const Mat& a, const Vec& v) {
    return Vec{a[0] * v[0] + a[1] * v[1] + a[2] * v[2], a[3] * v[0] + a[4] * v[1] + a[5] * v[2],
               a[6] * v[0] + a[7] * v[1] + a[8] * v[2]};
  };
  const auto axis_angle = [](const Vec& u, double q) {  // Rodrigues' formula
    const double c = std::cos(q), s = std::sin(q), t = 1.0 - c;
    return Mat{t * u[0] * u[0] + c,        t * u[0] * u[1] - s * u[2], t * u[0] * u[2] + s * u[1],
               t * u[0] * u[1] + s * u[2], t * u[1] * u[1] + c,        t * u[1] * u[2] - s * u[0],
               t * u[0] * u[2] - s * u[1], t * u[1] * u[2] + s * u[0], t * u[2] * u[2] + c};
  };
  Mat rot{1, 0, 0, 0, 1, 0, 0, 0, 1};
  Vec pos{0, 0, 0};
  for (int s = 0; s <= segment; ++s) {
    const Vec off = apply(rot, SegmentOffset(p, s));
    for (int k = 0; k < 3; ++k) pos[k] += off[k];
    if (s == kHumerus) rot = mul(rot, axis_angle({-1, 0, 0}, kShoulderRefElevationRad));
    for (int c : JointsOfSegment(s)) {
      const Hinge& h = Hinges()[c];
      rot = mul(rot, axis_angle(h.axis, p.coordinates[c].initial_rad - h.ref_rad));
    }
  }
  const Vec v = apply(rot, point);
  return {pos[0] + v[0], pos[1] + v[1], pos[2] + v[2]};
}

void WriteJoint(const ModelParams& p, int c, const std::string& indent, std::string* xml) {
  const PassiveJointParams& j = p.coordinates[c].passive;
  *xml += indent + "<joint name=\"" + CoordinateNames()[c] +
          "\" type=\"hinge\" pos=\"0 0 0\" axis=\"" + Triple(Hinges()[c].axis) + "\" ref=\"" +
          Num(Hinges()[c].ref_rad) + "\" limited=\"true\" range=\"" + Num(j.min_angle_rad) + " " +
          Num(j.max_angle_rad) + "\" stiffness=\"" + Num(j.stiffness_nm_per_rad) +
          "\" springref=\"" + Num(j.rest_angle_rad) + "\" damping=\"" + Num(j.damping_nms_per_rad) +
          "\" armature=\"0\"/>\n";
}

/// The bodies, nested from the humerus (its hinges, inertial, cuff sites) down the chain.
void WriteBodies(const ModelParams& p, std::string* xml) {
  std::string indent = "    ";
  for (int s = 0; s < kNumSegments; ++s) {
    const SegmentParams& seg = p.segments[s];
    *xml += indent + "<body name=\"" + SegmentNames()[s] + "\" pos=\"" +
            Triple(SegmentOffset(p, s)) + "\"" +
            (s == kHumerus ? " axisangle=\"-1 0 0 " + Num(kShoulderRefElevationRad) + "\"" : "") +
            ">\n";
    const std::string in = indent + "  ";
    *xml += in + "<inertial pos=\"" + Triple(seg.com_in_body_m) + "\" mass=\"" + Num(seg.mass_kg) +
            "\" diaginertia=\"" + Triple(seg.inertia_about_com_kg_m2) + "\"/>\n";
    for (int c : JointsOfSegment(s)) WriteJoint(p, c, in, xml);
    for (std::size_t k = 0; k < p.bands.size(); ++k) {
      if (p.bands[k].segment != s) continue;
      *xml += in + "<site name=\"band" + std::to_string(k) + "_cuff\" pos=\"" +
              Triple(p.bands[k].cuff_in_segment_m) + "\"/>\n";
    }
    for (std::size_t k = 0; k < p.weight_compensation.size(); ++k) {
      if (p.weight_compensation[k].segment != s) continue;
      *xml += in + "<site name=\"support" + std::to_string(k) + "_cuff\" pos=\"" +
              Triple(p.weight_compensation[k].cuff_in_segment_m) + "\"/>\n";
    }
    indent = in;
  }
  for (int s = kNumSegments - 1; s >= 0; --s) {
    *xml += std::string(4 + 2 * static_cast<std::size_t>(s), ' ') + "</body>\n";
  }
}

/// World sites: band anchors and the far sites above the weight-compensation cuffs.
void WriteWorldSites(const ModelParams& p, std::string* xml) {
  for (std::size_t k = 0; k < p.bands.size(); ++k) {
    *xml += "    <site name=\"band" + std::to_string(k) + "_anchor\" pos=\"" +
            Triple(p.bands[k].anchor_in_ground_m) + "\"/>\n";
  }
  const Vec up = Up(p);
  for (std::size_t k = 0; k < p.weight_compensation.size(); ++k) {
    const auto& w = p.weight_compensation[k];
    const Vec cuff = InitialPointInGround(p, w.segment, w.cuff_in_segment_m);
    const Vec far{cuff[0] + kFarSiteM * up[0], cuff[1] + kFarSiteM * up[1],
                  cuff[2] + kFarSiteM * up[2]};
    *xml +=
        "    <site name=\"support" + std::to_string(k) + "_far\" pos=\"" + Triple(far) + "\"/>\n";
  }
}

void WriteTendonsAndActuators(const ModelParams& p, std::string* xml) {
  const std::vector<double> coef = MjcfTendonCoefficients(p);
  const std::size_t nm = p.muscles.size();
  *xml += "  <tendon>\n";
  for (std::size_t j = 0; j < nm; ++j) {
    *xml += "    <fixed name=\"" + p.muscles[j].name + "\">\n";
    for (int i = 0; i < kNumCoordinates; ++i) {
      const double c = coef[i * nm + j];
      if (c == 0.0) continue;
      *xml += "      <joint joint=\"" + CoordinateNames()[i] + "\" coef=\"" + Num(c) + "\"/>\n";
    }
    *xml += "    </fixed>\n";
  }
  for (std::size_t k = 0; k < p.bands.size(); ++k) {
    const std::string n = "band" + std::to_string(k);
    *xml += "    <spatial name=\"" + n + "\" stiffness=\"" + Num(p.bands[k].stiffness_n_per_m) +
            "\" springlength=\"" + Num(p.bands[k].slack_length_m) + "\">\n      <site site=\"" + n +
            "_anchor\"/>\n      <site site=\"" + n + "_cuff\"/>\n    </spatial>\n";
  }
  for (std::size_t k = 0; k < p.weight_compensation.size(); ++k) {
    const std::string n = "support" + std::to_string(k);
    *xml += "    <spatial name=\"" + n + "\">\n      <site site=\"" + n +
            "_cuff\"/>\n      <site site=\"" + n + "_far\"/>\n    </spatial>\n";
  }
  *xml += "  </tendon>\n  <actuator>\n";
  for (const auto& m : p.muscles) {
    const double gain = -m.hill.max_isometric_force_n * std::cos(m.hill.pennation_at_optimal_rad);
    *xml += "    <general name=\"" + m.name + "\" tendon=\"" + m.name +
            "\" ctrllimited=\"true\" ctrlrange=\"0 1\" gaintype=\"fixed\" gainprm=\"" + Num(gain) +
            "\" biastype=\"none\"/>\n";
  }
  for (std::size_t k = 0; k < p.weight_compensation.size(); ++k) {
    // Force = gain·ctrl + bias = −F_w: shortens the cuff-to-far-site tendon (pulls up).
    const std::string n = "support" + std::to_string(k);
    *xml += "    <general name=\"" + n + "\" tendon=\"" + n +
            "\" ctrllimited=\"false\" gaintype=\"fixed\" gainprm=\"0\" biastype=\"affine\" "
            "biasprm=\"" +
            Num(-p.weight_compensation[k].force_n) + " 0 0\"/>\n";
  }
  *xml += "  </actuator>\n";
}

}  // namespace

const char* MjcfIntegratorName(MjcfIntegrator integrator) {
  switch (integrator) {
    case MjcfIntegrator::kRk4:
      return "RK4";
    case MjcfIntegrator::kImplicit:
      return "implicit";
    default:
      return "Euler";
  }
}

std::vector<double> MjcfTendonCoefficients(const ModelParams& params) {
  std::vector<double> rest(kNumCoordinates);
  for (int i = 0; i < kNumCoordinates; ++i) {
    rest[i] = params.coordinates[i].passive.rest_angle_rad;
  }
  std::vector<tendons::MusclePath> paths;
  paths.reserve(params.muscles.size());
  for (const auto& m : params.muscles) paths.push_back(m.path);
  std::vector<double> coef = tendons::MomentArmMatrix(paths, rest);
  for (double& c : coef) c = -c;  // ∂l/∂q = −r
  return coef;
}

std::string WriteMjcf(const ModelParams& params, const MjcfOptions& options) {
  CheckRepresentable(params, options);
  std::string xml;
  xml += "<mujoco model=\"" + options.model_name + "\">\n";
  xml +=
      "  <!-- Written by fesim::sim::WriteMjcf (sim/mjcf.h says what maps to what and where the "
      "two models differ). SI units, angles in rad. -->\n";
  xml += "  <compiler angle=\"radian\" inertiafromgeom=\"false\"/>\n";
  xml += "  <option timestep=\"" + Num(options.timestep_s) + "\" integrator=\"" +
         MjcfIntegratorName(options.integrator) + "\" gravity=\"" + Triple(params.gravity_m_s2) +
         "\">\n    <flag contact=\"disable\"/>\n  </option>\n";
  xml += "  <worldbody>\n";
  WriteWorldSites(params, &xml);
  WriteBodies(params, &xml);
  xml += "  </worldbody>\n";
  WriteTendonsAndActuators(params, &xml);
  std::string qpos, qvel;
  for (int i = 0; i < kNumCoordinates; ++i) {
    qpos += (i ? " " : "") + Num(params.coordinates[i].initial_rad);
    qvel += (i ? " " : "") + Num(params.coordinates[i].initial_speed_rad_s);
  }
  xml += "  <keyframe>\n    <key name=\"initial\" qpos=\"" + qpos + "\" qvel=\"" + qvel +
         "\"/>\n  </keyframe>\n</mujoco>\n";
  return xml;
}

ActivationTrack::ActivationTrack(const ModelParams& params, const StimulationSchedule& schedule) {
  const muscles::ArrayMatrix array = BuildElectrodeMatrix(params);
  const std::size_t nm = params.muscles.size();
  if (schedule.values.size() != schedule.times.size()) {
    throw std::invalid_argument("ActivationTrack: " + std::to_string(schedule.times.size()) +
                                " stimulation times but " + std::to_string(schedule.values.size()) +
                                " rows");
  }
  Segment rest;
  for (const auto& m : params.muscles) rest.omega.push_back(m.activation_omega_rad_s);
  rest.w.assign(nm, 0.0);
  rest.a0.assign(nm, 0.0);
  rest.a_dot0.assign(nm, 0.0);
  segments_.push_back(rest);  // zero stimulation before the first time (StimulationSchedule)
  for (std::size_t k = 0; k < schedule.times.size(); ++k) {
    const double t = schedule.times[k];
    const Segment& prev = segments_.back();
    if (!(t >= prev.t0_s) || (k > 0 && !(t > schedule.times[k - 1]))) {
      throw std::invalid_argument(
          "ActivationTrack: stimulation times must be ≥ 0 and strictly "
          "increasing (time " +
          Num(t) + ")");
    }
    Segment next;
    next.t0_s = t;
    next.w = RecruitedFractions(params, array, schedule.values[k]);
    for (std::size_t j = 0; j < nm; ++j) {
      const auto s = muscles::ActivationFreeResponse(prev.omega[j], prev.w[j],
                                                     {prev.a0[j], prev.a_dot0[j]}, t - prev.t0_s);
      next.a0.push_back(s.a);
      next.a_dot0.push_back(s.a_dot);
      next.omega.push_back(muscles::IntervalOmega(params.muscles[j].activation_omega_rad_s,
                                                  params.muscles[j].deactivation_ratio, next.w[j],
                                                  s));
    }
    if (t == prev.t0_s) segments_.pop_back();  // a change at t = 0 replaces the rest segment
    segments_.push_back(std::move(next));
  }
}

void ActivationTrack::At(double t_s, double* a) const {
  // The last segment starting at or before t (segments_[0] starts at 0).
  auto it = std::upper_bound(segments_.begin(), segments_.end(), t_s,
                             [](double t, const Segment& s) { return t < s.t0_s; });
  const Segment& s = it == segments_.begin() ? segments_.front() : *(it - 1);
  const double dt = std::max(0.0, t_s - s.t0_s);
  for (std::size_t j = 0; j < s.w.size(); ++j) {
    a[j] = muscles::ActivationFreeResponse(s.omega[j], s.w[j], {s.a0[j], s.a_dot0[j]}, dt).a;
  }
}

std::vector<double> ActivationTrack::At(double t_s) const {
  std::vector<double> a(segments_.front().w.size());
  At(t_s, a.data());
  return a;
}

}  // namespace fesim::sim
