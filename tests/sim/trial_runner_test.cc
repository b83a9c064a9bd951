// Trials with mechanisms switched on: each changes the output as its model says (issue 3).
#include "sim/trial_runner.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <complex>

#include "sim/default_model.h"
#include "sim/mechanisms.h"
#include "tests/testing/rk4.h"

namespace fesim::sim {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;
constexpr double kTimeConstantTol = 0.10;  // issue 3: "within 10 %"

/// Every coordinate locked at rest, no gravity: an isometric rig with an elbow torque sensor.
ModelParams LockedRig() {
  ModelParams p = DefaultModelParams();
  p.gravity_m_s2 = {0, 0, 0};
  for (auto& c : p.coordinates) {
    c.mode = CoordinateMode::kLocked;
    c.initial_rad = c.passive.rest_angle_rad;
  }
  return p;
}

TrialRequest Request(double duration, std::vector<double> times,
                     std::vector<std::vector<double>> values) {
  TrialRequest r;
  r.duration_s = duration;
  r.stimulation.times = std::move(times);
  r.stimulation.values = std::move(values);
  r.sensors.angles.coordinates.clear();
  r.sensors.torques.coordinates = {kElbowFlexion};
  r.sensors.torques.rate_hz = 100.0;
  r.sensors.truth_rate_hz = 100.0;
  return r;
}

TEST(TrialRunner, FatigueDecaysWithTheConfiguredTimeConstant) {
  ModelParams p = LockedRig();
  p.mechanisms.fatigue = {true, 5.0, 300.0, 0.3};
  p.channels[2].muscle_weights = {{"BIC", 1.0}};  // one muscle, one time constant
  const UpperLimbModel model(p);
  TrialRequest r = Request(60.0, {0.0}, {{0, 0, 250, 0, 0, 0}});
  r.sensors.truth_rate_hz = 10.0;
  const TrialResult res = RunTrial(model, r);
  const auto& tau = res.truth.Column("tau.elbow_flexion");
  const auto& a = res.truth.Column("a.BIC");
  // After activation settles (t ≥ 3 s) a is constant, fitness relaxes with
  // τ = 1/(a/T_fat + (1 − a)/T_rec) towards φ∞, and the active torque is ∝ φ.
  const double act = a[30];
  const double tau_expected = 1.0 / (act / 5.0 + (1 - act) / 300.0);
  const double phi_inf = (0.3 * act / 5.0 + (1 - act) / 300.0) * tau_expected;
  // Locked at the rest posture, where every fibre is at optimal length, the passive fibre
  // force is zero and the elbow torque is K·φ(t): it decays from φ(t0) towards φ∞ with τ.
  const int i0 = 30;  // t0 = 3 s
  const double t0 = 3.0;
  const double phi_t0 = phi_inf + (1.0 - phi_inf) * std::exp(-t0 / tau_expected);
  const double tau_inf_expected = tau[i0] * phi_inf / phi_t0;
  const int i1 = static_cast<int>(std::lround((t0 + tau_expected) * 10.0));
  const double ratio = (tau[i1] - tau_inf_expected) / (tau[i0] - tau_inf_expected);
  EXPECT_NEAR(-tau_expected / std::log(ratio) / tau_expected, 1.0, kTimeConstantTol)
      << "tau expected " << tau_expected << " s";
  // The fatigued level, reached after 60 s ≫ τ.
  EXPECT_NEAR(tau.back() / tau_inf_expected, 1.0, kTimeConstantTol);
  EXPECT_LT(tau.back(), 0.6 * tau[i0]);
}

TEST(TrialRunner, DelayShiftsTheResponseByTheConfiguredLag) {
  ModelParams p = LockedRig();
  const UpperLimbModel plain(p);
  p.mechanisms.electromechanical_delay_s = 0.05;  // 5 samples at 100 Hz
  const UpperLimbModel delayed(p);
  const TrialRequest r = Request(2.0, {0.5}, {{0, 0, 200, 0, 0, 0}});
  const auto a = RunTrial(plain, r).truth;
  const auto b = RunTrial(delayed, r).truth;
  const auto& ta = a.Column("tau.elbow_flexion");
  const auto& tb = b.Column("tau.elbow_flexion");
  double moved = 0.0;
  for (std::size_t i = 5; i < ta.size(); ++i) {
    EXPECT_NEAR(tb[i], ta[i - 5], 1e-6) << "t = " << a.time[i];
    moved = std::max(moved, std::abs(ta[i]));
  }
  EXPECT_GT(moved, 1.0);
  // The trial records the commanded stimulation, not the delayed one.
  EXPECT_EQ(b.Column("u.bic")[51], 200.0);
}

TEST(TrialRunner, TremorPutsASpectralPeakAtItsFrequency) {
  ModelParams p = LockedRig();
  p.coordinates[kWristFlexion].mode = CoordinateMode::kFree;
  p.mechanisms.tremor.enabled = true;
  p.mechanisms.tremor.coordinate = kWristFlexion;
  p.mechanisms.tremor.frequency_hz = 7.0;
  p.mechanisms.tremor.amplitude_nm = 0.05;
  const UpperLimbModel model(p);
  TrialRequest r = Request(10.0, {}, {});
  r.sensors.torques.coordinates.clear();
  const auto t = RunTrial(model, r).truth;
  const auto& q = t.Column("q.wrist_flexion");
  // DFT magnitude over 2–15 Hz after a 2 s run-in (0.125 Hz resolution over 8 s).
  double best_f = 0.0, best = 0.0;
  for (double f = 2.0; f <= 15.0; f += 0.125) {
    std::complex<double> acc = 0.0;
    for (std::size_t i = 200; i < q.size() - 1; ++i) {
      acc += q[i] * std::polar(1.0, -2.0 * M_PI * f * t.time[i]);
    }
    if (std::abs(acc) > best) {
      best = std::abs(acc);
      best_f = f;
    }
  }
  EXPECT_NEAR(best_f, 7.0, 0.125);
}

TEST(TrialRunner, PotentiationEnhancesATestContractionAfterConditioning) {
  ModelParams p = LockedRig();
  p.channels[2].muscle_weights = {{"BIC", 1.0}};
  p.mechanisms.potentiation = {true, 0.5, 2.0, 60.0};
  const UpperLimbModel model(p);
  // Test pulse 0–1 s, conditioning 3–13 s, rest, test pulse 15–16 s.
  const TrialRequest r = Request(16.0, {0.0, 1.0, 3.0, 13.0, 15.0},
                                 {{0, 0, 150, 0, 0, 0},
                                  {0, 0, 0, 0, 0, 0},
                                  {0, 0, 250, 0, 0, 0},
                                  {0, 0, 0, 0, 0, 0},
                                  {0, 0, 150, 0, 0, 0}});
  const TrialResult res = RunTrial(model, r);
  const auto& tau = res.truth.Column("tau.elbow_flexion");
  const double first = tau[100], second = tau[1600];  // end of each test pulse
  EXPECT_GT(second, 1.1 * first);
}

TEST(TrialRunner, CrosstalkReachesMusclesBeyondTheElectrodeMatrix) {
  ModelParams p = DefaultModelParams();
  const auto clean = BuildElectrodeMatrix(p);
  p.mechanisms.crosstalk = {0.2, 0.03};
  const auto leaky = BuildElectrodeMatrix(p);
  const int bra = 9, tri_channel = 3, fcr = 3, ext_channel = 0;
  ASSERT_EQ(p.muscles[bra].name, "BRA");
  EXPECT_EQ(clean(bra, tri_channel), 0.0);
  EXPECT_NEAR(leaky(bra, tri_channel), 0.2, 1e-12);  // the triceps pair leaks to an elbow flexor
  EXPECT_GT(leaky(fcr, ext_channel), 2.0 * clean(fcr, ext_channel));  // wider array spread
}

TEST(TrialRunner, SpasticityAddsVelocityDependentResistanceAboveThreshold) {
  ModelParams p = LockedRig();
  auto& elbow = p.coordinates[kElbowFlexion];
  elbow.mode = CoordinateMode::kPrescribed;
  elbow.prescription = {80 * kDeg, 30 * kDeg, 1.0, 0.0};  // peak speed 3.3 rad/s
  const UpperLimbModel plain(p);
  elbow.passive.reflex_gain_nms_per_rad = 0.8;
  elbow.passive.reflex_threshold_rad_s = 1.0;
  const UpperLimbModel spastic(p);
  const TrialRequest r = Request(2.0, {}, {});
  const auto a = RunTrial(plain, r).truth;
  const auto b = RunTrial(spastic, r).truth;
  int active = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double qd = a.Column("qd.elbow_flexion")[i];
    const double expected = ReflexTorque(0.8, 1.0, qd);
    // The driven joint's sensor reads the limb's applied moments, now including the reflex.
    EXPECT_NEAR(b.Column("tau.elbow_flexion")[i] - a.Column("tau.elbow_flexion")[i], expected,
                1e-6);
    active += expected != 0.0;
  }
  EXPECT_GT(active, 50);
}

