#include "sim/reaching.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "protocols/filters.h"
#include "sim/sensors.h"

namespace fesim::sim {

using protocols::Vec3;
using SimTK::Mat33;
using SimTK::State;

namespace {

constexpr double kMaxNewtonStepRad = 0.3;  // step limit of the IK Newton iteration, rad
constexpr double kMinAbsDeterminant = 1e-12;
constexpr double kWindowTolS = 1e-9;  // sample-time tolerance when cutting trials, s

SimTK::Vec3 ToSimTK(const std::array<double, 3>& a) { return SimTK::Vec3(a[0], a[1], a[2]); }
Vec3 FromSimTK(const SimTK::Vec3& v) { return {v[0], v[1], v[2]}; }

const SimTK::MobilizedBody& Hand(const UpperLimbModel& model) { return model.SegmentBody(kHand); }

/// Columns of the 3×4 station Jacobian of P for the four arm coordinates.
std::array<SimTK::Vec3, 4> StationColumns(const UpperLimbModel& model, const State& s,
                                          const ReachingOptions& o) {
  SimTK::Matrix JS;
  model.matter().calcStationJacobian(s, Hand(model).getMobilizedBodyIndex(),
                                     ToSimTK(o.handle_in_hand_m), JS);
  std::array<SimTK::Vec3, 4> out;
  for (int j = 0; j < 4; ++j) {
    const int u = model.CoordinateBody(kReachingCoordinates[j]).getFirstUIndex(s);
    out[j] = SimTK::Vec3(JS(0, u), JS(1, u), JS(2, u));
  }
  return out;
}

/// J₃ = columns of plane, elevation and elbow.
Mat33 SquareJacobian(const std::array<SimTK::Vec3, 4>& c) {
  Mat33 J;
  for (int r = 0; r < 3; ++r) {
    J(r, 0) = c[0][r];
    J(r, 1) = c[1][r];
    J(r, 2) = c[3][r];
  }
  return J;
}

SimTK::Vec3 Solve3(const Mat33& J, const SimTK::Vec3& b, double t) {
  if (std::abs(SimTK::det(J)) < kMinAbsDeterminant) {
    throw std::runtime_error("reaching IK: singular arm Jacobian at t = " + std::to_string(t) +
                             " s");
  }
  return J.invert() * b;
}

void SetArmQ(const UpperLimbModel& model, State& s, const std::array<double, 4>& q) {
  for (int j = 0; j < 4; ++j) model.CoordinateBody(kReachingCoordinates[j]).setOneQ(s, 0, q[j]);
}

void SetArmU(const UpperLimbModel& model, State& s, const std::array<double, 4>& u) {
  for (int j = 0; j < 4; ++j) model.CoordinateBody(kReachingCoordinates[j]).setOneU(s, 0, u[j]);
}

double Dot(const std::array<double, 3>& a, const Vec3& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/// dv/dt by central differences, one-sided at the ends.
std::vector<double> Differentiate(const std::vector<double>& t, const std::vector<double>& v) {
  const std::size_t n = v.size();
  std::vector<double> d(n, 0.0);
  if (n < 2) return d;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t lo = k == 0 ? 0 : k - 1, hi = k + 1 == n ? k : k + 1;
    d[k] = (v[hi] - v[lo]) / (t[hi] - t[lo]);
  }
  return d;
}

/// The rig's processing of one sensor (file comment of sim/reaching.h): active when the sensor
/// has noise or a low-pass; the zero-phase Butterworth of order kLowpassOrder.
struct Processing {
  static constexpr int kLowpassOrder = 2;
  Processing(const SensorParams& p, double rate_hz, const std::string& name)
      : active(p.noise_std > 0.0 || p.lowpass_hz > 0.0) {
    if (p.lowpass_hz <= 0.0) return;
    if (!(p.lowpass_hz < 0.5 * rate_hz)) {
      throw std::invalid_argument(name + ".lowpass_hz = " + std::to_string(p.lowpass_hz) +
                                  " is not below half the reaching sample rate (" +
                                  std::to_string(0.5 * rate_hz) + " Hz)");
    }
    sections = protocols::DesignButterworthLowPass(kLowpassOrder, p.lowpass_hz, rate_hz);
    // Odd-reflection padding of three periods of the cutoff (the transient's length).
    padding = static_cast<std::size_t>(std::ceil(3.0 * rate_hz / p.lowpass_hz));
  }
  std::vector<double> Filter(const std::vector<double>& x) const {
    return sections.empty() ? x : protocols::FilterZeroPhase(sections, x, padding);
  }
  bool active = false;
  std::vector<protocols::Biquad> sections;
  std::size_t padding = 0;
};

}  // namespace

double SwivelRotation(const ReachingOptions& o, const Vec3& p) {
  const Vec3 d = {p[0] - o.rotation_reference_m[0], p[1] - o.rotation_reference_m[1],
                  p[2] - o.rotation_reference_m[2]};
  return o.rotation_at_reference_rad + Dot(o.rotation_gradient_rad_per_m, d);
}

Vec3 HandlePosition(const UpperLimbModel& model, const State& s, const ReachingOptions& o) {
  return FromSimTK(Hand(model).findStationLocationInGround(s, ToSimTK(o.handle_in_hand_m)));
}

std::vector<std::array<double, 6>> HandleJacobianColumns(const UpperLimbModel& model,
                                                         const State& s, const ReachingOptions& o) {
  SimTK::RowVector_<SimTK::SpatialVec> JF;
  model.matter().calcFrameJacobian(s, Hand(model).getMobilizedBodyIndex(),
                                   ToSimTK(o.handle_in_hand_m), JF);
  std::vector<std::array<double, 6>> cols(4);
  for (int j = 0; j < 4; ++j) {
    const int u = model.CoordinateBody(kReachingCoordinates[j]).getFirstUIndex(s);
    const SimTK::SpatialVec& c = JF[u];  // [ω; v]
    cols[j] = {c[1][0], c[1][1], c[1][2], c[0][0], c[0][1], c[0][2]};
  }
  return cols;
}

ReachingKinematics SolveReachingKinematics(const UpperLimbModel& model,
                                           const protocols::HandPath& path,
                                           const ReachingOptions& o) {
  if (!(o.ik_tolerance_m > 0.0) || o.ik_max_iterations < 1) {
    throw std::invalid_argument(
        "ReachingOptions: ik_tolerance_m must be > 0 and "
        "ik_max_iterations ≥ 1");
  }
  const std::size_t n = path.times_s.size();
  if (n == 0 || path.position_m.size() != n || path.velocity_m_s.size() != n ||
      path.acceleration_m_s2.size() != n) {
    throw std::invalid_argument("SolveReachingKinematics: hand path samples missing or unequal");
  }
  const auto& matter = model.matter();
  const auto& system = model.system();
  State s = system.getDefaultState();
  system.realizeModel(s);
  for (int i = 0; i < kNumCoordinates; ++i) {
    model.CoordinateBody(i).setOneQ(s, 0, model.params().coordinates[i].initial_rad);
    model.CoordinateBody(i).setOneU(s, 0, 0.0);
  }
  const SimTK::Vec3 handle = ToSimTK(o.handle_in_hand_m);
  const SimTK::Vec3 g = ToSimTK(o.rotation_gradient_rad_per_m);

  ReachingKinematics out;
  out.times_s = path.times_s;
  out.q.resize(n);
  out.qd.resize(n);
  out.qdd.resize(n);
  std::array<double, 4> q = o.initial_guess_rad;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = path.times_s[k];
    const SimTK::Vec3 p = ToSimTK(path.position_m[k]);
    q[2] = SwivelRotation(o, path.position_m[k]);
    bool converged = false;
    for (int it = 0; it <= o.ik_max_iterations; ++it) {
      SetArmQ(model, s, q);
      system.realize(s, SimTK::Stage::Position);
      const SimTK::Vec3 e = p - Hand(model).findStationLocationInGround(s, handle);
      if (e.norm() <= o.ik_tolerance_m) {
        converged = true;
        break;
      }
      if (it == o.ik_max_iterations) break;
      SimTK::Vec3 dq = Solve3(SquareJacobian(StationColumns(model, s, o)), e, t);
      const double big = std::max({std::abs(dq[0]), std::abs(dq[1]), std::abs(dq[2])});
      if (big > kMaxNewtonStepRad) dq *= kMaxNewtonStepRad / big;
      q[0] += dq[0];
      q[1] += dq[1];
      q[3] += dq[2];
    }
    if (!converged) {
      throw std::runtime_error("reaching IK: no joint angles reach the hand target at t = " +
                               std::to_string(t) + " s (outside the arm's workspace?)");
    }
    // Rates: exact differentials of the swivel rule and of p_GP(q) = p.
    const auto cols = StationColumns(model, s, o);
    const Mat33 J3 = SquareJacobian(cols);
    const SimTK::Vec3 v = ToSimTK(path.velocity_m_s[k]);
    const SimTK::Vec3 a = ToSimTK(path.acceleration_m_s2[k]);
    std::array<double, 4> qd{}, qdd{};
    qd[2] = SimTK::dot(g, v);
    const SimTK::Vec3 qd3 = Solve3(J3, v - cols[2] * qd[2], t);
    qd[0] = qd3[0];
    qd[1] = qd3[1];
    qd[3] = qd3[2];
    SetArmU(model, s, qd);
    system.realize(s, SimTK::Stage::Velocity);
    const SimTK::Vec3 bias =
        matter.calcBiasForStationJacobian(s, Hand(model).getMobilizedBodyIndex(), handle);
    qdd[2] = SimTK::dot(g, a);
    const SimTK::Vec3 qdd3 = Solve3(J3, a - bias - cols[2] * qdd[2], t);
    qdd[0] = qdd3[0];
    qdd[1] = qdd3[1];
    qdd[3] = qdd3[2];
    out.q[k] = q;
    out.qd[k] = qd;
    out.qdd[k] = qdd;
  }
  return out;
}

