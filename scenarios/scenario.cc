#include "scenarios/scenario.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <set>
#include <sstream>
#include <stdexcept>

#include "base/trial.h"
#include "protocols/protocols.h"
#include "scenarios/yaml_node.h"
#include "sim/default_model.h"

namespace fesim {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

using internal::Fmt;
using Node = internal::YamlNode;

int MuscleIndex(const sim::ModelParams& m, const std::string& name) {
  for (std::size_t j = 0; j < m.muscles.size(); ++j) {
    if (m.muscles[j].name == name) return static_cast<int>(j);
  }
  return -1;
}

std::string MuscleList(const sim::ModelParams& m) {
  std::string s;
  for (const auto& x : m.muscles) s += (s.empty() ? "" : ", ") + x.name;
  return s;
}

std::string CoordinateList() {
  std::string s;
  for (const auto& n : sim::CoordinateNames()) s += (s.empty() ? "" : ", ") + n;
  return s;
}

int Coordinate(const Node& parent, const std::string& key, const std::string& name) {
  const int i = sim::CoordinateIndex(name);
  if (i < 0)
    parent.FailKey(key, "unknown coordinate '" + name + "' (allowed: " + CoordinateList() + ")");
  return i;
}

void LoadCoordinates(const Node& n, sim::ModelParams* m) {
  for (const auto& name : n.MapKeys()) {
    const int i = Coordinate(n, name, name);
    const Node c = n.Child(name);
    c.Keys({"mode", "initial_deg", "initial_speed_deg_s", "rest_deg", "min_deg", "max_deg",
            "stiffness_nm_per_rad", "damping_nms_per_rad", "limit_stiffness_nm_per_rad",
            "limit_sharpness_per_rad", "coulomb_friction_nm", "static_friction_nm",
            "stribeck_velocity_rad_s", "reflex_gain_nms_per_rad", "reflex_threshold_deg_s",
            "reflex_direction_bias", "prescription"});
    auto& p = m->coordinates[i];
    auto& pj = p.passive;
    c.Number("min_deg", -180, 180, &pj.min_angle_rad, kDeg);
    c.Number("max_deg", -180, 180, &pj.max_angle_rad, kDeg);
    if (!(pj.max_angle_rad > pj.min_angle_rad)) c.Fail("max_deg must be greater than min_deg");
    const double lo = pj.min_angle_rad / kDeg, hi = pj.max_angle_rad / kDeg;
    c.Number("rest_deg", lo, hi, &pj.rest_angle_rad, kDeg);
    p.initial_rad = pj.rest_angle_rad;
    c.Number("initial_deg", lo, hi, &p.initial_rad, kDeg);
    c.Number("initial_speed_deg_s", -2000, 2000, &p.initial_speed_rad_s, kDeg);
    c.Number("stiffness_nm_per_rad", 0, 1e3, &pj.stiffness_nm_per_rad);
    c.Number("damping_nms_per_rad", 0, 1e2, &pj.damping_nms_per_rad);
    c.Number("limit_stiffness_nm_per_rad", 0, 1e4, &pj.limit_stiffness_nm_per_rad);
    c.Number("limit_sharpness_per_rad", 1, 200, &pj.limit_sharpness_per_rad);
    c.Number("coulomb_friction_nm", 0, 100, &pj.coulomb_friction_nm);
    c.Number("static_friction_nm", 0, 100, &pj.static_friction_nm);
    c.Number("stribeck_velocity_rad_s", 1e-4, 10, &pj.stribeck_velocity_rad_s);
    c.Number("reflex_gain_nms_per_rad", 0, 100, &pj.reflex_gain_nms_per_rad);
    c.Number("reflex_threshold_deg_s", 0, 2000, &pj.reflex_threshold_rad_s, kDeg);
    c.Number("reflex_direction_bias", -1, 1, &pj.reflex_direction_bias);
    if (c.Has("mode")) {
      const std::string mode = c.Choice("mode", {"free", "locked", "prescribed"});
      p.mode = mode == "free"     ? sim::CoordinateMode::kFree
               : mode == "locked" ? sim::CoordinateMode::kLocked
                                  : sim::CoordinateMode::kPrescribed;
    }
    if (c.Has("prescription")) {
      if (p.mode != sim::CoordinateMode::kPrescribed) {
        c.FailKey("prescription", "only allowed with mode: prescribed");
      }
      const Node pr = c.Child("prescription");
      pr.Keys({"offset_deg", "amplitude_deg", "frequency_hz", "phase_deg"});
      pr.Number("offset_deg", -180, 180, &p.prescription.offset_rad, kDeg);
      pr.Number("amplitude_deg", 0, 180, &p.prescription.amplitude_rad, kDeg);
      pr.Number("frequency_hz", 0, 50, &p.prescription.frequency_hz);
      pr.Number("phase_deg", -360, 360, &p.prescription.phase_rad, kDeg);
      p.initial_rad = p.prescription.offset_rad +
                      p.prescription.amplitude_rad * std::sin(p.prescription.phase_rad);
    } else if (p.mode == sim::CoordinateMode::kPrescribed) {
      c.FailKey("prescription", "missing required key (mode: prescribed)");
    }
  }
}

void LoadMuscles(const Node& n, sim::ModelParams* m) {
  for (const auto& name : n.MapKeys()) {
    const int j = MuscleIndex(*m, name);
    if (j < 0) n.FailKey(name, "unknown muscle (allowed: " + MuscleList(*m) + ")");
    const Node c = n.Child(name);
    c.Keys({"max_isometric_force_n", "optimal_fibre_length_m", "tendon_slack_length_m",
            "pennation_deg", "omega_rad_s", "deactivation_ratio", "alpha", "beta_per_us", "gamma"});
    auto& mu = m->muscles[j];
    c.Number("max_isometric_force_n", 0.1, 1e4, &mu.hill.max_isometric_force_n);
    c.Number("optimal_fibre_length_m", 0.005, 0.5, &mu.hill.optimal_fibre_length_m);
    c.Number("tendon_slack_length_m", 0.0, 0.6, &mu.hill.tendon_slack_length_m);
    c.Number("pennation_deg", 0, 60, &mu.hill.pennation_at_optimal_rad, kDeg);
    c.Number("omega_rad_s", 0.1, 100, &mu.activation_omega_rad_s);
    c.Number("deactivation_ratio", 0.05, 20, &mu.deactivation_ratio);
    c.Number("alpha", 1e-3, 1, &mu.recruitment.alpha);
    c.Number("beta_per_us", 1e-4, 1, &mu.recruitment.beta_per_us);
    c.Number("gamma", 1e-3, 1e6, &mu.recruitment.gamma);
  }
}

void LoadElectrodes(const Node& n, sim::ModelParams* m) {
  n.Keys({"array", "channels"});
  if (n.Has("array")) {
    const Node a = n.Child("array");
    a.Keys({"rows", "cols", "pitch_m", "origin_m", "spread_m", "motor_points"});
    if (a.Has("rows")) m->array.rows = a.Integer("rows", 1, 16);
    if (a.Has("cols")) m->array.cols = a.Integer("cols", 1, 16);
    a.Number("pitch_m", 1e-3, 0.1, &m->array.pitch_m);
    a.Number("spread_m", 1e-4, 0.1, &m->array.spread_m);
    if (a.Has("origin_m")) {
      const auto o = a.Vector("origin_m", 2, -0.5, 0.5);
      m->array.origin = {o[0], o[1]};
    }
    if (a.Has("motor_points")) {
      const Node mp = a.Child("motor_points");
      m->array.motor_points.clear();
      for (const auto& name : mp.MapKeys()) {
        if (MuscleIndex(*m, name) < 0)
          mp.FailKey(name, "unknown muscle (allowed: " + MuscleList(*m) + ")");
        const auto p = mp.Vector(name, 2, -0.5, 0.5);
        m->array.motor_points.push_back({name, {p[0], p[1]}});
      }
    }
  }
  if (n.Has("channels")) {
    const Node ch = n.Child("channels");
    m->channels.clear();
    const int pads = m->array.rows * m->array.cols;
    std::set<std::string> names;
    for (std::size_t k = 0; k < ch.Size(); ++k) {
      const Node c = ch.Item(k);
      c.Keys({"name", "pads", "muscles"});
      sim::ChannelParams p;
      p.name = c.Text("name");
      if (!names.insert(p.name).second) c.FailKey("name", "duplicate channel '" + p.name + "'");
      if (c.Has("pads")) p.pads = c.IntList("pads", 0, pads - 1);
      if (c.Has("muscles")) {
        const Node mw = c.Child("muscles");
        for (const auto& name : mw.MapKeys()) {
          if (MuscleIndex(*m, name) < 0)
            mw.FailKey(name, "unknown muscle (allowed: " + MuscleList(*m) + ")");
          p.muscle_weights.emplace_back(name, mw.Number(name, 0, 10));
        }
      }
      if (p.pads.empty() && p.muscle_weights.empty()) c.Fail("a channel needs pads or muscles");
      m->channels.push_back(p);
    }
  }
}

void LoadSupport(const Node& n, sim::ModelParams* m) {
  n.Keys({"bands", "weight_compensation"});
  const auto segment = [](const Node& c) {
    const std::string s = c.Text("segment");
    const int i = sim::SegmentIndex(s);
    if (i < 0) {
      std::string list;
      for (const auto& x : sim::SegmentNames()) list += (list.empty() ? "" : ", ") + x;
      c.FailKey("segment", "unknown segment '" + s + "' (allowed: " + list + ")");
    }
    return i;
  };
  const auto vec3 = [](const std::vector<double>& v) { return sim::Vec3d{v[0], v[1], v[2]}; };
  if (n.Has("bands")) {
    const Node b = n.Child("bands");
    for (std::size_t k = 0; k < b.Size(); ++k) {
      const Node c = b.Item(k);
      c.Keys({"segment", "cuff_m", "anchor_m", "stiffness_n_per_m", "slack_length_m"});
      sim::BandParams band;
      band.segment = segment(c);
      band.cuff_in_segment_m = vec3(c.Vector("cuff_m", 3, -1, 1));
      band.anchor_in_ground_m = vec3(c.Vector("anchor_m", 3, -5, 5));
      band.stiffness_n_per_m = c.Number("stiffness_n_per_m", 0, 1e5);
      band.slack_length_m = c.Number("slack_length_m", 0, 5);
      m->bands.push_back(band);
    }
  }
  if (n.Has("weight_compensation")) {
    const Node w = n.Child("weight_compensation");
    for (std::size_t k = 0; k < w.Size(); ++k) {
      const Node c = w.Item(k);
      c.Keys({"segment", "cuff_m", "force_n"});
      m->weight_compensation.push_back(
          {segment(c), vec3(c.Vector("cuff_m", 3, -1, 1)), c.Number("force_n", 0, 500)});
    }
  }
}

std::vector<double> ChannelValues(const Node& n, const sim::ModelParams& m) {
  std::vector<double> u(m.channels.size(), 0.0);
  for (const auto& name : n.MapKeys()) {
    int k = -1;
    for (std::size_t i = 0; i < m.channels.size(); ++i) {
      if (m.channels[i].name == name) k = static_cast<int>(i);
    }
    if (k < 0) {
      std::string list;
      for (const auto& c : m.channels) list += (list.empty() ? "" : ", ") + c.name;
      n.FailKey(name, "unknown channel (allowed: " + list + ")");
    }
    u[k] = n.Number(name, 0, 300);
  }
  return u;
}

std::string Directory(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? "" : path.substr(0, slash + 1);
}

/// The protocol generators of protocols/protocols.h, by name, with their parameters.
protocols::StimulationProgram LoadProtocol(const Node& n, const sim::ModelParams& m) {
  n.Keys({"name",
          "channel",
          "channels",
          "u_min_us",
          "u_max_us",
          "u_sum_max_us",
          "seed",
          "spacing_us",
          "step_duration_s",
          "order",
          "duration_s",
          "rest_s",
          "num_triangles",
          "settling_time_s",
          "cutoff_hz",
          "filter_order",
          "num_levels",
          "register_length",
          "symbol_duration_s",
          "f_min_hz",
          "f_max_hz",
          "frequency_step_hz",
          "amplitude_us",
          "coact_agonist_us",
          "coact_antagonist_us",
          "level_min_us",
          "level_max_us",
          "step_min_s",
          "step_max_s",
          "gap_min_s",
          "gap_max_s"});
  const std::string name = n.Choice("name", {"step_grid", "ramp", "staircase", "filtered_noise",
                                             "prms", "multisine", "shoulder_steps"});
  const auto channel_ok = [&](const std::string& key, const std::string& c) {
    for (const auto& ch : m.channels) {
      if (ch.name == c) return c;
    }
    n.FailKey(key, "unknown channel '" + c + "'");
  };
  protocols::StimulationLimit limit;
  n.Number("u_sum_max_us", 0, 1800, &limit.sum_max_us);
  std::uint64_t seed = 1;
  if (n.Has("seed")) seed = static_cast<std::uint64_t>(n.Integer("seed", 0, 1 << 30));
  protocols::IsometricTestTiming timing;
  n.Number("duration_s", 0.1, 36000, &timing.duration_s);
  n.Number("rest_s", 0, 3600, &timing.rest_s);
  const auto channels = [&](std::vector<std::string> fallback) {
    if (!n.Has("channels")) return fallback;
    std::vector<std::string> out;
    for (const auto& c : n.Child("channels").TextList()) out.push_back(channel_ok("channels", c));
    return out;
  };
  const std::string channel =
      n.Has("channel") ? channel_ok("channel", n.Text("channel")) : std::string("bic");
  try {
    if (name == "step_grid") {
      protocols::StepGridParams p;
      p.channels = channels(p.channels);
      n.Number("u_max_us", 0, 1800, &p.u_max_us);
      n.Number("spacing_us", 1, 300, &p.spacing_us);
      n.Number("step_duration_s", 0.01, 600, &p.step_duration_s);
      if (n.Has("order")) {
        p.order = n.Choice("order", {"first_fastest", "last_fastest"}) == "first_fastest"
                      ? protocols::GridOrder::kFirstChannelFastest
                      : protocols::GridOrder::kLastChannelFastest;
      }
      return protocols::StepGrid(p);
    }
    if (name == "ramp") {
      protocols::TriangularRampParams p;
      p.channel = channel;
      n.Number("u_min_us", 0, 300, &p.u_min_us);
      n.Number("u_max_us", 0, 300, &p.u_peak_us);
      if (n.Has("num_triangles")) p.num_triangles = n.Integer("num_triangles", 1, 1000);
      p.timing = timing;
      p.limit = limit;
      return protocols::TriangularRamp(p);
    }
    if (name == "staircase") {
      protocols::StaircaseParams p;
      p.channel = channel;
      n.Number("u_min_us", 0, 300, &p.u_min_us);
      n.Number("u_max_us", 0, 300, &p.u_max_us);
      n.Number("settling_time_s", 0.01, 3600, &p.settling_time_s);
      p.timing = timing;
      p.limit = limit;
      p.seed = seed;
      return protocols::Staircase(p);
    }
    if (name == "filtered_noise") {
      protocols::FilteredRandomNoiseParams p;
      p.channel = channel;
      n.Number("u_min_us", 0, 300, &p.u_min_us);
      n.Number("u_max_us", 0, 300, &p.u_max_us);
      n.Number("cutoff_hz", 1e-3, 500, &p.cutoff_hz);
      if (n.Has("filter_order")) p.filter_order = n.Integer("filter_order", 1, 10);
      p.timing = timing;
      p.limit = limit;
      p.seed = seed;
      return protocols::FilteredRandomNoise(p);
    }
    if (name == "prms") {
      protocols::PrmsParams p;
      p.channel = channel;
      n.Number("u_min_us", 0, 300, &p.u_min_us);
      n.Number("u_max_us", 0, 300, &p.u_max_us);
      if (n.Has("num_levels")) p.num_levels = n.Integer("num_levels", 2, 31);
      if (n.Has("register_length")) p.register_length = n.Integer("register_length", 1, 20);
      n.Number("symbol_duration_s", 1e-3, 3600, &p.symbol_duration_s);
      p.timing = timing;
      p.limit = limit;
      p.seed = seed;
      return protocols::Prms(p);
    }
    if (name == "multisine") {
      protocols::MultisineParams p;
      p.channels = channels(p.channels);
      n.Number("f_min_hz", 1e-3, 500, &p.f_min_hz);
      n.Number("f_max_hz", 1e-3, 500, &p.f_max_hz);
      n.Number("frequency_step_hz", 1e-3, 500, &p.frequency_step_hz);
      n.Number("amplitude_us", 0, 300, &p.amplitude_us);
      n.Number("coact_agonist_us", 0, 300, &p.coact_agonist_us);
      n.Number("coact_antagonist_us", 0, 300, &p.coact_antagonist_us);
      n.Number("duration_s", 0.1, 36000, &p.duration_s);
      p.limit = limit;
      p.seed = seed;
      return protocols::Multisine(p);
    }
    protocols::ShoulderStepsParams p;
    p.channels = channels(p.channels);
    n.Number("level_min_us", 0, 300, &p.level_min_us);
    n.Number("level_max_us", 0, 300, &p.level_max_us);
    n.Number("step_min_s", 1e-3, 3600, &p.step_min_s);
    n.Number("step_max_s", 1e-3, 3600, &p.step_max_s);
    n.Number("gap_min_s", 0, 3600, &p.gap_min_s);
    n.Number("gap_max_s", 0, 3600, &p.gap_max_s);
    n.Number("duration_s", 0.1, 36000, &p.duration_s);
    n.Number("rest_s", 0, 3600, &p.rest_s);
    p.limit = limit;
    p.seed = seed;
    return protocols::ShoulderPseudoRandomSteps(p);
  } catch (const std::invalid_argument& e) {
    n.Fail(e.what());
  }
}

protocols::ReachingParams LoadReaching(const Node& n) {
  n.Keys({"repetitions", "reach_duration_s", "hold_s", "pause_s", "transfer_duration_s",
          "sample_rate_hz", "homes_m", "targets_m", "paths"});
  protocols::ReachingParams r;
  if (n.Has("repetitions")) r.repetitions = n.Integer("repetitions", 1, 100);
  n.Number("reach_duration_s", 0.01, 60, &r.reach_duration_s);
  n.Number("hold_s", 0, 60, &r.hold_s);
  n.Number("pause_s", 0, 60, &r.pause_s);
  n.Number("transfer_duration_s", 0.01, 60, &r.transfer_duration_s);
  n.Number("sample_rate_hz", 1, 10000, &r.sample_rate_hz);
  const auto points = [&](const std::string& key) {
    std::vector<protocols::Vec3> out;
    const Node list = n.Child(key);
    for (std::size_t i = 0; i < list.Size(); ++i) {
      const auto v = list.Item(i).Vector3();
      out.push_back({v[0], v[1], v[2]});
    }
    return out;
  };
  if (n.Has("homes_m")) r.homes_m = points("homes_m");
  if (n.Has("targets_m")) r.targets_m = points("targets_m");
  if (n.Has("paths")) {
    // Indices are checked against homes_m / targets_m by ReachingProgram (the caller's FailKey).
    const Node list = n.Child("paths");
    for (std::size_t i = 0; i < list.Size(); ++i) {
      const Node item = list.Item(i);
      item.Keys({"home", "target"});
      r.paths.push_back({item.Integer("home", 0, 15), item.Integer("target", 0, 999)});
    }
    if (r.paths.empty()) n.FailKey("paths", "needs at least one {home, target} pair");
  }
  return r;
}

void LoadStimulation(const Node& n, const std::string& path, const sim::ModelParams& m,
                     sim::TrialRequest* t, std::optional<protocols::ReachingParams>* reaching) {
  n.Keys({"duration_s", "type", "values_us", "steps", "file", "protocol", "reaching"});
  const std::string type = n.Choice("type", {"constant", "steps", "csv", "protocol", "reaching"});
  auto& sched = t->stimulation;
  if (type == "reaching") {
    *reaching = n.Has("reaching") ? LoadReaching(n.Child("reaching")) : protocols::ReachingParams{};
    try {
      t->duration_s = protocols::ReachingProgram(**reaching).duration_s;
    } catch (const std::invalid_argument& e) {
      n.FailKey("reaching", e.what());
    }
    return;
  }
  if (type == "protocol") {
    const protocols::StimulationProgram prog = LoadProtocol(n.Child("protocol"), m);
    t->duration_s = prog.duration_s;
    n.Number("duration_s", 1e-3, 36000, &t->duration_s);
    std::vector<int> column;  // model channel of each program channel
    for (const auto& c : prog.channels) {
      for (std::size_t k = 0; k < m.channels.size(); ++k) {
        if (m.channels[k].name == c) column.push_back(static_cast<int>(k));
      }
    }
    for (std::size_t i = 0; i < prog.times_s.size(); ++i) {
      std::vector<double> u(m.channels.size(), 0.0);
      for (std::size_t c = 0; c < column.size(); ++c) u[column[c]] = prog.values_us[i][c];
      sched.times.push_back(prog.times_s[i]);
      sched.values.push_back(u);
    }
    t->steady_state_times_s = prog.steady_state_times_s;
    return;
  }
  t->duration_s = n.Number("duration_s", 1e-3, 3600);
  if (type == "constant") {
    sched.times = {0.0};
    sched.values = {ChannelValues(n.Child("values_us"), m)};
  } else if (type == "steps") {
    const Node steps = n.Child("steps");
    for (std::size_t k = 0; k < steps.Size(); ++k) {
      const Node s = steps.Item(k);
      s.Keys({"time_s", "values_us"});
      const double time = s.Number("time_s", 0, t->duration_s);
      if (!sched.times.empty() && !(time > sched.times.back())) {
        s.FailKey("time_s", Fmt(time) + " is not after the previous step's time");
      }
      sched.times.push_back(time);
      sched.values.push_back(ChannelValues(s.Child("values_us"), m));
    }
    if (sched.times.empty()) n.FailKey("steps", "needs at least one step");
  } else {
    const std::string file = n.Text("file");
    const std::string full = !file.empty() && file[0] == '/' ? file : Directory(path) + file;
    Trial input;
    try {
      input = ReadTrialCsv(full);
    } catch (const std::exception& e) {
      n.FailKey("file", e.what());
    }
    std::vector<const std::vector<double>*> cols;
    for (const auto& c : m.channels) {
      if (!input.Has("u." + c.name)) {
        n.FailKey("file", full + " has no column u." + c.name + " (one per channel)");
      }
      cols.push_back(&input.Column("u." + c.name));
    }
    for (std::size_t i = 0; i < input.size(); ++i) {
      std::vector<double> u;
      for (std::size_t k = 0; k < cols.size(); ++k) {
        const double v = (*cols[k])[i];
        if (!(v >= 0.0 && v <= 300.0)) {
          n.FailKey("file", full + ": row " + std::to_string(i + 1) + " column u." +
                                m.channels[k].name + " = " + Fmt(v) + " is outside [0, 300]");
        }
        u.push_back(v);
      }
      sched.times.push_back(input.time[i]);
      sched.values.push_back(u);
    }
  }
}

void LoadMechanisms(const Node& n, sim::ModelParams* m) {
  n.Keys({"fatigue", "potentiation", "electromechanical_delay_s", "tremor", "crosstalk",
          "stretch_reflex"});
  auto& mech = m->mechanisms;
  if (n.Has("fatigue")) {
    const Node f = n.Child("fatigue");
    f.Keys({"fatigue_time_s", "recovery_time_s", "min_fitness"});
    mech.fatigue.enabled = true;
    f.Number("fatigue_time_s", 0.1, 1e5, &mech.fatigue.fatigue_time_s);
    f.Number("recovery_time_s", 0.1, 1e5, &mech.fatigue.recovery_time_s);
    f.Number("min_fitness", 0, 1, &mech.fatigue.min_fitness);
  }
  if (n.Has("potentiation")) {
    const Node p = n.Child("potentiation");
    p.Keys({"gain", "rise_time_s", "decay_time_s"});
    mech.potentiation.enabled = true;
    p.Number("gain", 0, 5, &mech.potentiation.gain);
    p.Number("rise_time_s", 0.01, 1e4, &mech.potentiation.rise_time_s);
    p.Number("decay_time_s", 0.01, 1e5, &mech.potentiation.decay_time_s);
  }
  n.Number("electromechanical_delay_s", 0, 1, &mech.electromechanical_delay_s);
  if (n.Has("tremor")) {
    const Node t = n.Child("tremor");
    t.Keys({"coordinate", "frequency_hz", "amplitude_nm", "amplitude_modulation", "modulation_hz",
            "frequency_drift_hz_per_s", "phase_deg"});
    auto& tr = mech.tremor;
    tr.enabled = true;
    if (t.Has("coordinate")) tr.coordinate = Coordinate(t, "coordinate", t.Text("coordinate"));
    t.Number("frequency_hz", 3, 12, &tr.frequency_hz);
    t.Number("amplitude_nm", 0, 50, &tr.amplitude_nm);
    t.Number("amplitude_modulation", 0, 1, &tr.amplitude_modulation);
    t.Number("modulation_hz", 0, 10, &tr.modulation_hz);
    t.Number("frequency_drift_hz_per_s", -1, 1, &tr.frequency_drift_hz_per_s);
    t.Number("phase_deg", -360, 360, &tr.phase_rad, kDeg);
  }
  if (n.Has("crosstalk")) {
    const Node c = n.Child("crosstalk");
    c.Keys({"fraction", "spread_m"});
    c.Number("fraction", 0, 1, &mech.crosstalk.fraction);
    c.Number("spread_m", 1e-4, 0.2, &mech.crosstalk.spread_m);
  }
  if (n.Has("stretch_reflex")) {
    const Node r = n.Child("stretch_reflex");
    r.Keys({"gain", "threshold_per_s", "loop_delay_s", "muscles"});
    auto& sr = mech.stretch_reflex;
    r.Number("gain", 0, 10, &sr.gain);
    r.Number("threshold_per_s", 0, 10, &sr.threshold_per_s);
    r.Number("loop_delay_s", 0.001, 1, &sr.loop_delay_s);
    sr.muscles = r.Child("muscles").TextList();
    for (const auto& name : sr.muscles) {
      const bool known = std::any_of(m->muscles.begin(), m->muscles.end(),
                                     [&](const sim::MuscleParams& x) { return x.name == name; });
      if (!known) r.Fail("muscles: unknown muscle '" + name + "'");
    }
  }
}

/// A sensor block; `unit` is the suffix of its noise/drift/outlier keys (deg, deg_s or nm) and
/// `scale` converts that unit to SI.
void LoadSensor(const Node& n, const std::string& unit, double scale, sim::SensorParams* s) {
  n.Keys({"rate_hz", "coordinates", "noise_std_" + unit, "offset_drift_" + unit + "_per_s",
          "dropout_probability", "dropout_mean_samples", "outlier_probability",
          "outlier_std_" + unit, "baseline_window_s", "lowpass_hz"});
  n.Number("baseline_window_s", 0, 3600, &s->baseline_window_s);
  n.Number("rate_hz", 0.1, 20000, &s->rate_hz);
  n.Number("noise_std_" + unit, 0, 1e3, &s->noise_std, scale);
  n.Number("offset_drift_" + unit + "_per_s", -100, 100, &s->offset_drift_per_s, scale);
  n.Number("dropout_probability", 0, 0.9, &s->dropout_probability);
  n.Number("dropout_mean_samples", 1, 1e4, &s->dropout_mean_samples);
  n.Number("outlier_probability", 0, 0.5, &s->outlier_probability);
  n.Number("outlier_std_" + unit, 0, 1e4, &s->outlier_std, scale);
  if (n.Has("coordinates")) {
    const Node c = n.Child("coordinates");
    s->coordinates.clear();
    for (const auto& name : c.TextList()) {
      s->coordinates.push_back(Coordinate(n, "coordinates", name));
    }
  }
}

/// The sensors block of a robot-driven reaching scenario (sim/reaching.h "Measurement"): the
/// joint angles and the robot's force sensor, each {noise_std_<unit>, lowpass_hz}; the rate is
/// the path's sample_rate_hz, the cutoff below half of it.
void LoadReachingSensors(const Node& s, const protocols::ReachingParams& reaching,
                         sim::SensorSuite* out) {
  s.Keys({"angles", "force"});
  const auto load = [&](const char* key, const std::string& unit, double scale,
                        sim::SensorParams* p) {
    if (!s.Has(key)) return;
    const Node n = s.Child(key);
    n.Keys({"noise_std_" + unit, "lowpass_hz"});
    n.Number("noise_std_" + unit, 0, 1e3, &p->noise_std, scale);
    const double nyquist = 0.5 * reaching.sample_rate_hz;
    n.Number("lowpass_hz", 0, nyquist, &p->lowpass_hz);
    if (p->lowpass_hz >= nyquist) {
      n.FailKey("lowpass_hz", internal::Fmt(p->lowpass_hz) + " is outside [0, " +
                                  internal::Fmt(nyquist) +
                                  ") (below half of stimulation.reaching.sample_rate_hz)");
    }
  };
  load("angles", "deg", kDeg, &out->angles);
  load("force", "n", 1.0, &out->force);
}

/// Bytes per cell of a trial CSV as FormatTrialCsv writes it (17 significant digits, sign,
/// exponent, comma), an upper estimate used to size the outputs before simulating.
constexpr double kCsvBytesPerCell = 24.0;

/// Refuses a trial whose records could not be written and read back: the truth record
/// (truth_rate_hz × duration rows × every channel, coordinate and muscle column) or the measured
/// one (the union of the sensors' grids) estimated above the trial file limit of ReadTrialCsv
/// (kMaxTrialFileBytes), naming the rate key that makes it so. A huge in-range request (20 kHz
/// truth for an hour: 72 million rows) used to end in a bare std::bad_alloc mid-simulation.
void CheckOutputSize(const Node& top, const sim::ModelParams& m, const sim::TrialRequest& t) {
  const sim::SensorSuite& s = t.sensors;
  const double channels = static_cast<double>(m.channels.size());
  const double muscles = static_cast<double>(m.muscles.size());
  const double truth_cols = 1.0 + channels + 3.0 * sim::kNumCoordinates + 2.0 * muscles +
                            static_cast<double>(s.torques.coordinates.size());
  const double truth_bytes = (t.duration_s * s.truth_rate_hz + 1.0) * truth_cols * kCsvBytesPerCell;
  struct Part {
    const char* key;
    const sim::SensorParams* sensor;
  };
  const Part sensors[] = {{"sensors.angles.rate_hz", &s.angles},
                          {"sensors.velocities.rate_hz", &s.velocities},
                          {"sensors.torques.rate_hz", &s.torques}};
  const double measured_cols =
      1.0 + channels +
      static_cast<double>(s.angles.coordinates.size() + s.velocities.coordinates.size() +
                          s.torques.coordinates.size());
  double measured_rows = 0.0, fastest = 0.0;
  const char* fastest_key = sensors[0].key;
  for (const Part& p : sensors) {
    if (p.sensor->coordinates.empty()) continue;  // writes no rows
    measured_rows += t.duration_s * p.sensor->rate_hz + 1.0;
    if (p.sensor->rate_hz > fastest) {
      fastest = p.sensor->rate_hz;
      fastest_key = p.key;
    }
  }
  const double measured_bytes = measured_rows * measured_cols * kCsvBytesPerCell;
  const auto limit = static_cast<double>(kMaxTrialFileBytes);
  if (truth_bytes <= limit && measured_bytes <= limit) return;
  const bool truth = truth_bytes >= measured_bytes;
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "%s: %g Hz for %g s makes the %s record ~%.3g rows x %.0f columns (~%.1f GB as "
                "CSV), more than the %.0f GiB a trial file may hold; lower the rate or "
                "stimulation.duration_s",
                truth ? "sensors.truth_rate_hz" : fastest_key, truth ? s.truth_rate_hz : fastest,
                t.duration_s, truth ? "truth" : "measured",
                truth ? t.duration_s * s.truth_rate_hz + 1.0 : measured_rows,
                truth ? truth_cols : measured_cols, (truth ? truth_bytes : measured_bytes) / 1e9,
                limit / 1073741824.0);
  top.Fail(buf);
}

}  // namespace