TEST(TrialRunner, StretchReflexActivatesAStretchedFlexorThroughItsLoopLagAndActivation) {
  // The wrist moved by a prescribed sine, no stimulation: FCR's activation is its reflex
  // activation alone, the cascade of mechanisms.h driven by its stretch velocity
  // ṽ = −d q̇ / l_opt (FCR's wrist moment arm d is constant; the other joints are locked). A
  // reference integration of that cascade by RK4 must give the trial's a.FCR; EDC, without the
  // reflex, stays at 0.
  ModelParams p = LockedRig();
  auto& wrist = p.coordinates[kWristFlexion];
  wrist.mode = CoordinateMode::kPrescribed;
  wrist.prescription = {0.0, 30 * kDeg, 1.0, 0.0};  // peak speed 3.3 rad/s
  p.mechanisms.stretch_reflex.gain = 0.5;
  p.mechanisms.stretch_reflex.threshold_per_s = 0.1;
  p.mechanisms.stretch_reflex.muscles = {"FCR", "FCU"};
  const int fcr = 3;
  ASSERT_EQ(p.muscles[fcr].name, "FCR");
  const auto& cr = p.muscles[fcr].path.crossings.at(0);
  ASSERT_EQ(cr.joint, kWristFlexion);
  ASSERT_EQ(cr.arm.model, tendons::MomentArmParams::Model::kConstant);
  const double d = cr.arm.d_m, l_opt = p.muscles[fcr].hill.optimal_fibre_length_m;
  const double omega = p.muscles[fcr].activation_omega_rad_s;
  const StretchReflexParams& reflex = p.mechanisms.stretch_reflex;
  auto f = [&](double t, const std::array<double, 3>& s) {
    const double qd = 30 * kDeg * 2.0 * M_PI * std::cos(2.0 * M_PI * t);
    return StretchReflexDerivative(reflex, omega, StretchReflexDrive(reflex, -d * qd / l_opt), s);
  };
  TrialRequest request = Request(2.0, {}, {});
  request.integrator.tolerance = 1e-8;
  const auto truth = RunTrial(UpperLimbModel(p), request).truth;
  std::array<double, 3> x{0.0, 0.0, 0.0};
  const double h = 1e-4;
  int active = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const double t_end = truth.time[i];
    for (double t = i == 0 ? 0.0 : truth.time[i - 1]; t < t_end - 0.5 * h; t += h) {
      x = test_util::Rk4Step(f, t, x, h);
    }
    EXPECT_NEAR(truth.Column("a.FCR")[i], x[1], 1e-6) << "t = " << t_end;
    EXPECT_EQ(truth.Column("a.EDC")[i], 0.0);
    active += x[1] > 0.01;
  }
  EXPECT_GT(active, 100);  // the reflex is on for most of the 2 s
}