ModelParams PrescribedReachingModel(const ModelParams& base, const ReachingKinematics& kin) {
  ModelParams p = base;
  for (auto& c : p.coordinates) {
    c.mode = CoordinateMode::kLocked;
    c.table = TablePrescription{};
  }
  for (int j = 0; j < 4; ++j) {
    CoordinateParams& c = p.coordinates[kReachingCoordinates[j]];
    c.mode = CoordinateMode::kPrescribed;
    TablePrescription& t = c.table;
    t.times_s = kin.times_s;
    for (std::size_t k = 0; k < kin.times_s.size(); ++k) {
      t.q_rad.push_back(kin.q[k][j]);
      t.qd_rad_s.push_back(kin.qd[k][j]);
      t.qdd_rad_s2.push_back(kin.qdd[k][j]);
    }
    if (!kin.q.empty()) c.initial_rad = kin.q.front()[j];
  }
  return p;
}

RobotWrench WrenchFromJointTorques(const std::vector<std::array<double, 6>>& cols,
                                   const std::array<double, 4>& tau) {
  if (cols.size() != 4) throw std::invalid_argument("WrenchFromJointTorques: need 4 columns");
  SimTK::Mat44 G;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      double d = 0.0;
      for (int r = 0; r < 6; ++r) d += cols[i][r] * cols[j][r];
      G(i, j) = d;
    }
  }
  if (std::abs(SimTK::det(G)) < kMinAbsDeterminant) {
    throw std::runtime_error("WrenchFromJointTorques: handle Jacobian is rank deficient");
  }
  const SimTK::Vec4 y = G.invert() * SimTK::Vec4(tau[0], tau[1], tau[2], tau[3]);
  std::array<double, 6> w{};
  for (int r = 0; r < 6; ++r) {
    for (int j = 0; j < 4; ++j) w[r] += cols[j][r] * y[j];
  }
  return {{w[0], w[1], w[2]}, {w[3], w[4], w[5]}};
}

