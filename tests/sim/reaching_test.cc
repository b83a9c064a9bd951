// Robot-driven reaching end to end (sim/reaching.h, [Schearer 2014] §II, issue 3).
#include "sim/reaching.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>

#include "identification/inverse_dynamics.h"
#include "protocols/filters.h"
#include "sim/default_model.h"

namespace fesim::sim {
namespace {

constexpr double kIkTolM = 1e-6;               // issue: hand within 1e-6 m of the path at samples
constexpr double kRestVelocityTol = 1e-9;      // m/s, hand at segment ends
constexpr double kRestAccelerationTol = 1e-7;  // m/s²
constexpr double kTorqueTol = 1e-6;        // N·m, issue: sensor → Jacobian vs inverse dynamics
constexpr double kStiffnessRelTol = 0.20;  // issue: elbow stiffness within 20 %

/// One home, `targets` targets, one repetition: a short run.
protocols::ReachingParams ShortReaching(int targets) {
  protocols::ReachingParams r;
  r.homes_m.resize(1);
  r.targets_m.resize(targets);
  r.repetitions = 1;
  return r;
}

double Distance(const protocols::Vec3& a, const protocols::Vec3& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                   (a[2] - b[2]) * (a[2] - b[2]));
}

double Norm(const protocols::Vec3& a) { return Distance(a, {0.0, 0.0, 0.0}); }

struct Rig {
  protocols::HandPath path;
  ReachingKinematics kin;
  std::unique_ptr<UpperLimbModel> model;
};

Rig MakeRig(const ModelParams& base, const protocols::ReachingParams& reaching,
            const ReachingOptions& options) {
  Rig rig;
  rig.path = protocols::ReachingProgram(reaching);
  const UpperLimbModel ik(base);
  rig.kin = SolveReachingKinematics(ik, rig.path, options);
  rig.model = std::make_unique<UpperLimbModel>(PrescribedReachingModel(base, rig.kin));
  return rig;
}

TEST(Reaching, InverseKinematicsReproducesTheHandPathAtEverySample) {
  const ModelParams base = DefaultModelParams();
  const ReachingOptions options;
  const protocols::ReachingParams reaching = ShortReaching(9);  // every target from home 0
  const protocols::HandPath path = protocols::ReachingProgram(reaching);
  const UpperLimbModel ik(base);
  const ReachingKinematics kin = SolveReachingKinematics(ik, path, options);
  SimTK::State s = ik.system().getDefaultState();
  ik.system().realizeModel(s);
  double worst = 0.0;
  for (std::size_t k = 0; k < path.times_s.size(); ++k) {
    for (int j = 0; j < 4; ++j)
      ik.CoordinateBody(kReachingCoordinates[j]).setOneQ(s, 0, kin.q[k][j]);
    ik.system().realize(s, SimTK::Stage::Position);
    worst = std::max(worst, Distance(HandlePosition(ik, s, options), path.position_m[k]));
    // The swivel rule holds and the arm stays inside its passive range of motion.
    EXPECT_NEAR(kin.q[k][2], SwivelRotation(options, path.position_m[k]), 1e-12);
    for (int j = 0; j < 4; ++j) {
      const auto& pj = base.coordinates[kReachingCoordinates[j]].passive;
      EXPECT_GT(kin.q[k][j], pj.min_angle_rad) << "joint " << j << " t " << path.times_s[k];
      EXPECT_LT(kin.q[k][j], pj.max_angle_rad) << "joint " << j << " t " << path.times_s[k];
    }
  }
  EXPECT_LT(worst, kIkTolM);
}

TEST(Reaching, SimulatedHandFollowsThePathAndRestsAtSegmentEnds) {
  const ReachingOptions options;
  Rig rig = MakeRig(DefaultModelParams(), ShortReaching(2), options);
  SimTK::State s = rig.model->MakeInitialState();
  // At samples: the prescribed arm puts the handle on the path with the path's velocity.
  for (std::size_t k = 0; k < rig.path.times_s.size(); k += 7) {
    const ReachingSample r = EvaluateReachingSample(*rig.model, &s, rig.path.times_s[k], options);
    EXPECT_LT(Distance(r.p_GP_m, rig.path.position_m[k]), kIkTolM);
    EXPECT_LT(Distance(r.v_GP_m_s, rig.path.velocity_m_s[k]), 1e-9);
    EXPECT_LT(Distance(r.a_GP_m_s2, rig.path.acceleration_m_s2[k]), 1e-7);
  }
  // Between samples (spline interpolation) the hand stays on the path to well under a micron.
  for (double t = 0.005; t < rig.path.duration_s; t += 0.1) {
    const ReachingSample r = EvaluateReachingSample(*rig.model, &s, t, options);
    EXPECT_LT(Distance(r.p_GP_m, protocols::EvaluateHandPath(rig.path, t).position_m), kIkTolM)
        << t;
  }
  // Velocity and acceleration zero at both ends of every segment (issue 3), and not zero
  // mid-reach.
  for (const auto& seg : rig.path.segments) {
    for (double t : {seg.start_s, seg.start_s + seg.duration_s}) {
      const ReachingSample r = EvaluateReachingSample(*rig.model, &s, t, options);
      EXPECT_LT(Norm(r.v_GP_m_s), kRestVelocityTol) << t;
      EXPECT_LT(Norm(r.a_GP_m_s2), kRestAccelerationTol) << t;
    }
    if (seg.kind == protocols::SegmentKind::kReach) {
      const ReachingSample r =
          EvaluateReachingSample(*rig.model, &s, seg.start_s + 0.5 * seg.duration_s, options);
      EXPECT_GT(Norm(r.v_GP_m_s), 0.05);
    }
  }
}

// The key test: joint torques from the simulated force/torque sensor through the arm
// Jacobian (004 §II.A, τ_r = J_rᵀ f_r) equal the model's passive + gravity + inertial torques
// computed independently by Simbody's inverse dynamics, M(q)q̈ + c(q,q̇) − f_applied(q,q̇) with
// f_applied = gravity + passive joint moments + relaxed-muscle passive forces.
TEST(Reaching, SensorTorquesThroughJacobianEqualInverseDynamics) {
  const ReachingOptions options;
  ModelParams base = DefaultModelParams();
  Rig rig = MakeRig(base, ShortReaching(1), options);
  const UpperLimbModel& model = *rig.model;
  SimTK::State s = model.MakeInitialState();
  SimTK::State free_state = model.MakeInitialState();  // for the independent computation
  double max_tau = 0.0, max_force = 0.0;
  for (std::size_t k = 0; k < rig.path.times_s.size(); k += 3) {
    const double t = rig.path.times_s[k];
    const ReachingSample r = EvaluateReachingSample(model, &s, t, options);
    // Independent: q, q̇ from the IK tables, q̈ from the IK tables, applied forces from the force
    // subsystem at that state, residual = M q̈ + c − f_applied.
    SimTK::State& f = free_state;
    f.setTime(t);
    for (int j = 0; j < 4; ++j) {
      const auto& b = model.CoordinateBody(kReachingCoordinates[j]);
      b.setOneQ(f, 0, rig.kin.q[k][j]);
      b.setOneU(f, 0, rig.kin.qd[k][j]);
    }
    model.system().realize(f, SimTK::Stage::Dynamics);
    SimTK::Vector udot(f.getNU(), 0.0), residual;
    for (int j = 0; j < 4; ++j) {
      udot[model.CoordinateBody(kReachingCoordinates[j]).getFirstUIndex(f)] = rig.kin.qdd[k][j];
    }
    model.matter().calcResidualForceIgnoringConstraints(
        f, model.system().getMobilityForces(f, SimTK::Stage::Dynamics),
        model.system().getRigidBodyForces(f, SimTK::Stage::Dynamics), udot, residual);
    for (int j = 0; j < 4; ++j) {
      const int u = model.CoordinateBody(kReachingCoordinates[j]).getFirstUIndex(f);
      EXPECT_NEAR(r.tau_nm[j], residual[u], kTorqueTol) << "joint " << j << " t " << t;
      max_tau = std::max(max_tau, std::abs(residual[u]));
    }
    max_force = std::max(max_force, Norm(r.wrench.force_n));
  }
  // Not a vacuous comparison: the arm weighs on the robot.
  EXPECT_GT(max_tau, 1.0);
  EXPECT_GT(max_force, 5.0);
}

TEST(Reaching, WrenchIsLeastNormAndMapsBackToTheTorques) {
  const std::vector<std::array<double, 6>> cols = {{0.1, 0.2, 0.0, 0.0, 1.0, 0.0},
                                                   {0.0, 0.3, -0.1, 1.0, 0.0, 0.0},
                                                   {-0.2, 0.0, 0.1, 0.0, 0.6, 0.8},
                                                   {0.05, -0.1, 0.25, 0.0, 0.0, 1.0}};
  const std::array<double, 4> tau = {1.0, -2.0, 0.5, 3.0};
  const RobotWrench w = WrenchFromJointTorques(cols, tau);
  const std::array<double, 4> back = JointTorquesFromWrench(cols, w);
  for (int j = 0; j < 4; ++j) EXPECT_NEAR(back[j], tau[j], 1e-12);
}

TEST(Reaching, SimulateReachingGivesOneTrialPerReachWithTheInvDynColumns) {
  const ReachingOptions options;
  protocols::ReachingParams reaching = ShortReaching(2);
  reaching.repetitions = 2;
  const std::vector<Trial> trials = SimulateReaching(DefaultModelParams(), reaching, options);
  ASSERT_EQ(trials.size(), 4u);
  const std::size_t expected = static_cast<std::size_t>(
      std::lround((2 * reaching.reach_duration_s + reaching.hold_s) * reaching.sample_rate_hz) + 1);
  for (const Trial& t : trials) {
    EXPECT_EQ(t.size(), expected);
    EXPECT_EQ(t.metadata.at("protocol"), "reaching");
    for (const char* c :
         {"q.elbow_flexion", "qd.shoulder_elv_plane", "qdd.shoulder_rotation",
          "tau.shoulder_elevation", "f.robot_x", "f.robot_y", "f.robot_z", "m.robot_z"}) {
      EXPECT_TRUE(t.Has(c)) << c;
    }
    // The hand starts and ends at rest.
    EXPECT_NEAR(t.Column("qd.elbow_flexion").front(), 0.0, 1e-9);
    EXPECT_NEAR(t.Column("qd.elbow_flexion").back(), 0.0, 1e-9);
  }
  EXPECT_EQ(trials[0].metadata.at("trajectory"), "0-0");
  EXPECT_EQ(trials[1].metadata.at("trajectory"), "0-0");
  EXPECT_EQ(trials[1].metadata.at("repetition"), "1");
  EXPECT_EQ(trials[2].metadata.at("trajectory"), "0-1");
  const identification::ReachingData data = identification::ExtractReachingData(trials);
  EXPECT_EQ(data.joints.size(), 4u);
  EXPECT_EQ(data.group_names.size(), 2u);
}

// 004 §II.B eq. (3): with the arm support cancelling gravity (here: gravity off) the elbow torque
// of the 54 reaching trajectories is dominated by stiffness and damping, and invdyn-parametric
// recovers the model's elbow stiffness. The muscles are removed so that the joint's passive
// k, b, q₀ are the whole ground truth: relaxed muscles' passive fibre forces add their own
// posture-dependent stiffness (with the default muscles the fit gives ≈ 3.0 N·m/rad against the
// joint's 2.29, +32 %), which eq. (3) lumps into k_s.
TEST(Reaching, FiftyFourTrajectoriesFeedInvDynParametricWhichRecoversElbowStiffness) {
  ModelParams base = DefaultModelParams();
  base.gravity_m_s2 = {0.0, 0.0, 0.0};
  base.muscles.clear();
  base.channels.clear();
  base.array.motor_points.clear();
  const std::vector<Trial> trials =
      SimulateReaching(base, protocols::ReachingParams{}, ReachingOptions{});
  ASSERT_EQ(trials.size(), 54u);
  const identification::ReachingData data = identification::ExtractReachingData(trials);
  EXPECT_EQ(data.group_names.size(), 18u);
  int elbow = -1;
  for (std::size_t j = 0; j < data.joints.size(); ++j) {
    if (data.joints[j] == "elbow_flexion") elbow = static_cast<int>(j);
  }
  ASSERT_GE(elbow, 0);
  const int J = static_cast<int>(data.joints.size());
  const auto fit = identification::FitParametricJoint(data.X.col(elbow), data.X.col(J + elbow),
                                                      data.tau.col(elbow));
  const double k_true = base.coordinates[kElbowFlexion].passive.stiffness_nm_per_rad;
  const auto params = fit.Params();
  std::printf(
      "elbow: k_s %.4f (true %.4f) N·m/rad, k_d %.4f (true %.4f), theta0 %.4f (true %.4f)\n",
      params.k_s, k_true, params.k_d, base.coordinates[kElbowFlexion].passive.damping_nms_per_rad,
      params.theta0, base.coordinates[kElbowFlexion].passive.rest_angle_rad);
  EXPECT_NEAR(params.k_s, k_true, kStiffnessRelTol * k_true);
  // The same trials through the `fesim identify --method invdyn-parametric` entry (with its
  // leave-one-trajectory-out CV over the 18 paths).
  const identification::MethodResult r =
      identification::RunInvDynMethod(identification::InvDynKind::kParametric, trials, {}, nullptr);
  EXPECT_NE(r.model_yaml.find("elbow_flexion"), std::string::npos);
  EXPECT_EQ(r.predictions.size(), trials.size());
}

/// Standard deviation of a − b (sample, n − 1).
double ResidualStd(const std::vector<double>& a, const std::vector<double>& b) {
  double mean = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) mean += (a[i] - b[i]) / a.size();
  double ss = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) ss += (a[i] - b[i] - mean) * (a[i] - b[i] - mean);
  return std::sqrt(ss / (a.size() - 1));
}