TEST(TrialRunner, StictionHoldsAJointThatCoulombFrictionAloneLetsSlide) {
  ModelParams p = LockedRig();
  auto& plane = p.coordinates[kShoulderElvPlane];
  plane.mode = CoordinateMode::kFree;
  plane.passive.stiffness_nm_per_rad = 0.0;
  plane.passive.coulomb_friction_nm = 0.2;
  p.coordinates[kShoulderElevation].initial_rad = 90 * kDeg;          // horizontal-plane rotation
  const TrialRequest r = Request(2.0, {0.0}, {{0, 0, 0, 0, 80, 0}});  // anterior deltoid
  const auto slide = RunTrial(UpperLimbModel(p), r).truth.Column("q.shoulder_elv_plane");
  plane.passive.static_friction_nm = 5.0;
  const auto stick = RunTrial(UpperLimbModel(p), r).truth.Column("q.shoulder_elv_plane");
  const double moved_slide = std::abs(slide.back() - slide.front());
  const double moved_stick = std::abs(stick.back() - stick.front());
  EXPECT_GT(moved_slide, 0.05);
  EXPECT_LT(moved_stick, 0.2 * moved_slide);
}

TEST(TrialRunner, BaselineOffsetRemovedFromTheRestPeriod) {
  ModelParams p = LockedRig();
  p.gravity_m_s2 = {0, -9.81, 0};  // gravity loads the held elbow: a torque offset
  const UpperLimbModel model(p);
  TrialRequest r = Request(4.0, {2.0}, {{0, 0, 200, 0, 0, 0}});
  r.sensors.torques.baseline_window_s = 1.5;
  const TrialResult res = RunTrial(model, r);
  const auto& meas = res.measured.Column("tau.elbow_flexion");
  const auto& truth = res.truth.Column("tau.elbow_flexion");
  EXPECT_GT(std::abs(truth[0]), 0.5);                       // the raw offset is there
  EXPECT_NEAR(meas[0], 0.0, 1e-9);                          // rest: offset removed
  EXPECT_NEAR(meas.back(), truth.back() - truth[0], 1e-9);  // contraction kept
}