std::array<double, 4> JointTorquesFromWrench(const std::vector<std::array<double, 6>>& cols,
                                             const RobotWrench& w) {
  // τ_j = column_j · [f; m] (protocols::JointTorquesFromEndEffectorForce with r_wb = 0 for the
  // force part, plus the moment part).
  const std::vector<double> tf =
      protocols::JointTorquesFromEndEffectorForce(w.force_n, {0.0, 0.0, 0.0}, cols);
  std::array<double, 4> tau{};
  for (int j = 0; j < 4; ++j) {
    tau[j] = tf[j] + cols[j][3] * w.moment_nm[0] + cols[j][4] * w.moment_nm[1] +
             cols[j][5] * w.moment_nm[2];
  }
  return tau;
}

ReachingSample EvaluateReachingSample(const UpperLimbModel& model, State* state, double t_s,
                                      const ReachingOptions& o) {
  State& s = *state;
  s.setTime(t_s);
  model.system().prescribe(s);
  model.system().realize(s, SimTK::Stage::Acceleration);
  ReachingSample out;
  const std::vector<double> tau = model.SensorTorques(s);
  for (int j = 0; j < 4; ++j) {
    const auto& b = model.CoordinateBody(kReachingCoordinates[j]);
    out.q[j] = b.getOneQ(s, 0);
    out.qd[j] = b.getOneU(s, 0);
    out.qdd[j] = b.getOneUDot(s, 0);
    // SensorTorques is what the limb exerts on the rig; the robot applies the opposite.
    out.robot_torque_nm[j] = -tau[kReachingCoordinates[j]];
  }
  out.jacobian_columns = HandleJacobianColumns(model, s, o);
  out.wrench = WrenchFromJointTorques(out.jacobian_columns, out.robot_torque_nm);
  out.tau_nm = JointTorquesFromWrench(out.jacobian_columns, out.wrench);
  const SimTK::Vec3 handle = ToSimTK(o.handle_in_hand_m);
  out.p_GP_m = FromSimTK(Hand(model).findStationLocationInGround(s, handle));
  out.v_GP_m_s = FromSimTK(Hand(model).findStationVelocityInGround(s, handle));
  out.a_GP_m_s2 = FromSimTK(Hand(model).findStationAccelerationInGround(s, handle));
  return out;
}