// The parser proper; ParseScenario below names the file in any stray yaml-cpp exception.
static Scenario ParseScenarioText(const std::string& text, const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ":" + std::to_string(e.mark.line + 1) +
                             ": YAML syntax: " + e.msg);
  }
  Scenario sc;
  sc.path = path;
  sc.source_text = text;
  const Node top(root, "", &sc.path);
  top.Keys({"name", "participant", "gravity_m_s2", "coordinates", "muscles", "electrodes",
            "support", "mechanisms", "stimulation", "sensors", "integrator"});
  sc.name = top.FileStem("name");
  double height = 1.75, mass = 75.0;
  if (top.Has("participant")) {
    const Node p = top.Child("participant");
    p.Keys({"height_m", "mass_kg"});
    p.Number("height_m", 1.2, 2.2, &height);
    p.Number("mass_kg", 30, 150, &mass);
  }
  sc.model = sim::DefaultModelParams(height, mass);
  sim::ModelParams& m = sc.model;
  if (top.Has("gravity_m_s2")) {
    const auto g = top.Vector("gravity_m_s2", 3, -100, 100);
    m.gravity_m_s2 = {g[0], g[1], g[2]};
  }
  if (top.Has("coordinates")) LoadCoordinates(top.Child("coordinates"), &m);
  if (top.Has("muscles")) LoadMuscles(top.Child("muscles"), &m);
  if (top.Has("electrodes")) LoadElectrodes(top.Child("electrodes"), &m);
  if (top.Has("support")) LoadSupport(top.Child("support"), &m);
  if (top.Has("mechanisms")) LoadMechanisms(top.Child("mechanisms"), &m);
  sim::CalibrateReferenceLengths(&m);

  sim::TrialRequest& t = sc.trial;
  t.name = sc.name;
  // Default sensors: every free coordinate's angle at 60 Hz with 1° noise; torques on every
  // locked or prescribed coordinate at 100 Hz.
  t.sensors.angles.rate_hz = 60.0;
  t.sensors.angles.noise_std = 1.0 * kDeg;
  t.sensors.torques.rate_hz = 100.0;
  t.sensors.torques.noise_std = 0.01;
  t.sensors.velocities.rate_hz = 100.0;
  for (int i = 0; i < sim::kNumCoordinates; ++i) {
    (m.coordinates[i].mode == sim::CoordinateMode::kFree ? t.sensors.angles : t.sensors.torques)
        .coordinates.push_back(i);
  }
  LoadStimulation(top.Child("stimulation"), path, m, &t, &sc.reaching);
  if (sc.reaching) {
    // Robot-driven reaching: noiseless unless the sensors block says otherwise.
    t.sensors = sim::SensorSuite{};
    if (top.Has("sensors")) LoadReachingSensors(top.Child("sensors"), *sc.reaching, &t.sensors);
  } else if (top.Has("sensors")) {
    const Node s = top.Child("sensors");
    s.Keys({"angles", "velocities", "torques", "truth_rate_hz"});
    if (s.Has("angles")) LoadSensor(s.Child("angles"), "deg", kDeg, &t.sensors.angles);
    if (s.Has("velocities"))
      LoadSensor(s.Child("velocities"), "deg_s", kDeg, &t.sensors.velocities);
    if (s.Has("torques")) LoadSensor(s.Child("torques"), "nm", 1.0, &t.sensors.torques);
    for (const char* k : {"angles", "velocities", "torques"}) {
      if (s.Has(k) && s.Child(k).Has("lowpass_hz")) {
        s.Child(k).FailKey("lowpass_hz",
                           "only for robot-driven reaching (stimulation type "
                           "reaching)");
      }
    }
    s.Number("truth_rate_hz", 0.1, 20000, &t.sensors.truth_rate_hz);
    if (s.Has("torques")) {
      for (int i : t.sensors.torques.coordinates) {
        if (m.coordinates[i].mode == sim::CoordinateMode::kFree) {
          s.Child("torques").FailKey("coordinates", "torque sensor on free coordinate " +
                                                        sim::CoordinateNames()[i] +
                                                        " (allowed: locked or prescribed ones)");
        }
      }
    }
  }
  if (top.Has("integrator")) {
    const Node in = top.Child("integrator");
    in.Keys({"method", "tolerance"});
    if (in.Has("method")) {
      const std::string method = in.Choice("method", {"cvodes", "cvodes-adams", "simbody-rkm"});
      t.integrator.method = method == "cvodes" ? sim::IntegratorParams::Method::kCvodes
                            : method == "cvodes-adams"
                                ? sim::IntegratorParams::Method::kCvodesAdams
                                : sim::IntegratorParams::Method::kSimbodyRkMerson;
    }
    if (in.Has("tolerance")) t.integrator.tolerance = in.Number("tolerance", 1e-12, 1e-2);
  }
  try {
    sim::BuildElectrodeMatrix(m);
  } catch (const std::exception& e) {
    top.FailKey("electrodes", e.what());
  }
  if (!sc.reaching) CheckOutputSize(top, m, t);
  return sc;
}

Scenario ParseScenario(const std::string& text, const std::string& path) {
  return internal::WithYamlErrorsNamed(path, [&] { return ParseScenarioText(text, path); });
}

Scenario LoadScenario(const std::string& path) {
  std::string text;
  try {
    text = ReadFile(path);
  } catch (const std::exception& e) {
    throw std::runtime_error(e.what());
  }
  return ParseScenario(text, path);
}

}  // namespace fesim
