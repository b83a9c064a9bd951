#include "sim/default_model.h"

#include <cmath>

#include "sim/anthropometry.h"

namespace fesim::sim {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;
using tendons::Crossing;
using tendons::MomentArmParams;
using Model = MomentArmParams::Model;

Crossing Constant(int joint, double r_m) { return {joint, {Model::kConstant, r_m, 0.0}, 0.0}; }
/// eq. (10) with r(0) = r0 and r(π/2) = r90: d = r0, d̃ = (r90 − r0)/g(π/2), g(π/2) = (1 − π/2)/2.
Crossing Landsmeer(int joint, double r0_m, double r90_m) {
  const double g90 = (1.0 - 3.14159265358979323846 / 2.0) / 2.0;
  return {joint, {Model::kLandsmeer, r0_m, (r90_m - r0_m) / g90}, 0.0};
}

struct MuscleRow {
  const char* name;
  double f_max, l_opt, l_ts, penn_deg;  // Holzbaur 2005 Table 2
  double omega;                         // rad/s, assumed
  double alpha, beta, gamma;            // eq. (3), assumed
  std::vector<Crossing> crossings;
};

std::vector<MuscleRow> MuscleTable() {
  return {
      {"ECRL",
       337.3,
       0.081,
       0.224,
       0.0,
       6.0,
       0.35,
       0.026,
       60.0,
       {Constant(kElbowFlexion, 0.010), Constant(kWristFlexion, -0.010),
        Constant(kWristDeviation, 0.015)}},
      {"ECRB",
       252.5,
       0.0585,
       0.222,
       9.0,
       6.5,
       0.35,
       0.028,
       70.0,
       {Constant(kWristFlexion, -0.015), Constant(kWristDeviation, 0.010)}},
      {"ECU",
       192.9,
       0.0622,
       0.2285,
       4.0,
       5.5,
       0.35,
       0.025,
       55.0,
       {Constant(kWristFlexion, -0.006), Constant(kWristDeviation, -0.022)}},
      {"FCR",
       407.9,
       0.0628,
       0.244,
       3.0,
       7.0,
       0.35,
       0.027,
       65.0,
       {Constant(kWristFlexion, 0.015), Constant(kWristDeviation, 0.008)}},
      {"FCU",
       479.8,
       0.0509,
       0.2649,
       12.0,
       6.0,
       0.35,
       0.024,
       50.0,
       {Constant(kWristFlexion, 0.016), Constant(kWristDeviation, -0.015)}},
      {"EDC",
       23.5,
       0.070,
       0.322,
       3.0,
       8.0,
       0.4,
       0.030,
       80.0,
       {Constant(kWristFlexion, -0.011), Constant(kMcpFlexion, -0.008),
        Constant(kPipFlexion, -0.003), Constant(kDipFlexion, -0.002)}},
      {"FDS",
       162.5,
       0.0837,
       0.2578,
       6.0,
       7.5,
       0.3,
       0.027,
       75.0,
       {Constant(kWristFlexion, 0.015), Landsmeer(kMcpFlexion, 0.010, 0.013),
        Landsmeer(kPipFlexion, 0.0065, 0.0085)}},
      {"FDP",
       162.1,
       0.0749,
       0.2817,
       7.0,
       7.0,
       0.3,
       0.026,
       70.0,
       {Constant(kWristFlexion, 0.014), Landsmeer(kMcpFlexion, 0.0095, 0.0125),
        Landsmeer(kPipFlexion, 0.0055, 0.0075), Constant(kDipFlexion, 0.0035)}},
      {"BIC",
       624.3,
       0.1157,
       0.2723,
       0.0,
       5.0,
       0.3,
       0.022,
       45.0,
       {Constant(kShoulderElevation, 0.010), Landsmeer(kElbowFlexion, 0.015, 0.040),
        Constant(kProSup, -0.006)}},
      {"BRA",
       987.3,
       0.0858,
       0.0535,
       0.0,
       5.0,
       0.25,
       0.022,
       45.0,
       {Landsmeer(kElbowFlexion, 0.010, 0.025)}},
      {"BRD",
       261.3,
       0.1726,
       0.1329,
       0.0,
       5.5,
       0.3,
       0.024,
       50.0,
       {Landsmeer(kElbowFlexion, 0.020, 0.060)}},
      {"TRI",
       798.5,
       0.134,
       0.143,
       12.0,
       4.5,
       0.3,
       0.022,
       45.0,
       {Constant(kShoulderElevation, -0.015), Constant(kElbowFlexion, -0.021)}},
      {"DELT1",
       1142.6,
       0.0976,
       0.093,
       22.0,
       4.0,
       0.25,
       0.020,
       40.0,
       {Constant(kShoulderElvPlane, 0.020), Constant(kShoulderElevation, 0.025),
        Constant(kShoulderRotation, 0.008)}},
      {"DELT3",
       259.9,
       0.1367,
       0.038,
       18.0,
       4.0,
       0.25,
       0.020,
       40.0,
       {Constant(kShoulderElvPlane, -0.025), Constant(kShoulderElevation, 0.010),
        Constant(kShoulderRotation, -0.010)}},
  };
}

struct JointRow {
  int coordinate;
  double k, b, rest_deg, min_deg, max_deg, limit_k;
};

// k N·m/rad, b N·m·s/rad; Table I of [Schearer 2014] converted from per-degree units where cited.
std::vector<JointRow> JointTable() {
  return {
      {kShoulderElvPlane, 0.01 / kDeg, 0.007 / kDeg, 14.0, -90.0, 130.0, 10.0},  // 004 Table I
      {kShoulderElevation, 0.10 / kDeg, 0.003 / kDeg, 17.0, 5.0, 150.0, 10.0},   // 004 Table I
      {kShoulderRotation, 0.5, 0.1, 0.0, -90.0, 90.0, 10.0},                     // assumed
      {kElbowFlexion, 0.04 / kDeg, 0.009 / kDeg, 81.0, 0.0, 150.0, 10.0},        // 004 Table I
      {kProSup, 0.5, 0.05, 0.0, -80.0, 80.0, 5.0},                               // assumed
      {kWristFlexion, 0.8, 0.03, 0.0, -70.0, 80.0, 3.0},                         // Formica 2012
      {kWristDeviation, 1.2, 0.03, 0.0, -35.0, 20.0, 3.0},                       // assumed
      {kMcpFlexion, 0.15, 0.004, 20.0, -30.0, 90.0, 1.0},                        // Kamper 2002
      {kPipFlexion, 0.06, 0.0015, 30.0, 0.0, 110.0, 0.5},                        // assumed
      {kDipFlexion, 0.03, 0.0008, 15.0, 0.0, 80.0, 0.3},                         // assumed
  };
}

}  // namespace