constexpr double kNoiseStdRelTol = 0.08;  // ≈ 4 standard errors of a std from ≥ 1500 samples

// The measurement of sim/reaching.h: the joint angles carry their configured noise, and the
// joint torques that of the force sensor through the handle Jacobian: τ − τ_clean = J_fᵀ Δf with
// J_f the Jacobian's linear rows, so std(τ_j − τ_clean,j) = σ_f √(mean_k |J_f,k,j|²).
TEST(Reaching, AngleAndForceSensorNoiseArePresentAtTheConfiguredLevel) {
  const ModelParams base = DefaultModelParams();
  const ReachingOptions options;
  protocols::ReachingParams reaching = ShortReaching(2);
  reaching.repetitions = 2;
  SensorSuite sensors;
  sensors.angles.noise_std = 0.01;  // rad
  sensors.force.noise_std = 0.5;    // N
  const std::vector<Trial> clean = SimulateReaching(base, reaching, options);
  const std::vector<Trial> noisy = SimulateReaching(base, reaching, options, sensors, 7);
  ASSERT_EQ(clean.size(), noisy.size());
  // Jacobians at the same samples (time from each reach's start_time_s).
  const Rig rig = MakeRig(base, reaching, options);
  SimTK::State st = rig.model->MakeInitialState();
  const auto& names = CoordinateNames();
  for (int j = 0; j < 4; ++j) {
    const std::string joint = names[kReachingCoordinates[j]];
    std::vector<double> qa, qb, ta, tb;
    double jf2 = 0.0;
    std::size_t n = 0;
    for (std::size_t k = 0; k < clean.size(); ++k) {
      const double t0 = std::stod(clean[k].metadata.at("start_time_s"));
      for (std::size_t i = 0; i < clean[k].size(); ++i) {
        qa.push_back(noisy[k].Column("q." + joint)[i]);
        qb.push_back(clean[k].Column("q." + joint)[i]);
        ta.push_back(noisy[k].Column("tau." + joint)[i]);
        tb.push_back(clean[k].Column("tau." + joint)[i]);
        const ReachingSample r =
            EvaluateReachingSample(*rig.model, &st, t0 + clean[k].time[i], options);
        for (int d = 0; d < 3; ++d) jf2 += r.jacobian_columns[j][d] * r.jacobian_columns[j][d];
        ++n;
      }
    }
    ASSERT_GT(n, 1500u);
    EXPECT_NEAR(ResidualStd(qa, qb), sensors.angles.noise_std,
                kNoiseStdRelTol * sensors.angles.noise_std)
        << joint;
    const double expected = sensors.force.noise_std * std::sqrt(jf2 / n);
    EXPECT_NEAR(ResidualStd(ta, tb), expected, kNoiseStdRelTol * expected) << joint;
  }
  // The force sensor's own columns carry σ_f per axis.
  std::vector<double> fa, fb;
  for (std::size_t k = 0; k < clean.size(); ++k) {
    for (const char* c : {"f.robot_x", "f.robot_y", "f.robot_z"}) {
      fa.insert(fa.end(), noisy[k].Column(c).begin(), noisy[k].Column(c).end());
      fb.insert(fb.end(), clean[k].Column(c).begin(), clean[k].Column(c).end());
    }
  }
  EXPECT_NEAR(ResidualStd(fa, fb), sensors.force.noise_std,
              kNoiseStdRelTol * sensors.force.noise_std);
}