TEST(TrialRunner, SensorDriftDropoutsAndOutliers) {
  ModelParams p = LockedRig();
  p.coordinates[kWristFlexion].mode = CoordinateMode::kFree;
  const UpperLimbModel model(p);
  TrialRequest r = Request(200.0, {}, {});
  r.sensors.torques.coordinates.clear();
  r.sensors.angles.coordinates = {kWristFlexion};
  r.sensors.angles.rate_hz = 100.0;
  r.sensors.angles.offset_drift_per_s = 0.001;
  r.sensors.truth_rate_hz = 100.0;
  const TrialResult clean = RunTrial(model, r);
  const auto& truth = clean.truth.Column("q.wrist_flexion");
  const auto& meas = clean.measured.Column("q.wrist_flexion");
  for (std::size_t i = 0; i < meas.size(); i += 997) {
    EXPECT_NEAR(meas[i] - truth[i], 0.001 * clean.measured.time[i], 1e-12);
  }
  r.sensors.angles.offset_drift_per_s = 0.0;
  r.sensors.angles.dropout_probability = 0.2;
  r.sensors.angles.dropout_mean_samples = 5.0;
  r.sensors.angles.outlier_probability = 0.05;
  r.sensors.angles.outlier_std = 0.5;
  const TrialResult dirty = RunTrial(model, r);
  const auto& m = dirty.measured.Column("q.wrist_flexion");
  int lost = 0, bursts = 0, outliers = 0, kept = 0;
  for (std::size_t i = 0; i < m.size(); ++i) {
    if (std::isnan(m[i])) {
      ++lost;
      bursts += i == 0 || !std::isnan(m[i - 1]);
    } else {
      ++kept;
      outliers += std::abs(m[i] - truth[i]) > 0.05;
    }
  }
  const auto n = static_cast<double>(m.size());
  EXPECT_NEAR(lost / n, 0.2, 0.03);
  EXPECT_NEAR(static_cast<double>(lost) / bursts, 5.0, 1.0);
  // P(outlier) · P(|N(0, 0.5²)| > 0.05) = 0.05 · 0.920
  EXPECT_NEAR(static_cast<double>(outliers) / kept, 0.05 * 0.920, 0.01);
  // Same seed, same artefacts.
  const TrialResult again = RunTrial(model, r);
  for (std::size_t i = 0; i < m.size(); ++i) {
    EXPECT_EQ(std::isnan(m[i]), std::isnan(again.measured.Column("q.wrist_flexion")[i]));
  }
}

}  // namespace
}  // namespace fesim::sim