const std::vector<std::string>& DefaultMuscleNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& row : MuscleTable()) n.emplace_back(row.name);
    return n;
  }();
  return names;
}

void CalibrateReferenceLengths(ModelParams* model) {
  std::vector<double> rest(kNumCoordinates);
  for (int i = 0; i < kNumCoordinates; ++i) {
    rest[i] = model->coordinates[i].passive.rest_angle_rad;
  }
  for (auto& m : model->muscles) {
    m.path.length_at_ref_m = 0.0;
    const double at_rest = tendons::MusculotendonLength(m.path, rest);  // = Σ Δl at rest
    m.path.length_at_ref_m = muscles::OptimalMusculotendonLength(m.hill) - at_rest;
  }
}

ModelParams DefaultModelParams(double height_m, double mass_kg) {
  ModelParams model;
  model.segments = ScaledSegments(height_m, mass_kg);
  const double scale = height_m / 1.75;
  // Acromion height 0.818 H and half biacromial breadth 0.129 H (Winter 2009 Fig. 4.1).
  model.shoulder_in_ground_m = {0.0, 0.818 * height_m, 0.129 * height_m};
  model.index_mcp_offset_m = 0.02 * scale;
  for (const auto& j : JointTable()) {
    auto& c = model.coordinates[j.coordinate];
    c.passive.stiffness_nm_per_rad = j.k;
    c.passive.damping_nms_per_rad = j.b;
    c.passive.rest_angle_rad = j.rest_deg * kDeg;
    c.passive.min_angle_rad = j.min_deg * kDeg;
    c.passive.max_angle_rad = j.max_deg * kDeg;
    c.passive.limit_stiffness_nm_per_rad = j.limit_k;
    c.initial_rad = c.passive.rest_angle_rad;
  }
  for (const auto& row : MuscleTable()) {
    MuscleParams m;
    m.name = row.name;
    m.hill.max_isometric_force_n = row.f_max;
    m.hill.optimal_fibre_length_m = row.l_opt * scale;
    m.hill.tendon_slack_length_m = row.l_ts * scale;
    m.hill.pennation_at_optimal_rad = row.penn_deg * kDeg;
    m.recruitment = {row.alpha, row.beta, row.gamma};
    m.activation_omega_rad_s = row.omega;
    m.path.name = row.name;
    m.path.crossings = row.crossings;
    model.muscles.push_back(m);
  }
  CalibrateReferenceLengths(&model);

  // 4×6 array on the forearm, rows along it from 3 cm below the elbow crease, columns around it
  // from the volar midline (c = 0) towards the dorsal side. Motor points: assumed positions
  // (flexors volar, extensors dorsal, proximal third of the forearm).
  model.array.rows = 4;
  model.array.cols = 6;
  model.array.pitch_m = 0.015 * scale;
  model.array.origin = {0.03 * scale, -0.0375 * scale};
  model.array.spread_m = 0.012 * scale;
  const auto mp = [scale](double s, double c) { return muscles::SkinPoint{s * scale, c * scale}; };
  model.array.motor_points = {{"FCR", mp(0.050, -0.030)}, {"FCU", mp(0.060, -0.040)},
                              {"FDS", mp(0.070, -0.020)}, {"FDP", mp(0.080, -0.030)},
                              {"ECRL", mp(0.040, 0.030)}, {"ECRB", mp(0.060, 0.035)},
                              {"EDC", mp(0.070, 0.030)},  {"ECU", mp(0.065, 0.040)}};
  // Channel 1: dorsal pads (cols 4–5, rows 1–3) for the extensors; channel 2: volar pads
  // (cols 0–1, rows 1–3) for the flexors — the two inputs of [Hand Hammerstein] §5.1.
  model.channels = {
      {"ext", {10, 11, 16, 17, 22, 23}, {}},     {"flex", {6, 7, 12, 13, 18, 19}, {}},
      {"bic", {}, {{"BIC", 1.0}, {"BRA", 0.3}}}, {"tri", {}, {{"TRI", 1.0}}},
      {"delt_ant", {}, {{"DELT1", 1.0}}},        {"delt_post", {}, {{"DELT3", 1.0}}},
  };
  return model;
}

}  // namespace fesim::sim