// With the low-pass on, the recorded noise is the white noise through the zero-phase filter:
// std = σ √(Σ g_n²), g the filter's impulse response (|H|², computed by filtering an impulse);
// the filter being linear, noisy − clean (both filtered) is exactly the filtered noise.
// Velocities are differences of the filtered angles, so qd of the noiseless run is near the exact
// rate (the zero-phase filter does not delay the motion).
TEST(Reaching, FilteredNoiseHasTheFiltersNoiseGainAndRatesAreNotDelayed) {
  const ModelParams base = DefaultModelParams();
  const ReachingOptions options;
  protocols::ReachingParams reaching = ShortReaching(2);
  reaching.repetitions = 3;
  reaching.sample_rate_hz = 25.0;
  SensorSuite filtered;
  filtered.angles.lowpass_hz = 2.0;
  filtered.force.lowpass_hz = 2.0;
  SensorSuite noisy = filtered;
  noisy.angles.noise_std = 0.01;
  const std::vector<Trial> a = SimulateReaching(base, reaching, options, noisy, 3);
  const std::vector<Trial> b = SimulateReaching(base, reaching, options, filtered, 3);
  const std::vector<Trial> exact = SimulateReaching(base, reaching, options);
  // Noise gain of the zero-phase second-order Butterworth at 2 Hz / 25 Hz.
  const auto sections = protocols::DesignButterworthLowPass(2, 2.0, 25.0);
  std::vector<double> impulse(401, 0.0);
  impulse[200] = 1.0;
  const std::vector<double> g = protocols::FilterZeroPhase(sections, impulse, 400);
  double g2 = 0.0;
  for (double v : g) g2 += v * v;
  std::vector<double> qa, qb;
  double worst_rate = 0.0, peak_rate = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    for (const auto& name : a[k].NamesWithPrefix("q.")) {
      // Away from the trial's ends, where the reflection padding stands in for unseen samples.
      const auto& x = a[k].Column(name);
      const auto& y = b[k].Column(name);
      for (std::size_t i = 10; i + 10 < x.size(); ++i) qa.push_back(x[i]), qb.push_back(y[i]);
      const std::string rate = "qd." + name.substr(2);
      for (std::size_t i = 0; i < x.size(); ++i) {
        worst_rate =
            std::max(worst_rate, std::abs(b[k].Column(rate)[i] - exact[k].Column(rate)[i]));
        peak_rate = std::max(peak_rate, std::abs(exact[k].Column(rate)[i]));
      }
    }
  }
  const double expected = noisy.angles.noise_std * std::sqrt(g2);
  ASSERT_GT(qa.size(), 1000u);
  EXPECT_NEAR(ResidualStd(qa, qb), expected, 0.1 * expected);
  EXPECT_LT(expected, 0.5 * noisy.angles.noise_std);  // the filter removes most of white noise
  // Central differences of the filtered angles at 25 Hz: within 10 % of the peak joint rate.
  EXPECT_LT(worst_rate, 0.1 * peak_rate);
}

}  // namespace
}  // namespace fesim::sim
