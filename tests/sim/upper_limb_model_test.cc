#include "sim/upper_limb_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>

#include "muscles/hill.h"
#include "sim/chain_dynamics.h"
#include "sim/default_model.h"
#include "sim/integrator.h"
#include "tendons/tendon_network.h"

namespace fesim::sim {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;
constexpr double kEnergyDriftTol = 1e-5;  // relative to the peak kinetic energy
constexpr double kTorqueTol = 1e-8;       // N·m
constexpr double kPowerTol = 1e-4;        // relative to the peak joint power
constexpr double kEquilibriumTol = 2e-4;  // rad

/// Runs the model from its initial state and calls `f` at each report time.
void RunModel(const UpperLimbModel& model, double duration, double dt, double tol,
              const StimulationSchedule& stim, const Observer& f,
              IntegratorParams::Method method = IntegratorParams::Method::kCvodes) {
  IntegratorParams ip;
  ip.method = method;
  ip.tolerance = tol;
  std::vector<double> times;
  for (double t = 0.0; t <= duration + 1e-12; t += dt) times.push_back(t);
  SimTK::State s = model.MakeInitialState();
  IntegrateTrial(model, ip, stim, times, &s, f);
}

TEST(UpperLimbModel, EnergyConservedWithoutMusclesDampingOrSupport) {
  ModelParams p = DefaultModelParams();
  p.muscles.clear();
  p.channels.clear();
  p.array.motor_points.clear();
  for (auto& c : p.coordinates) c.passive.damping_nms_per_rad = 0.0;
  // Start the arm and wrist displaced so they swing. The undamped index-finger joints (natural
  // frequencies up to ~40 Hz at ~10 g) are locked: they conserve energy too, but resolving their
  // oscillation for 10 s costs minutes of integration without testing anything new.
  for (int i = kShoulderElvPlane; i <= kWristDeviation; ++i) {
    p.coordinates[i].initial_rad = p.coordinates[i].passive.rest_angle_rad + 0.2;
  }
  for (int i : {kMcpFlexion, kPipFlexion, kDipFlexion}) {
    p.coordinates[i].mode = CoordinateMode::kLocked;
    p.coordinates[i].initial_rad = p.coordinates[i].passive.rest_angle_rad;
  }
  p.coordinates[kShoulderElevation].initial_rad = 60 * kDeg;
  const UpperLimbModel model(p);
  double e0 = NAN, max_drift = 0.0, max_ke = 0.0;
  RunModel(
      model, 10.0, 0.01, 1e-8, {},
      [&](const SimTK::State& s) {
        const double e = model.MechanicalEnergy(s);
        if (std::isnan(e0)) e0 = e;
        max_drift = std::max(max_drift, std::abs(e - e0));
        max_ke = std::max(max_ke, model.system().calcKineticEnergy(s));
      },
      IntegratorParams::Method::kCvodesAdams);
  EXPECT_GT(max_ke, 0.1);  // it really moved
  EXPECT_LT(max_drift / max_ke, kEnergyDriftTol) << "drift " << max_drift << " J of " << e0;
  std::printf("energy drift %.3g J = %.3g of peak kinetic energy, %.3g of total energy\n",
              max_drift, max_drift / max_ke, max_drift / std::abs(e0));
}

TEST(UpperLimbModel, PowerBalanceOfMuscles) {
  // −Σ f · dl_MT/dt (lengths differentiated numerically along the motion) equals
  // Σ τ · q̇ with τ the generalised forces Simbody actually received from the muscles.
  const ModelParams p = DefaultModelParams();
  const UpperLimbModel model(p);
  StimulationSchedule stim;
  stim.times = {0.0, 0.5};
  stim.values = {{150, 0, 200, 0, 120, 0}, {60, 220, 0, 180, 0, 150}};
  double max_power = 0.0, max_err = 0.0;
  RunModel(model, 1.5, 0.05, 1e-8, stim, [&](const SimTK::State& s) {
    const auto q = model.GetQs(s);
    const auto qd = model.GetUs(s);
    const MuscleSnapshot m = model.ComputeMuscles(s);
    const auto tau = model.MuscleMobilityForces(s);
    constexpr double h = 1e-6;
    std::vector<double> qp(q), qm(q);
    for (int i = 0; i < kNumCoordinates; ++i) {
      qp[i] += h * qd[i];
      qm[i] -= h * qd[i];
    }
    double muscle_power = 0.0, joint_power = 0.0;
    for (std::size_t j = 0; j < p.muscles.size(); ++j) {
      const double dldt = (tendons::MusculotendonLength(p.muscles[j].path, qp) -
                           tendons::MusculotendonLength(p.muscles[j].path, qm)) /
                          (2 * h);
      muscle_power -= m.force_n[j] * dldt;
    }
    for (int i = 0; i < kNumCoordinates; ++i) joint_power += tau[i] * qd[i];
    max_power = std::max(max_power, std::abs(joint_power));
    max_err = std::max(max_err, std::abs(muscle_power - joint_power));
  });
  EXPECT_GT(max_power, 0.01);
  EXPECT_LT(max_err / max_power, kPowerTol);
}

TEST(UpperLimbModel, LockedElbowSensorReadsTendonTorque) {
  // Isometric rig ([Le 2010]): every coordinate locked, no gravity, elbow at its passive rest
  // angle. The torque sensor must read Σ_j R_ej f_j.
  ModelParams p = DefaultModelParams();
  p.gravity_m_s2 = {0, 0, 0};
  for (auto& c : p.coordinates) {
    c.mode = CoordinateMode::kLocked;
    c.initial_rad = c.passive.rest_angle_rad;
  }
  const UpperLimbModel model(p);
  StimulationSchedule stim;
  stim.times = {0.0};
  stim.values = {{0, 0, 250, 120, 0, 0}};
  std::vector<tendons::MusclePath> paths;
  for (const auto& m : p.muscles) paths.push_back(m.path);
  int checked = 0;
  RunModel(model, 2.0, 0.25, 1e-8, stim, [&](const SimTK::State& s) {
    const MuscleSnapshot m = model.ComputeMuscles(s);
    const auto r = tendons::MomentArmMatrix(paths, model.GetQs(s));
    double expected = 0.0;
    for (std::size_t j = 0; j < paths.size(); ++j)
      expected += r[kElbowFlexion * paths.size() + j] * m.force_n[j];
    const double measured = model.SensorTorques(s)[kElbowFlexion];
    EXPECT_NEAR(measured, expected, kTorqueTol) << "t = " << s.getTime();
    if (s.getTime() > 1.0) {
      EXPECT_GT(std::abs(expected), 1.0);  // biceps and triceps really pull
      ++checked;
    }
  });
  EXPECT_GT(checked, 0);
}

TEST(UpperLimbModel, StaticEquilibriumOnSupportMatchesEnergyMinimum) {
  // Sagittal arm with free shoulder elevation and elbow, held by an elastic band on the
  // humerus and weight compensation on the forearm. Dynamics (forces, damping) must settle where
  // the total potential energy is stationary — found independently by Newton's method on V(q).
  ModelParams p = DefaultModelParams();
  p.muscles.clear();
  p.channels.clear();
  p.array.motor_points.clear();
  for (auto& c : p.coordinates) {
    c.mode = CoordinateMode::kLocked;
    c.initial_rad = c.passive.rest_angle_rad;
  }
  p.coordinates[kShoulderElvPlane].initial_rad = 90 * kDeg;
  for (int i : {kShoulderElevation, kElbowFlexion}) {
    p.coordinates[i].mode = CoordinateMode::kFree;
    p.coordinates[i].passive.damping_nms_per_rad = 2.0;
  }
  p.coordinates[kShoulderElevation].initial_rad = 40 * kDeg;
  p.coordinates[kElbowFlexion].initial_rad = 70 * kDeg;
  BandParams band;
  band.segment = kHumerus;
  band.cuff_in_segment_m = {0.0, -0.2, 0.0};
  band.anchor_in_ground_m = {0.3, 2.0, p.shoulder_in_ground_m[2]};
  band.stiffness_n_per_m = 120.0;
  band.slack_length_m = 0.3;
  p.bands = {band};
  p.weight_compensation = {{kForearm, {0.0, -0.12, 0.0}, 8.0}};
  const UpperLimbModel model(p);

  std::vector<double> settled;
  RunModel(model, 30.0, 30.0, 1e-9, {}, [&](const SimTK::State& s) { settled = model.GetQs(s); });

  SimTK::State s = model.MakeInitialState();
  const auto energy = [&](double e, double k) {
    model.CoordinateBody(kShoulderElevation).setOneQ(s, 0, e);
    model.CoordinateBody(kElbowFlexion).setOneQ(s, 0, k);
    model.CoordinateBody(kShoulderElevation).setOneU(s, 0, 0.0);
    model.CoordinateBody(kElbowFlexion).setOneU(s, 0, 0.0);
    model.system().realize(s, SimTK::Stage::Velocity);
    return model.MechanicalEnergy(s);
  };
  double x[2] = {40 * kDeg, 70 * kDeg};
  constexpr double h = 1e-4;
  for (int it = 0; it < 30; ++it) {
    double g[2], H[2][2];
    const double f0 = energy(x[0], x[1]);
    for (int i = 0; i < 2; ++i) {
      double xp[2] = {x[0], x[1]}, xm[2] = {x[0], x[1]};
      xp[i] += h;
      xm[i] -= h;
      g[i] = (energy(xp[0], xp[1]) - energy(xm[0], xm[1])) / (2 * h);
      H[i][i] = (energy(xp[0], xp[1]) - 2 * f0 + energy(xm[0], xm[1])) / (h * h);
    }
    H[0][1] = H[1][0] = (energy(x[0] + h, x[1] + h) - energy(x[0] + h, x[1] - h) -
                         energy(x[0] - h, x[1] + h) + energy(x[0] - h, x[1] - h)) /
                        (4 * h * h);
    const double det = H[0][0] * H[1][1] - H[0][1] * H[1][0];
    x[0] -= (H[1][1] * g[0] - H[0][1] * g[1]) / det;
    x[1] -= (H[0][0] * g[1] - H[1][0] * g[0]) / det;
  }
  EXPECT_NEAR(settled[kShoulderElevation], x[0], kEquilibriumTol);
  EXPECT_NEAR(settled[kElbowFlexion], x[1], kEquilibriumTol);
  // The support matters: without it the equilibrium is elsewhere.
  EXPECT_GT(std::abs(x[0] - p.coordinates[kShoulderElevation].passive.rest_angle_rad), 0.05);
}

TEST(UpperLimbModel, PrescribedCoordinateFollowsItsTrajectory) {
  ModelParams p = DefaultModelParams();
  auto& elbow = p.coordinates[kElbowFlexion];
  elbow.mode = CoordinateMode::kPrescribed;
  elbow.prescription = {1.2, 0.3, 0.5, 0.0};
  elbow.initial_rad = 1.2;
  const UpperLimbModel model(p);
  RunModel(model, 2.0, 0.1, 1e-7, {}, [&](const SimTK::State& s) {
    const double t = s.getTime();
    EXPECT_NEAR(model.GetQ(s, kElbowFlexion), 1.2 + 0.3 * std::sin(2 * SimTK::Pi * 0.5 * t), 1e-9);
    EXPECT_TRUE(std::isfinite(model.SensorTorques(s)[kElbowFlexion]));
  });
}

/// The hand rig's locks (shoulder, elbow, pro/supination) plus DIP, and an elastic band on the
/// forearm (locked: its force acts on a locked or welded body).
void LockHandRigAndDipWithABandOnTheForearm(ModelParams* p) {
  for (int c : {kShoulderElvPlane, kShoulderElevation, kShoulderRotation, kElbowFlexion, kProSup,
                kDipFlexion}) {
    p->coordinates[c].mode = CoordinateMode::kLocked;
  }
  BandParams band;
  band.segment = kForearm;
  band.cuff_in_segment_m = {0.0, -0.1, 0.0};
  band.anchor_in_ground_m = {0.0, 0.5, 0.0};
  band.stiffness_n_per_m = 200.0;
  p->bands.push_back(band);
}

TEST(UpperLimbModel, WeldedLockedCoordinatesGiveTheSameDynamics) {
  // Hand rig (shoulder, elbow, pro/supination locked) with DIP locked too: the first five are
  // folded into the ground (ModelBuildOptions::weld_locked), DIP stays a weld below a mobile
  // body with its mass. A band on the (welded) forearm acts on the ground or the locked body
  // alike. At one state with every free coordinate moving and muscles active, the free
  // coordinates' accelerations and mass matrix must equal the locked model's to round-off.
  constexpr double kAccelerationTol = 1e-9;  // rad/s², relative to the largest
  ModelParams p = DefaultModelParams();
  LockHandRigAndDipWithABandOnTheForearm(&p);
  p.coordinates[kDipFlexion].initial_rad = 0.3;
  const UpperLimbModel locked(p), welded(p, ModelBuildOptions{true});
  EXPECT_EQ(locked.NumWelded(), 0);
  EXPECT_EQ(welded.NumWelded(), 6);
  EXPECT_EQ(welded.QIndex(kElbowFlexion), -1);
  EXPECT_GE(welded.QIndex(kWristFlexion), 0);
  const std::vector<int> free = {kWristFlexion, kWristDeviation, kMcpFlexion, kPipFlexion};
  SimTK::State sl = locked.MakeInitialState(), sw = welded.MakeInitialState();
  EXPECT_EQ(sw.getNQ(), static_cast<int>(free.size()));
  for (SimTK::State* s : {&sl, &sw}) {
    const UpperLimbModel& m = s == &sl ? locked : welded;
    for (std::size_t k = 0; k < free.size(); ++k) {
      m.CoordinateBody(free[k]).setOneQ(*s, 0, 0.2 - 0.15 * static_cast<double>(k));
      m.CoordinateBody(free[k]).setOneU(*s, 0, 1.0 + 0.5 * static_cast<double>(k));
    }
    m.SetStimulation(*s, {150, 90, 0, 0, 0, 0});
    const int a0 = m.ActivationYIndex(*s);
    for (int j = 0; j < m.num_muscles(); ++j) s->updY()[a0 + 2 * j] = 0.3 + 0.02 * j;
    m.system().realize(*s, SimTK::Stage::Acceleration);
  }
  EXPECT_DOUBLE_EQ(welded.GetQ(sw, kDipFlexion), 0.3);
  EXPECT_DOUBLE_EQ(welded.GetQ(sw, kElbowFlexion), p.coordinates[kElbowFlexion].initial_rad);
  EXPECT_EQ(welded.GetQs(sw), locked.GetQs(sl));
  double largest = 0.0;
  for (int c : free) largest = std::max(largest, std::abs(sl.getUDot()[locked.UIndex(c)]));
  EXPECT_GT(largest, 1.0);
  for (int c : free) {
    EXPECT_NEAR(sw.getUDot()[welded.UIndex(c)], sl.getUDot()[locked.UIndex(c)],
                kAccelerationTol * largest)
        << CoordinateNames()[c];
  }
  SimTK::Matrix ml, mw;
  locked.matter().calcM(sl, ml);
  welded.matter().calcM(sw, mw);
  for (int r : free) {
    for (int c : free) {
      EXPECT_NEAR(mw(welded.UIndex(r), welded.UIndex(c)), ml(locked.UIndex(r), locked.UIndex(c)),
                  1e-12);
    }
  }
  EXPECT_THROW(welded.SensorTorques(sw), std::logic_error);
}

/// Simbody's Ẏ after realize(Acceleration) against UpperLimbModel::CalcYDot at one state of
/// `model` with every mobile coordinate displaced and moving, muscles stimulated and active.
void ExpectFastDerivativesMatchSimbody(const UpperLimbModel& model, double t, bool closed_form) {
  constexpr double kRelativeTol = 1e-10;  // of the largest |Ẏ| component
  ASSERT_TRUE(model.HasFastDerivatives());
  SimTK::State s = model.MakeInitialState();
  for (int c = 0; c < kNumCoordinates; ++c) {
    if (model.Welded(c) || model.params().coordinates[c].mode != CoordinateMode::kFree) continue;
    const auto& passive = model.params().coordinates[c].passive;
    const double mid = 0.5 * (passive.min_angle_rad + passive.max_angle_rad);
    const double half = 0.5 * (passive.max_angle_rad - passive.min_angle_rad);
    model.CoordinateBody(c).setOneQ(s, 0, mid + half * 0.6 * std::sin(1.7 * c + 0.3));
    model.CoordinateBody(c).setOneU(s, 0, 1.5 * std::cos(2.3 * c));
  }
  model.SetStimulation(s, {150, 90, 60, 200, 120, 30});
  model.SetActivationsInClosedForm(s, closed_form);
  const int a0 = model.ActivationYIndex(s);
  for (int j = 0; j < model.num_muscles(); ++j) {
    s.updY()[a0 + 2 * j] = 0.2 + 0.04 * j;
    s.updY()[a0 + 2 * j + 1] = 0.5 - 0.1 * j;
  }
  for (int k = a0 + 2 * model.num_muscles(); k < s.getNY(); ++k) s.updY()[k] = 0.4 + 0.01 * k;
  s.setTime(t);
  model.system().realize(s, SimTK::Stage::Acceleration);
  const SimTK::Vector& expected = s.getYDot();
  SimTK::State fresh = s;  // the fast path needs no realised stage past Model
  fresh.invalidateAllCacheAtOrAbove(SimTK::Stage::Time);
  RhsWorkspace ws;
  std::vector<double> ydot(s.getNY(), NAN);
  model.CalcYDot(fresh, &ws, ydot.data());
  const int activations_end = closed_form ? a0 + 2 * model.num_muscles() : a0;
  double largest = 0.0;
  for (int k = 0; k < s.getNY(); ++k) largest = std::max(largest, std::abs(expected[k]));
  ASSERT_GT(largest, 1.0);
  for (int k = 0; k < s.getNY(); ++k) {
    if (k >= a0 && k < activations_end) continue;  // stale in closed form: nothing reads them
    EXPECT_NEAR(ydot[k], expected[k], kRelativeTol * largest) << "Y index " << k;
  }
  // The same bits from (t, Y) given beside a state whose variables and time differ (it gives
  // only the stimulation and the closed-form flag), the scratch reused.
  SimTK::State other = fresh;
  for (int k = 0; k < other.getNY(); ++k) other.updY()[k] = 0.3 * other.getY()[k] + 0.01;
  other.setTime(t + 1.0);
  std::vector<double> ydot_from_y(s.getNY(), NAN);
  model.CalcYDot(other, t, &fresh.getY()[0], &ws, ydot_from_y.data());
  for (int k = 0; k < s.getNY(); ++k) {
    if (k >= a0 && k < activations_end) continue;
    EXPECT_EQ(ydot_from_y[k], ydot[k]) << "Y index " << k;
  }
}

TEST(UpperLimbModel, FastDerivativesMatchSimbody) {
  // The default model (ten free coordinates, the support's bands and cuffs), then with fatigue,
  // potentiation and a tremor (extra z), with a stretch reflex of three muscles (more z), then the
  // hand rig locked by Simbody's lock and welded (ModelBuildOptions::weld_locked) with a band on
  // the welded forearm and a cuff on the hand.
  ModelParams p = DefaultModelParams();
  ExpectFastDerivativesMatchSimbody(UpperLimbModel(p), 0.0, false);
  ExpectFastDerivativesMatchSimbody(UpperLimbModel(p), 0.0, true);
  p.mechanisms.fatigue.enabled = true;
  p.mechanisms.potentiation.enabled = true;
  p.mechanisms.tremor.enabled = true;
  p.mechanisms.tremor.amplitude_nm = 0.3;
  ExpectFastDerivativesMatchSimbody(UpperLimbModel(p), 0.37, true);
  p.mechanisms.stretch_reflex.gain = 0.4;
  p.mechanisms.stretch_reflex.muscles = {"FCR", "FDS", "BIC"};
  ExpectFastDerivativesMatchSimbody(UpperLimbModel(p), 0.37, true);
  ExpectFastDerivativesMatchSimbody(UpperLimbModel(p), 0.37, false);
  LockHandRigAndDipWithABandOnTheForearm(&p);
  p.weight_compensation.push_back({kHand, {0.01, -0.03, 0.0}, 2.0});
  ExpectFastDerivativesMatchSimbody(UpperLimbModel(p), 0.37, true);
  ExpectFastDerivativesMatchSimbody(UpperLimbModel(p, ModelBuildOptions{true}), 0.37, true);
  // Prescribed coordinates have no fast path.
  p.coordinates[kElbowFlexion].mode = CoordinateMode::kPrescribed;
  const UpperLimbModel prescribed(p);
  EXPECT_FALSE(prescribed.HasFastDerivatives());
  RhsWorkspace ws;
  std::vector<double> ydot(prescribed.MakeInitialState().getNY());
  EXPECT_THROW(prescribed.CalcYDot(prescribed.MakeInitialState(), &ws, ydot.data()),
               std::logic_error);
}

/// `*s` stimulated on all six channels with closed-form activations, and a Y of it with every q
/// and u moved from the initial state and muscle j's activation 0.3 + 0.03 j.
std::vector<double> StimulatedStateAwayFromRest(const UpperLimbModel& model, SimTK::State* s) {
  model.SetStimulation(*s, {150, 90, 60, 200, 120, 30});
  model.SetActivationsInClosedForm(*s, true);
  std::vector<double> y(s->getY().getContiguousScalarData(),
                        s->getY().getContiguousScalarData() + s->getNY());
  for (int k = 0; k < s->getNQ() + s->getNU(); ++k) y[k] += 0.1 * std::sin(1.7 * k + 0.3);
  const int a0 = model.ActivationYIndex(*s);
  for (int j = 0; j < model.num_muscles(); ++j) y[a0 + 2 * j] = 0.3 + 0.03 * j;
  return y;
}

TEST(UpperLimbModel, RightHandSideSkipsOnlyTheMusclesOnWelds) {
  // On the welded hand rig the right-hand side skips the muscles that cross welds only (BIC, BRA,
  // BRD, TRI, DELT1, DELT3: their force 0 in its scratch): every coordinate with a mobility gets
  // the muscle torque of the full evaluation (ComputeMuscles) bit for bit, and every muscle that
  // crosses one the same force.
  ModelParams p = DefaultModelParams();
  LockHandRigAndDipWithABandOnTheForearm(&p);
  const UpperLimbModel model(p, ModelBuildOptions{true});
  SimTK::State s = model.MakeInitialState();
  const std::vector<double> y = StimulatedStateAwayFromRest(model, &s);
  RhsWorkspace ws;
  std::vector<double> ydot(y.size());
  model.CalcYDot(s, 0.2, y.data(), &ws, ydot.data());
  const MuscleSnapshot full = model.ComputeMuscles(s, y.data());
  int mobile = 0;
  for (int c = 0; c < kNumCoordinates; ++c) {
    if (model.UIndex(c) < 0) continue;
    ++mobile;
    EXPECT_EQ(ws.muscles.joint_torque_nm[c], full.joint_torque_nm[c]) << "coordinate " << c;
  }
  EXPECT_EQ(mobile, 4);  // wrist flexion and deviation, MCP, PIP
  int skipped = 0;
  for (int j = 0; j < model.num_muscles(); ++j) {
    bool crosses_mobile = false;
    for (const auto& c : p.muscles[j].path.crossings) {
      crosses_mobile = crosses_mobile || model.UIndex(c.joint) >= 0;
    }
    if (crosses_mobile) {
      EXPECT_EQ(ws.muscles.force_n[j], full.force_n[j]) << p.muscles[j].name;
    } else {
      EXPECT_EQ(ws.muscles.force_n[j], 0.0) << p.muscles[j].name;
      skipped += full.force_n[j] != 0.0;
    }
  }
  EXPECT_EQ(skipped, 6);
}

TEST(UpperLimbModel, RightHandSideAtTheSamePositionsReusesThemBitwise) {
  // The speed columns of a difference-quotient Jacobian: the same Q, other U. The scratch keeps
  // the position terms of the last Q (RhsWorkspace); a call that reuses them gives the same bits
  // as one that computes them, and a new Q or another model computes them again.
  ModelParams p = DefaultModelParams();
  const UpperLimbModel model(p);
  p.segments[kHand].mass_kg *= 1.5;
  const UpperLimbModel heavier(p);
  SimTK::State s = model.MakeInitialState();
  const std::vector<double> y = StimulatedStateAwayFromRest(model, &s);
  const int a0 = model.ActivationYIndex(s);
  const auto fresh = [&](const UpperLimbModel& m, const std::vector<double>& at) {
    RhsWorkspace ws;
    std::vector<double> out(at.size(), NAN);
    m.CalcYDot(s, 0.2, at.data(), &ws, out.data());
    return out;
  };
  RhsWorkspace ws;
  std::vector<double> ydot(y.size());
  model.CalcYDot(s, 0.2, y.data(), &ws, ydot.data());
  const auto expect_same = [&](const std::vector<double>& a, const std::vector<double>& b,
                               const char* what) {
    for (std::size_t k = 0; k < a.size(); ++k) {
      if (static_cast<int>(k) >= a0 && static_cast<int>(k) < a0 + 2 * model.num_muscles()) continue;
      ASSERT_EQ(a[k], b[k]) << what << ", Y index " << k;
    }
  };
  std::vector<double> other_u = y;
  other_u[s.getNQ() + 3] += 1e-7;
  other_u[s.getNQ() + 8] -= 0.4;
  model.CalcYDot(s, 0.2, other_u.data(), &ws, ydot.data());
  expect_same(ydot, fresh(model, other_u), "other U, positions kept");
  std::vector<double> other_q = other_u;
  other_q[2] += 1e-9;
  model.CalcYDot(s, 0.2, other_q.data(), &ws, ydot.data());
  expect_same(ydot, fresh(model, other_q), "other Q");
  // ComputeMuscles on the same scratch at another Q overwrites the kept lengths and arms: the
  // next right-hand side at the kept Q computes them again.
  std::vector<double> elsewhere = other_q;
  elsewhere[9] += 0.3;
  model.ComputeMuscles(s, elsewhere.data(), &ws);
  model.CalcYDot(s, 0.2, other_q.data(), &ws, ydot.data());
  expect_same(ydot, fresh(model, other_q), "after ComputeMuscles elsewhere");
  heavier.CalcYDot(s, 0.2, other_q.data(), &ws, ydot.data());
  expect_same(ydot, fresh(heavier, other_q), "another model at the same Q");
  bool differs = false;
  const std::vector<double> light = fresh(model, other_q);
  for (int k = s.getNQ(); k < s.getNQ() + s.getNU(); ++k) differs = differs || ydot[k] != light[k];
  EXPECT_TRUE(differs) << "the heavier hand changes the accelerations";
}

TEST(UpperLimbModel, TorquePointGivesMuscleAndPassiveTorquesBits) {
  // Every coordinate's q and q̇ moved in turn, and a person with other passive joints: the kept
  // parts give MuscleAndPassiveTorques' values bit for bit, and the moves change the torques.
  const ModelParams p = DefaultModelParams();
  std::vector<tendons::MusclePath> paths;
  for (const auto& m : p.muscles) paths.push_back(m.path);
  std::vector<double> q(kNumCoordinates), qd(kNumCoordinates), a(p.muscles.size());
  for (int c = 0; c < kNumCoordinates; ++c) {
    q[c] = p.coordinates[c].initial_rad + 0.2 * std::sin(1.3 * c + 0.4);
    qd[c] = 0.7 * std::cos(0.9 * c);
  }
  for (std::size_t j = 0; j < a.size(); ++j) a[j] = 0.1 + 0.05 * static_cast<double>(j);
  const TorquePoint point(p, paths, q, qd, a);
  const auto same = [](const std::vector<double>& x, const std::vector<double>& y) {
    return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0;
  };
  EXPECT_TRUE(same(point.torques(), MuscleAndPassiveTorques(p, paths, q, qd, a)));
  for (int c = 0; c < kNumCoordinates; ++c) {
    for (bool speed : {false, true}) {
      std::vector<double> q1 = q, qd1 = qd;
      const double value = (speed ? qd : q)[c] + 1e-3;
      (speed ? qd1 : q1)[c] = value;
      const std::vector<double> moved = point.WithCoordinate(c, speed, value);  // a copy
      EXPECT_TRUE(same(moved, MuscleAndPassiveTorques(p, paths, q1, qd1, a)))
          << "coordinate " << c << (speed ? " speed" : " angle");
      EXPECT_FALSE(same(moved, point.torques())) << "coordinate " << c;
    }
  }
  ModelParams stiffer = p;
  for (auto& coordinate : stiffer.coordinates) {
    coordinate.passive.stiffness_nm_per_rad *= 1.7;
    coordinate.passive.damping_nms_per_rad += 0.01;
  }
  const std::vector<double> passive = point.WithPassiveOf(stiffer);
  EXPECT_TRUE(same(passive, MuscleAndPassiveTorques(stiffer, paths, q, qd, a)));
  EXPECT_FALSE(same(passive, point.torques()));
  // One joint's stiffness moved (as a fit's k of one joint): the others' passive torques kept.
  ModelParams one = p;
  one.coordinates[kElbowFlexion].passive.stiffness_nm_per_rad *= 1.3;
  const std::vector<double> one_moved = point.WithPassiveOf(one);
  EXPECT_TRUE(same(one_moved, MuscleAndPassiveTorques(one, paths, q, qd, a)));
  for (int c = 0; c < kNumCoordinates; ++c) {
    EXPECT_EQ(one_moved[c] != point.torques()[c], c == kElbowFlexion) << "coordinate " << c;
  }
  // Muscles moved (as a fit's wrist moment-arm scale, one muscle's Hill parameters, the
  // active-force gains of fatigue): the moved ones evaluated again, the others kept.
  ModelParams arms = p;
  std::vector<tendons::MusclePath> arm_paths = paths;
  for (auto& path : arm_paths) {
    for (auto& crossing : path.crossings) {
      if (crossing.joint == kWristFlexion) crossing.arm.d_m *= 1.2;
    }
  }
  for (std::size_t j = 0; j < arms.muscles.size(); ++j) arms.muscles[j].path = arm_paths[j];
  arms.muscles[3].hill.max_isometric_force_n *= 0.8;
  arms.coordinates[kWristFlexion].passive.stiffness_nm_per_rad *= 1.1;
  const std::vector<double> with_arms = point.WithMusclesOf(arms, arm_paths, {});
  EXPECT_TRUE(same(with_arms, MuscleAndPassiveTorques(arms, arm_paths, q, qd, a)));
  EXPECT_FALSE(same(with_arms, point.torques()));
  EXPECT_TRUE(same(point.WithMusclesOf(p, paths, {}), point.torques()));
  std::vector<double> gains(a.size(), 1.0);
  gains[5] = 0.7;
  EXPECT_TRUE(same(point.WithMusclesOf(p, paths, gains),
                   MuscleAndPassiveTorques(p, paths, q, qd, a, gains)));
  // Read at the hand rig's free coordinates only: the same bits there, the shoulder and elbow
  // muscles (crossing none of them) not evaluated.
  std::vector<char> read(kNumCoordinates, 0);
  for (int c : {kWristFlexion, kWristDeviation, kMcpFlexion, kPipFlexion}) read[c] = 1;
  const TorquePoint hand(p, paths, q, qd, a, gains, read);
  const TorquePoint all(p, paths, q, qd, a, gains);
  const auto same_where_read = [&](const std::vector<double>& x, const std::vector<double>& y,
                                   std::size_t stride) {
    bool ok = true;
    for (int c = 0; c < kNumCoordinates; ++c) {
      if (!read[c]) continue;
      ok = ok && std::memcmp(&x[c * stride], &y[c * stride], stride * sizeof(double)) == 0;
    }
    return ok;
  };
  EXPECT_TRUE(same_where_read(hand.torques(), all.torques(), 1));
  EXPECT_FALSE(same(hand.torques(), all.torques()));  // the elbow's muscles left out
  EXPECT_TRUE(same_where_read(hand.WithCoordinate(kMcpFlexion, false, q[kMcpFlexion] + 1e-3),
                              all.WithCoordinate(kMcpFlexion, false, q[kMcpFlexion] + 1e-3), 1));
  EXPECT_TRUE(same_where_read(hand.WithCoordinate(kWristFlexion, true, 0.3),
                              all.WithCoordinate(kWristFlexion, true, 0.3), 1));
  EXPECT_TRUE(same_where_read(hand.WithMusclesOf(arms, arm_paths, gains),
                              all.WithMusclesOf(arms, arm_paths, gains), 1));
  EXPECT_TRUE(same_where_read(hand.WithPassiveOf(stiffer), all.WithPassiveOf(stiffer), 1));
  for (bool gain : {false, true}) {
    EXPECT_TRUE(same_where_read(hand.PerMuscleInput(gain), all.PerMuscleInput(gain), a.size()));
  }
  EXPECT_THROW(TorquePoint(p, paths, q, qd, a, {}, {1, 0}), std::invalid_argument);
}

TEST(UpperLimbModel, TorquePerActivationAndGainAreTheirForwardDifferencesAndDerivatives) {
  // TorquePerActivation and TorquePerActiveGain (TorquePoint::PerMuscleInput, from the point's
  // kept arms, lengths, velocities and forces) give, bit for bit, R_cj (f_j(x + 1e-6) − f_j(x)) /
  // 1e-6 composed from the tendon and Hill functions, with and without active-force gains
  // (fatigue), at two postures; and the activation entries are the torques' derivatives (a
  // central difference of MuscleAndPassiveTorques).
  const ModelParams p = DefaultModelParams();
  std::vector<tendons::MusclePath> paths;
  for (const auto& m : p.muscles) paths.push_back(m.path);
  const auto same = [](const std::vector<double>& x, const std::vector<double>& y) {
    return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0;
  };
  const std::size_t nm = p.muscles.size();
  for (double shift : {0.0, 0.35}) {
    std::vector<double> q(kNumCoordinates), qd(kNumCoordinates), a(nm);
    for (int c = 0; c < kNumCoordinates; ++c) {
      q[c] = p.coordinates[c].initial_rad + 0.2 * std::sin(1.3 * c + 0.4) + shift;
      qd[c] = 0.7 * std::cos(0.9 * c + shift);
    }
    for (std::size_t j = 0; j < nm; ++j) a[j] = 0.1 + 0.05 * static_cast<double>(j);
    std::vector<double> gains(nm);
    for (std::size_t j = 0; j < nm; ++j) gains[j] = 0.6 + 0.03 * static_cast<double>(j);
    for (const std::vector<double>& g : {std::vector<double>{}, gains}) {
      for (bool per_gain : {false, true}) {
        std::vector<double> expected = tendons::MomentArmMatrix(paths, q);
        for (std::size_t j = 0; j < nm; ++j) {
          const auto& hill = p.muscles[j].hill;
          const auto fibre =
              muscles::FibreFromMusculotendon(hill, tendons::MusculotendonLength(paths[j], q),
                                              tendons::MusculotendonVelocity(paths[j], q, qd));
          const double gj = g.empty() ? 1.0 : g[j];
          const double df = (muscles::HillTendonForce(hill, a[j] + (per_gain ? 0.0 : 1e-6), fibre,
                                                      gj + (per_gain ? 1e-6 : 0.0)) -
                             muscles::HillTendonForce(hill, a[j], fibre, gj)) /
                            1e-6;
          for (int c = 0; c < kNumCoordinates; ++c) expected[c * nm + j] *= df;
        }
        const std::vector<double> got = per_gain ? TorquePerActiveGain(p, paths, q, qd, a, g)
                                                 : TorquePerActivation(p, paths, q, qd, a, g);
        EXPECT_TRUE(same(got, expected)) << "shift " << shift << " per gain " << per_gain;
      }
      const std::vector<double> per_a = TorquePerActivation(p, paths, q, qd, a, g);
      for (std::size_t j : {std::size_t{0}, nm / 2, nm - 1}) {
        std::vector<double> up = a, down = a;
        up[j] += 1e-5;
        down[j] -= 1e-5;
        const auto tu = MuscleAndPassiveTorques(p, paths, q, qd, up, g);
        const auto td = MuscleAndPassiveTorques(p, paths, q, qd, down, g);
        for (int c = 0; c < kNumCoordinates; ++c) {
          const double central = (tu[c] - td[c]) / 2e-5;
          EXPECT_NEAR(per_a[c * nm + j], central, 1e-3 * (std::abs(central) + 1e-3))
              << "muscle " << j << " coordinate " << c;
        }
      }
    }
  }
}

TEST(UpperLimbModel, StimulationIsClippedToPulseWidthLimits) {
  const UpperLimbModel model(DefaultModelParams());
  SimTK::State s = model.MakeInitialState();
  model.SetStimulation(s, {-10, 400, 100, 0, 0, 0});
  const auto u = model.GetStimulation(s);
  EXPECT_EQ(u[0], 0.0);
  EXPECT_EQ(u[1], 300.0);
  EXPECT_EQ(u[2], 100.0);
  EXPECT_THROW(model.SetStimulation(s, {1, 2}), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::sim