std::vector<Trial> SimulateReaching(const ModelParams& base,
                                    const protocols::ReachingParams& reaching,
                                    const ReachingOptions& o, const SensorSuite& sensors,
                                    std::uint64_t seed) {
  const protocols::HandPath path = protocols::ReachingProgram(reaching);
  const Processing angle_processing(sensors.angles, reaching.sample_rate_hz, "sensors.angles");
  const Processing force_processing(sensors.force, reaching.sample_rate_hz, "sensors.force");
  ModelParams free_arm = base;
  for (int c : kReachingCoordinates) {
    free_arm.coordinates[c].mode = CoordinateMode::kFree;
    free_arm.coordinates[c].table = TablePrescription{};
  }
  const UpperLimbModel ik_model(free_arm);
  const ReachingKinematics kin = SolveReachingKinematics(ik_model, path, o);
  const UpperLimbModel model(PrescribedReachingModel(base, kin));
  State s = model.MakeInitialState();

  const auto& names = CoordinateNames();
  std::vector<Trial> trials;
  const auto& segs = path.segments;
  for (std::size_t i = 0; i < segs.size(); ++i) {
    if (segs[i].kind != protocols::SegmentKind::kReach) continue;
    std::size_t last = i;
    while (last + 1 < segs.size() &&
           (segs[last + 1].kind == protocols::SegmentKind::kHold ||
            segs[last + 1].kind == protocols::SegmentKind::kReturn) &&
           segs[last].kind != protocols::SegmentKind::kReturn) {
      ++last;
    }
    const double t0 = segs[i].start_s;
    const double t1 = segs[last].start_s + segs[last].duration_s;
    Trial trial;
    trial.metadata["protocol"] = "reaching";
    trial.metadata["source"] = "fesim robot-driven reaching (papers/004 §II.A)";
    trial.metadata["trajectory"] =
        std::to_string(segs[i].home_index) + "-" + std::to_string(segs[i].target_index);
    trial.metadata["home"] = std::to_string(segs[i].home_index);
    trial.metadata["target"] = std::to_string(segs[i].target_index);
    trial.metadata["repetition"] = std::to_string(segs[i].repetition);
    trial.metadata["start_time_s"] = std::to_string(t0);
    std::vector<std::vector<double>> cols(4 * 4 + 6);
    // Per reach, independent streams for the angle and force noise.
    const std::uint64_t reach = trials.size();
    GaussianNoise angle_noise(DeriveSeed(seed, 2 * reach + 1));
    GaussianNoise force_noise(DeriveSeed(seed, 2 * reach + 2));
    for (std::size_t k = 0; k < path.times_s.size(); ++k) {
      const double t = path.times_s[k];
      if (t < t0 - kWindowTolS || t > t1 + kWindowTolS) continue;
      ReachingSample r = EvaluateReachingSample(model, &s, t, o);
      trial.time.push_back(t - t0);
      if (force_processing.active) {
        for (double& f : r.wrench.force_n) f += force_noise.Sample(sensors.force.noise_std);
        r.tau_nm = JointTorquesFromWrench(r.jacobian_columns, r.wrench);
      }
      for (int j = 0; j < 4; ++j) {
        const double q_noise =
            angle_processing.active ? angle_noise.Sample(sensors.angles.noise_std) : 0.0;
        cols[j].push_back(r.q[j] + q_noise);
        cols[4 + j].push_back(r.qd[j]);
        cols[8 + j].push_back(r.qdd[j]);
        cols[12 + j].push_back(r.tau_nm[j]);
      }
      for (int d = 0; d < 3; ++d) {
        cols[16 + d].push_back(r.wrench.force_n[d]);
        cols[19 + d].push_back(r.wrench.moment_nm[d]);
      }
    }
    for (int j = 0; j < 4; ++j) {
      if (angle_processing.active) {
        cols[j] = angle_processing.Filter(cols[j]);
        cols[4 + j] = Differentiate(trial.time, cols[j]);
        cols[8 + j] = Differentiate(trial.time, cols[4 + j]);
      }
      if (force_processing.active) cols[12 + j] = force_processing.Filter(cols[12 + j]);
    }
    const char* prefixes[4] = {"q.", "qd.", "qdd.", "tau."};
    for (int g = 0; g < 4; ++g) {
      for (int j = 0; j < 4; ++j) {
        trial.AddColumn(prefixes[g] + names[kReachingCoordinates[j]], std::move(cols[4 * g + j]));
      }
    }
    const char* axes[3] = {"x", "y", "z"};
    for (int d = 0; d < 3; ++d) trial.AddColumn(std::string("f.robot_") + axes[d], cols[16 + d]);
    for (int d = 0; d < 3; ++d) trial.AddColumn(std::string("m.robot_") + axes[d], cols[19 + d]);
    trials.push_back(std::move(trial));
  }
  return trials;
}

}  // namespace fesim::sim
