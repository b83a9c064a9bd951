#include "sim/integrator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <stdexcept>
#include <string>

#include "muscles/activation.h"
#include "sim/default_model.h"

namespace fesim::sim {
namespace {

constexpr double kAgreementTol = 1e-6;  // rad, issue 2
constexpr double kActivationTol = 1e-6;

std::vector<double> Times(double duration, double dt) {
  std::vector<double> t;
  for (double x = 0.0; x <= duration + 1e-12; x += dt) t.push_back(x);
  return t;
}

TEST(Integrator, CvodesAndSimbodyAgreeOnFiveSecondTrial) {
  const UpperLimbModel model(DefaultModelParams());
  StimulationSchedule stim;
  stim.times = {0.0, 1.0, 2.5, 4.0};
  stim.values = {{0, 0, 0, 0, 0, 0},
                 {180, 60, 150, 0, 100, 50},
                 {40, 220, 0, 160, 30, 120},
                 {0, 0, 0, 0, 0, 0}};
  const auto times = Times(5.0, 0.05);
  std::vector<std::vector<double>> a, b;
  IntegratorParams cv{IntegratorParams::Method::kCvodes, 1e-9};
  IntegratorParams rk{IntegratorParams::Method::kSimbodyRkMerson, 1e-9};
  SimTK::State s1 = model.MakeInitialState();
  IntegrateTrial(model, cv, stim, times, &s1,
                 [&](const SimTK::State& s) { a.push_back(model.GetQs(s)); });
  SimTK::State s2 = model.MakeInitialState();
  IntegrateTrial(model, rk, stim, times, &s2,
                 [&](const SimTK::State& s) { b.push_back(model.GetQs(s)); });
  ASSERT_EQ(a.size(), b.size());
  double worst = 0.0, moved = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    for (int i = 0; i < kNumCoordinates; ++i) {
      worst = std::max(worst, std::abs(a[k][i] - b[k][i]));
      moved = std::max(moved, std::abs(a[k][i] - a[0][i]));
    }
  }
  EXPECT_GT(moved, 0.1);
  EXPECT_LT(worst, kAgreementTol);
  std::printf("CVODES vs Simbody RKM: max |dq| = %.3g rad over 5 s (largest excursion %.3g rad)\n",
              worst, moved);
}

TEST(Integrator, VariablesObserverSeesTheSameBitsAsTheStateObserver) {
  // Report times on the breakpoints (1.0, 2.5 s) and between them, closer together than the
  // steps; the observer reads q, u and the muscles from CVODES' vector instead of the state.
  // Also on the default model with its hand rig locked (components left out of CVODES).
  for (const bool locked : {false, true}) {
    ModelParams p = DefaultModelParams();
    if (locked) {
      for (int c = 0; c < kWristFlexion; ++c) p.coordinates[c].mode = CoordinateMode::kLocked;
    }
    const UpperLimbModel model(p);
    StimulationSchedule stim;
    stim.times = {0.0, 1.0, 2.5};
    stim.values = {{0, 0, 0, 0, 0, 0}, {180, 60, 150, 0, 100, 50}, {40, 220, 0, 160, 30, 120}};
    const auto times = Times(3.0, 0.01);
    const IntegratorParams cv{IntegratorParams::Method::kCvodes, 1e-4};
    std::vector<std::vector<double>> from_state, from_y;
    SimTK::State s1 = model.MakeInitialState();
    IntegrateTrial(
        model, cv, stim, times, &s1,
        [&](const SimTK::State& s) {
          std::vector<double> row = model.GetQs(s);
          for (double x : model.GetUs(s)) row.push_back(x);
          for (double x : model.ComputeMuscles(s).force_n) row.push_back(x);
          row.push_back(s.getTime());
          from_state.push_back(row);
        },
        SimTK::Stage::Instance);
    SimTK::State s2 = model.MakeInitialState();
    IntegrateTrialVariables(model, cv, stim, times, &s2, [&](double t, const double* y) {
      std::vector<double> row = model.GetQs(s2, y);
      for (double x : model.GetUs(s2, y)) row.push_back(x);
      for (double x : model.ComputeMuscles(s2, y).force_n) row.push_back(x);
      row.push_back(t);
      from_y.push_back(row);
    });
    ASSERT_EQ(from_y.size(), times.size());
    ASSERT_EQ(from_state.size(), times.size());
    for (std::size_t k = 0; k < times.size(); ++k) {
      for (std::size_t i = 0; i < from_y[k].size(); ++i) {
        ASSERT_EQ(from_y[k][i], from_state[k][i])
            << "locked " << locked << " row " << k << " value " << i;
      }
    }
    // Observing positions and speeds only (no activations computed): the same q and u.
    SimTK::State s3 = model.MakeInitialState();
    std::size_t row = 0;
    IntegrateTrialVariables(
        model, cv, stim, times, &s3,
        [&](double, const double* y) {
          const std::vector<double> q = model.GetQs(s3, y), u = model.GetUs(s3, y);
          for (int i = 0; i < kNumCoordinates; ++i) {
            ASSERT_EQ(q[i], from_state[row][i]) << "row " << row;
            ASSERT_EQ(u[i], from_state[row][kNumCoordinates + i]) << "row " << row;
          }
          ++row;
        },
        VariablesObserved::kPositionsAndSpeeds);
    EXPECT_EQ(row, times.size());
    // Both states end at the last report's solution.
    EXPECT_EQ(s2.getTime(), s1.getTime());
    for (int k = 0; k < s1.getNY(); ++k) EXPECT_EQ(s2.getY()[k], s1.getY()[k]) << "Y index " << k;
  }
}

TEST(Integrator, LockedActivationFollowsAnalyticStepResponse) {
  // With every coordinate locked the activation of each muscle is exactly eq. (6)'s step
  // response to w = H_IRC(A u): checks the z-state wiring, the schedule and the breakpoints.
  ModelParams p = DefaultModelParams();
  for (auto& c : p.coordinates) c.mode = CoordinateMode::kLocked;
  const UpperLimbModel model(p);
  StimulationSchedule stim;
  stim.times = {0.3};
  stim.values = {{0, 0, 200, 0, 0, 0}};
  const int bic = 8;
  ASSERT_EQ(p.muscles[bic].name, "BIC");
  const double w = muscles::Recruitment(p.muscles[bic].recruitment, 200.0);
  SimTK::State s = model.MakeInitialState();
  IntegrateTrial(model, {IntegratorParams::Method::kCvodes, 1e-10}, stim, Times(2.0, 0.1), &s,
                 [&](const SimTK::State& st) {
                   const double expected =
                       muscles::ActivationStepResponse(p.muscles[bic].activation_omega_rad_s, w,
                                                       st.getTime() - 0.3)
                           .a;
                   EXPECT_NEAR(model.ComputeMuscles(st).activation[bic], expected, kActivationTol);
                 });
}

TEST(Integrator, LockedActivationFallsAtItsDeactivationRatioInBothIntegrators) {
  // Biceps stimulated from 0.3 s and released at 1.0 s with Ω on falling recruitment × 0.4
  // (muscles::IntervalOmega): from 1.0 s a(t) is eq. (6)'s free response at 0.4 Ω from the step
  // response's state at 1.0 s — in CVODES' closed form and in Simbody's RKM, which integrates ż.
  ModelParams p = DefaultModelParams();
  for (auto& c : p.coordinates) c.mode = CoordinateMode::kLocked;
  constexpr double kRatio = 0.4;
  for (auto& m : p.muscles) m.deactivation_ratio = kRatio;
  const UpperLimbModel model(p);
  StimulationSchedule stim;
  stim.times = {0.3, 1.0};
  stim.values = {{0, 0, 200, 0, 0, 0}, {0, 0, 0, 0, 0, 0}};
  const int bic = 8;
  ASSERT_EQ(p.muscles[bic].name, "BIC");
  const double omega = p.muscles[bic].activation_omega_rad_s;
  const double w = muscles::Recruitment(p.muscles[bic].recruitment, 200.0);
  const auto expected = [&](double t) {
    if (t <= 1.0) return muscles::ActivationStepResponse(omega, w, t - 0.3).a;
    const auto at_release = muscles::ActivationStepResponse(omega, w, 0.7);
    return muscles::ActivationFreeResponse(kRatio * omega, 0.0, at_release, t - 1.0).a;
  };
  for (const auto method :
       {IntegratorParams::Method::kCvodes, IntegratorParams::Method::kSimbodyRkMerson}) {
    SimTK::State s = model.MakeInitialState();
    double falling_gap = 0.0;  // largest a(t) above the symmetric free response
    IntegrateTrial(model, {method, 1e-10}, stim, Times(2.5, 0.1), &s, [&](const SimTK::State& st) {
      const double t = st.getTime();
      const double a = model.ComputeMuscles(st).activation[bic];
      EXPECT_NEAR(a, expected(t), kActivationTol) << "t = " << t;
      if (t > 1.0) {
        const auto at_release = muscles::ActivationStepResponse(omega, w, 0.7);
        falling_gap = std::max(
            falling_gap, a - muscles::ActivationFreeResponse(omega, 0.0, at_release, t - 1.0).a);
      }
    });
    EXPECT_GT(falling_gap, 0.1 * w);  // the slower decay is visible
  }
}

TEST(Integrator, LockedCoordinatesLeftOutOfCvodesStillAgreeWithSimbody) {
  // Hand rig: shoulder, elbow and pro/supination locked. CVODES advances only the free q, u (its
  // tolerance scaled to keep the same error norm); Simbody's RKM integrates the whole state. The
  // free joints must agree to the issue-2 tolerance and the locked ones stay exactly put.
  ModelParams p = DefaultModelParams();
  for (int c : {kShoulderElvPlane, kShoulderElevation, kShoulderRotation, kElbowFlexion, kProSup}) {
    p.coordinates[c].mode = CoordinateMode::kLocked;
  }
  const UpperLimbModel model(p);
  SimTK::State s0 = model.MakeInitialState();
  EXPECT_EQ(model.LockedYIndices(s0).size(), 10u);
  StimulationSchedule stim;
  stim.times = {0.0, 0.5, 2.0};
  stim.values = {{0, 0, 0, 0, 0, 0}, {200, 80, 0, 0, 0, 0}, {60, 250, 0, 0, 0, 0}};
  const auto times = Times(3.0, 0.05);
  std::vector<std::vector<double>> a, b;
  SimTK::State s1 = s0;
  IntegrateTrial(model, {IntegratorParams::Method::kCvodes, 1e-9}, stim, times, &s1,
                 [&](const SimTK::State& s) { a.push_back(model.GetQs(s)); });
  SimTK::State s2 = s0;
  IntegrateTrial(model, {IntegratorParams::Method::kSimbodyRkMerson, 1e-9}, stim, times, &s2,
                 [&](const SimTK::State& s) { b.push_back(model.GetQs(s)); });
  ASSERT_EQ(a.size(), b.size());
  double worst = 0.0, moved = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    for (int i = 0; i < kNumCoordinates; ++i) {
      if (p.coordinates[i].mode == CoordinateMode::kLocked) {
        EXPECT_EQ(a[k][i], p.coordinates[i].initial_rad);
        continue;
      }
      worst = std::max(worst, std::abs(a[k][i] - b[k][i]));
      moved = std::max(moved, std::abs(a[k][i] - a[0][i]));
    }
  }
  EXPECT_GT(moved, 0.1);
  EXPECT_LT(worst, kAgreementTol);
  std::printf("hand rig, CVODES (free q, u only) vs Simbody RKM: max |dq| = %.3g rad\n", worst);
}

/// Index of the muscle called `name` in p.
int MuscleNamed(const ModelParams& p, const std::string& name) {
  for (std::size_t j = 0; j < p.muscles.size(); ++j) {
    if (p.muscles[j].name == name) return static_cast<int>(j);
  }
  throw std::invalid_argument("no muscle " + name);
}

TEST(Integrator, WeldedLockedCoordinatesIntegrateTheSameTrajectoryAndSensitivities) {
  // The fits' models weld the hand rig's locked coordinates (ModelBuildOptions::weld_locked):
  // CVODES must see the same error norm (the welds count as the locked q and u they replace), so
  // the two models take about the same steps and their angles and sensitivities agree to the
  // tolerance. Not to the step: the step sequence follows round-off (a 1e-15 rad change of the
  // initial wrist angle moves 817 steps at tolerance 1e-6 to 759–799), and the two models'
  // right-hand sides differ by round-off. Without the weld count the welded model takes 6 % more
  // steps.
  ModelParams base = DefaultModelParams();
  for (int c : {kShoulderElvPlane, kShoulderElevation, kShoulderRotation, kElbowFlexion, kProSup}) {
    base.coordinates[c].mode = CoordinateMode::kLocked;
  }
  ParameterPerturbation k_wrist{base, 0.0, 1.0}, mass_hand{base, 0.0, 1.0};
  double& k = k_wrist.params.coordinates[kWristFlexion].passive.stiffness_nm_per_rad;
  k_wrist.scale = std::abs(k);
  k_wrist.step = 1e-7 * k_wrist.scale;
  k += k_wrist.step;
  mass_hand.scale = base.segments[kHand].mass_kg;
  mass_hand.step = 1e-7 * mass_hand.scale;
  mass_hand.params.segments[kHand].mass_kg += mass_hand.step;
  StimulationSchedule stim;
  stim.times = {0.0, 0.4, 1.2};
  stim.values = {{0, 0, 0, 0, 0, 0}, {180, 60, 0, 0, 0, 0}, {70, 220, 0, 0, 0, 0}};
  const auto times = Times(2.0, 0.05);
  const IntegratorParams integrator{IntegratorParams::Method::kCvodes, 1e-10};
  std::vector<std::vector<double>> q[2], sens[2];
  IntegrationStats stats[2];
  for (int w = 0; w < 2; ++w) {
    const UpperLimbModel model(base, ModelBuildOptions{w == 1});
    SimTK::State s = model.MakeInitialState();
    stats[w] = IntegrateTrialSensitivities(
        model, integrator, stim, times, {k_wrist, mass_hand}, &s,
        [&](double, const double* y, const std::vector<double>& dq) {
          q[w].push_back(model.GetQs(s, y));
          sens[w].push_back(dq);
        },
        1);  // ∂f/∂y at every step: no reuse error that
             // follows the step sequence
  }
  std::printf("steps locked %ld, welded %ld\n", stats[0].steps, stats[1].steps);
  EXPECT_NEAR(static_cast<double>(stats[1].steps), static_cast<double>(stats[0].steps),
              0.03 * static_cast<double>(stats[0].steps));
  ASSERT_EQ(q[0].size(), times.size());
  ASSERT_EQ(q[1].size(), times.size());
  double largest = 0.0, worst = 0.0, largest_s = 0.0, worst_s = 0.0;
  for (std::size_t i = 0; i < times.size(); ++i) {
    for (int c = 0; c < kNumCoordinates; ++c) {
      largest = std::max(largest, std::abs(q[0][i][c] - q[0][0][c]));
      worst = std::max(worst, std::abs(q[1][i][c] - q[0][i][c]));
    }
    for (std::size_t j = 0; j < sens[0][i].size(); ++j) {
      largest_s = std::max(largest_s, std::abs(sens[0][i][j]));
      worst_s = std::max(worst_s, std::abs(sens[1][i][j] - sens[0][i][j]));
    }
  }
  EXPECT_GT(largest, 0.1);  // the wrist and fingers really move
  std::printf("max |dq| %.3g rad, max |d sensitivity| %.3g of %.3g\n", worst, worst_s, largest_s);
  EXPECT_LT(worst, 1e-9);
  EXPECT_LT(worst_s, 3e-5 * largest_s);
}

/// A parameter of a sensitivity test: its name, where it lives in the model and the relative
/// step of its central differences (larger for a parameter whose outputs move so little that
/// the integration's error, ≈ 1e-8 rad at tolerance 1e-10, would dominate a 1e-4 step's
/// difference).
struct ParameterAt {
  std::string name;
  std::function<double&(ModelParams&)> at;
  double difference_step = 1e-4;
};

/// Muscle j's moment arm at the wrist.
double& WristArm(ModelParams& m, int j) {
  for (auto& cr : m.muscles[j].path.crossings) {
    if (cr.joint == kWristFlexion) return cr.arm.d_m;
  }
  throw std::invalid_argument("no wrist crossing");
}

/// The hand rig of the sensitivity tests: shoulder, elbow and pro/supination locked.
ModelParams SensitivityHandRig() {
  ModelParams base = DefaultModelParams();
  for (int c : {kShoulderElvPlane, kShoulderElevation, kShoulderRotation, kElbowFlexion, kProSup}) {
    base.coordinates[c].mode = CoordinateMode::kLocked;
  }
  return base;
}

/// Both array channels stepped: channel 1 falls at 1.2 s, channel 2 at 2.0 s.
StimulationSchedule SensitivitySteps() {
  StimulationSchedule stim;
  stim.times = {0.0, 0.4, 1.2, 2.0};
  stim.values = {
      {0, 0, 0, 0, 0, 0}, {180, 60, 0, 0, 0, 0}, {70, 220, 0, 0, 0, 0}, {120, 120, 0, 0, 0, 0}};
  return stim;
}

/// `base` with each parameter moved by 1e-7 of its value (the sensitivity integration's steps).
std::vector<ParameterPerturbation> Perturbations(const ModelParams& base,
                                                 const std::vector<ParameterAt>& parameters) {
  std::vector<ParameterPerturbation> perturbed;
  for (const ParameterAt& parameter : parameters) {
    ParameterPerturbation pp{base, 0.0, 1.0};
    double& v = parameter.at(pp.params);
    pp.scale = std::abs(v);
    pp.step = 1e-7 * std::abs(v);
    v += pp.step;
    perturbed.push_back(pp);
  }
  return perturbed;
}

/// Forward sensitivities of `base` (3 s of SensitivitySteps at tolerance 1e-10) against central
/// differences of whole simulations, per parameter: checks that each column is non-zero and
/// within 0.2 % of the largest |∂q/∂θ| with ∂f/∂y formed at every step (exact) and within 1 % with
/// its rigid-body part formed at every 16th (the default; the muscle and passive part at every
/// step). With the rigid-body part reused the error follows the step sequence, which round-off
/// moves: the array spread's column 0.08–0.56 % over tolerances 0.99–1.01 × 1e-10 with either
/// right-hand side (UpperLimbModel::CalcYDot or Simbody's), the tremor's 0.02–0.63 %, the hand
/// mass's 0.24–0.67 %; 1.2 % / 1.6 % when the whole ∂f/∂y is formed only at every 4th / 16th
/// step. Returns the integration statistics, exact and default.
std::pair<IntegrationStats, IntegrationStats> ExpectSensitivitiesMatchCentralDifferences(
    const ModelParams& base, const std::vector<ParameterAt>& parameters) {
  const StimulationSchedule stim = SensitivitySteps();
  const auto times = Times(3.0, 0.05);
  const IntegratorParams integrator{IntegratorParams::Method::kCvodes, 1e-10};
  const int np = static_cast<int>(parameters.size());
  const std::vector<ParameterPerturbation> perturbed = Perturbations(base, parameters);
  const UpperLimbModel model(base);
  std::vector<std::vector<double>> sens, sens16;  // [sample][c * np + k]
  SimTK::State s = model.MakeInitialState();
  const IntegrationStats stats = IntegrateTrialSensitivities(
      model, integrator, stim, times, perturbed, &s,
      [&](double, const double*, const std::vector<double>& dq) { sens.push_back(dq); }, 1);
  SimTK::State s16 = model.MakeInitialState();
  const IntegrationStats stats16 = IntegrateTrialSensitivities(
      model, integrator, stim, times, perturbed, &s16,
      [&](double, const double*, const std::vector<double>& dq) { sens16.push_back(dq); });
  EXPECT_EQ(sens.size(), times.size());
  EXPECT_EQ(sens16.size(), times.size());
  if (sens.size() != times.size() || sens16.size() != times.size()) return {stats, stats16};
  const auto simulate = [&](const ModelParams& m) {
    const UpperLimbModel limb(m);
    SimTK::State st = limb.MakeInitialState();
    std::vector<std::vector<double>> q;
    IntegrateTrial(limb, integrator, stim, times, &st,
                   [&](const SimTK::State& x) { q.push_back(limb.GetQs(x)); });
    return q;
  };
  for (int k = 0; k < np; ++k) {
    ModelParams plus = base, minus = base;
    const double h = parameters[k].difference_step * std::abs(parameters[k].at(plus));
    parameters[k].at(plus) += h;
    parameters[k].at(minus) -= h;
    const auto qp = simulate(plus), qm = simulate(minus);
    double largest = 0.0, worst = 0.0, worst16 = 0.0;
    for (std::size_t i = 0; i < times.size(); ++i) {
      for (int c = 0; c < kNumCoordinates; ++c) {
        const double fd = (qp[i][c] - qm[i][c]) / (2.0 * h);
        const double an = sens[i][static_cast<std::size_t>(c) * np + k];
        if (base.coordinates[c].mode == CoordinateMode::kLocked) {
          EXPECT_EQ(an, 0.0);
          continue;
        }
        largest = std::max(largest, std::abs(fd));
        worst = std::max(worst, std::abs(an - fd));
        worst16 = std::max(worst16, std::abs(sens16[i][static_cast<std::size_t>(c) * np + k] - fd));
      }
    }
    std::printf(
        "%-13s max |dq/dtheta| %.4g, max |sensitivity - central difference| %.3g (every "
        "step), %.3g (default: rigid-body part every 16th)\n",
        parameters[k].name.c_str(), largest, worst, worst16);
    EXPECT_GT(largest, 0.0) << parameters[k].name;
    EXPECT_LT(worst, 2e-3 * largest) << parameters[k].name;
    EXPECT_LT(worst16, 1e-2 * largest) << parameters[k].name;
  }
  std::printf("steps %ld / %ld, right-hand sides %ld / %ld (every step / default)\n", stats.steps,
              stats16.steps, stats.rhs_evaluations, stats16.rhs_evaluations);
  return {stats, stats16};
}

/// Person parameters of the sensitivity tests: the wrist's passive stiffness, ECRL's recruitment
/// β, wrist moment arm and activation rate Ω, FCR's F_max and the hand's mass.
std::vector<ParameterAt> PersonParametersAt(const ModelParams& base) {
  const int ecrl = MuscleNamed(base, "ECRL"), fcr = MuscleNamed(base, "FCR");
  return {
      {"k.wrist",
       [](ModelParams& m) -> double& {
         return m.coordinates[kWristFlexion].passive.stiffness_nm_per_rad;
       }},
      {"beta.ECRL",
       [ecrl](ModelParams& m) -> double& { return m.muscles[ecrl].recruitment.beta_per_us; }},
      {"d.ECRL.wrist", [ecrl](ModelParams& m) -> double& { return WristArm(m, ecrl); }},
      {"Fmax.FCR",
       [fcr](ModelParams& m) -> double& { return m.muscles[fcr].hill.max_isometric_force_n; }},
      {"omega.ECRL",
       [ecrl](ModelParams& m) -> double& { return m.muscles[ecrl].activation_omega_rad_s; }},
      {"mass.hand", [](ModelParams& m) -> double& { return m.segments[kHand].mass_kg; }},
  };
}

TEST(Integrator, ForwardSensitivitiesMatchCentralDifferencesOfWholeSimulations) {
  // Parameters of every kind the sensitivity right-hand side re-evaluates: passive stiffness
  // (direct torque), recruitment β and γ and the array's current spread (through w and the
  // closed-form activation sensitivities across breakpoints), a wrist moment arm (path, direct
  // torque), F_max (Hill), an activation rate Ω and its deactivation ratio (eq. 6's free
  // response), a wrist tremor's amplitude, frequency and phase (TremorTorque, a function of t) and
  // the hand's mass (a second Simbody system).
  ModelParams base = SensitivityHandRig();
  base.mechanisms.tremor.enabled = true;
  base.mechanisms.tremor.coordinate = kWristFlexion;
  base.mechanisms.tremor.amplitude_nm = 0.05;
  base.mechanisms.tremor.frequency_hz = 6.0;
  base.mechanisms.tremor.phase_rad = 0.3;
  // Muscles deactivate at 0.6 Ω (muscles::IntervalOmega).
  for (auto& m : base.muscles) m.deactivation_ratio = 0.6;
  const int ecrl = MuscleNamed(base, "ECRL"), fcr = MuscleNamed(base, "FCR");
  std::vector<ParameterAt> parameters = PersonParametersAt(base);
  const std::vector<ParameterAt> more = {
      {"gamma.FCR", [&](ModelParams& m) -> double& { return m.muscles[fcr].recruitment.gamma; }},
      {"array.spread", [](ModelParams& m) -> double& { return m.array.spread_m; }},
      {"deact.ECRL", [&](ModelParams& m) -> double& { return m.muscles[ecrl].deactivation_ratio; }},
      {"tremor.A", [](ModelParams& m) -> double& { return m.mechanisms.tremor.amplitude_nm; }},
      {"tremor.f", [](ModelParams& m) -> double& { return m.mechanisms.tremor.frequency_hz; }},
      {"tremor.phase", [](ModelParams& m) -> double& { return m.mechanisms.tremor.phase_rad; }},
  };
  parameters.insert(parameters.end(), more.begin(), more.end());
  const auto [exact, reused] = ExpectSensitivitiesMatchCentralDifferences(base, parameters);
  EXPECT_LT(reused.rhs_evaluations, exact.rhs_evaluations / 2);
}

TEST(Integrator, SensitivitiesPerStepEqualCvodesInterpolationAtTheReports) {
  // IntegratorParams::sensitivities_per_step reports the sensitivities from one Taylor
  // polynomial per CVODES step instead of CVodeGetSens at each report: on the sensitivity rig at
  // the fits' coarse tolerance (several 100 Hz reports per step) the same values to round-off,
  // the same steps and zeros for the locked coordinates.
  const ModelParams base = SensitivityHandRig();
  const std::vector<ParameterAt> parameters = PersonParametersAt(base);
  const std::vector<ParameterPerturbation> perturbed = Perturbations(base, parameters);
  const UpperLimbModel model(base);
  const auto times = Times(3.0, 0.01);
  const auto run = [&](bool per_step, IntegrationStats* stats) {
    IntegratorParams integrator{IntegratorParams::Method::kCvodes, 1e-2};
    integrator.sensitivities_per_step = per_step;
    SimTK::State s = model.MakeInitialState();
    std::vector<std::vector<double>> sens;
    *stats = IntegrateTrialSensitivities(
        model, integrator, SensitivitySteps(), times, perturbed, &s,
        [&](double, const double*, const std::vector<double>& dq) { sens.push_back(dq); });
    return sens;
  };
  IntegrationStats cvodes_stats, step_stats;
  const auto cvodes = run(false, &cvodes_stats), per_step = run(true, &step_stats);
  ASSERT_EQ(cvodes.size(), times.size());
  ASSERT_EQ(per_step.size(), times.size());
  EXPECT_EQ(cvodes_stats.steps, step_stats.steps);
  EXPECT_LT(step_stats.steps, static_cast<long>(times.size()) / 2);
  double largest = 0.0, worst = 0.0;
  for (std::size_t i = 0; i < times.size(); ++i) {
    for (std::size_t j = 0; j < cvodes[i].size(); ++j) {
      largest = std::max(largest, std::abs(cvodes[i][j]));
      worst = std::max(worst, std::abs(per_step[i][j] - cvodes[i][j]));
      if (cvodes[i][j] == 0.0) EXPECT_EQ(per_step[i][j], 0.0);
    }
  }
  EXPECT_GT(largest, 0.0);
  EXPECT_LT(worst, 1e-12 * largest);
}

TEST(Integrator, SensitivitiesWithFatigueAndPotentiationMatchCentralDifferences) {
  // Fatigue and potentiation fast enough to change the force within the 3 s trial (fitness down
  // to ≈ 0.5, potentiation up to ≈ 0.5 on the stimulated muscles): their states are CVODES
  // components whose columns of ∂f/∂y are formed exactly (integrator.h). The person's parameters
  // (through the activations, the torques and the masses) and the mechanisms' own rates and gain.
  ModelParams base = SensitivityHandRig();
  base.mechanisms.fatigue = {true, 2.0, 20.0, 0.3};
  base.mechanisms.potentiation = {true, 0.8, 1.0, 10.0};
  std::vector<ParameterAt> parameters = PersonParametersAt(base);
  const std::vector<ParameterAt> mechanisms = {
      {"fatigue.T_fat",
       [](ModelParams& m) -> double& { return m.mechanisms.fatigue.fatigue_time_s; }},
      {"fatigue.T_rec",
       [](ModelParams& m) -> double& { return m.mechanisms.fatigue.recovery_time_s; }, 1e-3},
      {"fatigue.min", [](ModelParams& m) -> double& { return m.mechanisms.fatigue.min_fitness; }},
      {"pot.gain", [](ModelParams& m) -> double& { return m.mechanisms.potentiation.gain; }},
      {"pot.rise", [](ModelParams& m) -> double& { return m.mechanisms.potentiation.rise_time_s; }},
      {"pot.decay",
       [](ModelParams& m) -> double& { return m.mechanisms.potentiation.decay_time_s; }, 1e-3},
  };
  parameters.insert(parameters.end(), mechanisms.begin(), mechanisms.end());
  ExpectSensitivitiesMatchCentralDifferences(base, parameters);
}

TEST(Integrator, SensitivitiesRejectStatesTheyCannotDifferentiate) {
  ModelParams p = DefaultModelParams();
  p.mechanisms.stretch_reflex.gain = 0.1;
  p.mechanisms.stretch_reflex.muscles = {"FCR"};
  const UpperLimbModel model(p);
  SimTK::State s = model.MakeInitialState();
  StimulationSchedule stim;
  EXPECT_THROW(
      IntegrateTrialSensitivities(model, {}, stim, {0.0, 0.1}, {}, &s,
                                  [](double, const double*, const std::vector<double>&) {}),
      std::invalid_argument);
  // A perturbed model that switches fatigue on has another state layout.
  const UpperLimbModel plain(DefaultModelParams());
  ParameterPerturbation fatigued{DefaultModelParams(), 1e-6, 1.0};
  fatigued.params.mechanisms.fatigue.enabled = true;
  SimTK::State s1 = plain.MakeInitialState();
  EXPECT_THROW(
      IntegrateTrialSensitivities(plain, {}, stim, {0.0, 0.1}, {fatigued}, &s1,
                                  [](double, const double*, const std::vector<double>&) {}),
      std::invalid_argument);
  SimTK::State s2 = plain.MakeInitialState();
  EXPECT_THROW(IntegrateTrialSensitivities(
                   plain, {IntegratorParams::Method::kSimbodyRkMerson, 1e-6}, stim, {0.0, 0.1}, {},
                   &s2, [](double, const double*, const std::vector<double>&) {}),
               std::invalid_argument);
}

/// Default model whose elbow stretch reflex has a NaN gain: its torque is exactly 0 while
/// |q̇_elbow| ≤ threshold and NaN as soon as the elbow moves faster (mechanisms.cc, ReflexTorque).
ModelParams ElbowReflexFault(double gain, double threshold_rad_s) {
  ModelParams p = DefaultModelParams();
  p.coordinates[kElbowFlexion].passive.reflex_gain_nms_per_rad = gain;
  p.coordinates[kElbowFlexion].passive.reflex_threshold_rad_s = threshold_rad_s;
  return p;
}

TEST(Integrator, SimbodyFailureNamesTimeCoordinateAndHint) {
  // Planted fault: unstimulated, the flexed elbow (1.41 rad) extends under gravity and its speed
  // crosses the reflex threshold at t_c (found on the healthy model, reflex off; ≈ 0.08 s). With a
  // NaN reflex gain the RKM integration must fail there, and its message must say when, where
  // and what to check.
  constexpr double kThreshold = 2.0;  // rad/s
  const StimulationSchedule stim;
  const auto times = Times(0.5, 0.001);
  const IntegratorParams rk{IntegratorParams::Method::kSimbodyRkMerson, 1e-6};

  const UpperLimbModel healthy(ElbowReflexFault(0.0, kThreshold));
  double t_cross = -1.0;
  SimTK::State s0 = healthy.MakeInitialState();
  IntegrateTrial(healthy, rk, stim, times, &s0, [&](const SimTK::State& s) {
    if (t_cross < 0.0 && std::abs(healthy.GetUs(s)[kElbowFlexion]) > kThreshold) {
      t_cross = s.getTime();
    }
  });
  ASSERT_GT(t_cross, 0.02) << "the elbow must reach the threshold speed after a while";

  const UpperLimbModel faulty(ElbowReflexFault(std::nan(""), kThreshold));
  SimTK::State s1 = faulty.MakeInitialState();
  std::string message;
  try {
    IntegrateTrial(faulty, rk, stim, times, &s1, [](const SimTK::State&) {});
  } catch (const std::runtime_error& e) {
    message = e.what();
  }
  std::printf("t_cross = %.4f s; message: %s\n", t_cross, message.c_str());
  ASSERT_FALSE(message.empty()) << "a NaN torque must stop the integration";
  EXPECT_EQ(message.find('\n'), std::string::npos) << "one line";
  const std::string prefix = "integration failed at t = ";
  ASSERT_EQ(message.rfind(prefix, 0), 0u) << message;
  const double t_fail = std::stod(message.substr(prefix.size()));
  // The crossing lies in (t_cross − 1 ms, t_cross]; the last accepted RKM step ends before it,
  // at most one step earlier (steps of a few ms at this tolerance).
  EXPECT_GT(t_fail, t_cross - 0.01);
  EXPECT_LT(t_fail, t_cross + 0.001);
  EXPECT_NE(message.find("Simbody RKM"), std::string::npos) << message;
  bool names_coordinate = false;
  for (const auto& name : CoordinateNames()) {
    if (message.find("coordinate " + name + " at ") != std::string::npos) names_coordinate = true;
  }
  EXPECT_TRUE(names_coordinate) << message;
  EXPECT_NE(message.find("Hint: check stimulation, stiffness and range limits"), std::string::npos)
      << message;
}

TEST(Integrator, CvodesFailureCarriesItsMessageAndPrintsNothing) {
  // The planted fault under CVODES, with threshold 0 so that the torque is NaN from the first
  // step on (at 2 rad/s CVODES crawls along the threshold for minutes before it gives up): the
  // failure is an exception whose one line carries CVODES' own reason; nothing goes to stderr (a
  // fit's rejected trial point is not the user's error, and `fesim benchmark` on the independent
  // cohort printed dozens of such blocks).
  const UpperLimbModel faulty(ElbowReflexFault(std::nan(""), 0.0));
  SimTK::State s = faulty.MakeInitialState();
  std::string message;
  ::testing::internal::CaptureStderr();
  try {
    IntegrateTrial(faulty, IntegratorParams{IntegratorParams::Method::kCvodes, 1e-6}, {},
                   Times(0.5, 0.001), &s, [](const SimTK::State&) {});
  } catch (const std::runtime_error& e) {
    message = e.what();
  }
  const std::string err = ::testing::internal::GetCapturedStderr();
  ASSERT_FALSE(message.empty()) << "a NaN torque must stop the integration";
  EXPECT_EQ(message.rfind("integration failed at t = ", 0), 0u) << message;
  EXPECT_NE(message.find("CVODES CV_"), std::string::npos) << message;
  EXPECT_NE(message.find("At t = "), std::string::npos) << "CVODES' own reason: " << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  EXPECT_EQ(err, "");
}

TEST(Integrator, SpeedTimeScaleLoosensOnlyTheSpeedsAndKeepsTheAnglesAccurate) {
  // Hand rig (arm locked) with a 0.12 N·m, 5.35 Hz wrist tremor, the case that made diagnosis
  // fits slow: at tolerance 1e-5 the steps are limited by the speeds' error. With their absolute
  // tolerance at tolerance / t_c (t_c = 0.1 s, IntegratorParams::speed_time_scale_s) CVODES takes
  // fewer steps, and the angles stay within a few tolerances' worth of a 1e-10 solution.
  ModelParams p = DefaultModelParams();
  for (int c : {kShoulderElvPlane, kShoulderElevation, kShoulderRotation, kElbowFlexion, kProSup}) {
    p.coordinates[c].mode = CoordinateMode::kLocked;
  }
  p.mechanisms.tremor.enabled = true;
  p.mechanisms.tremor.coordinate = kWristFlexion;
  p.mechanisms.tremor.amplitude_nm = 0.12;
  p.mechanisms.tremor.frequency_hz = 5.35;
  const UpperLimbModel model(p);
  StimulationSchedule stim;
  stim.times = {0.0, 1.0, 4.0, 7.0};
  stim.values = {
      {0, 0, 0, 0, 0, 0}, {200, 0, 0, 0, 0, 0}, {0, 150, 0, 0, 0, 0}, {0, 0, 0, 0, 0, 0}};
  const auto times = Times(10.0, 0.025);
  const auto run = [&](double tolerance, double time_scale, std::vector<std::vector<double>>* q) {
    IntegratorParams ip{IntegratorParams::Method::kCvodes, tolerance};
    ip.speed_time_scale_s = time_scale;
    SimTK::State s = model.MakeInitialState();
    return IntegrateTrial(model, ip, stim, times, &s,
                          [&](const SimTK::State& st) { q->push_back(model.GetQs(st)); });
  };
  std::vector<std::vector<double>> ref, plain, scaled;
  run(1e-10, 0.0, &ref);
  const IntegrationStats plain_stats = run(1e-5, 0.0, &plain);
  const IntegrationStats scaled_stats = run(1e-5, 0.1, &scaled);
  const auto worst = [&](const std::vector<std::vector<double>>& q) {
    double w = 0.0;
    for (std::size_t k = 0; k < ref.size(); ++k) {
      for (int i = 0; i < kNumCoordinates; ++i) w = std::max(w, std::abs(q[k][i] - ref[k][i]));
    }
    return w;
  };
  const double e_plain = worst(plain), e_scaled = worst(scaled);
  std::printf(
      "tremor, tolerance 1e-5: %ld steps, max |dq| %.3g rad; t_c 0.1 s: %ld steps, %.3g rad\n",
      plain_stats.steps, e_plain, scaled_stats.steps, e_scaled);
  EXPECT_LT(static_cast<double>(scaled_stats.steps), 0.8 * static_cast<double>(plain_stats.steps));
  EXPECT_LT(e_scaled, 3e-4);  // 30 tolerances; the 1° sensor noise is 0.0175 rad
  EXPECT_LT(e_scaled, 5.0 * e_plain);
  IntegratorParams bad{IntegratorParams::Method::kCvodes, 1e-5};
  bad.speed_time_scale_s = -0.1;
  SimTK::State s = model.MakeInitialState();
  EXPECT_THROW(IntegrateTrial(model, bad, stim, times, &s, [](const SimTK::State&) {}),
               std::invalid_argument);
}

TEST(Integrator, StepBudgetEndsASimulationThatNeedsMoreAndChangesNothingOtherwise) {
  const UpperLimbModel model(DefaultModelParams());
  StimulationSchedule stim;
  stim.times = {0.0, 1.0};
  stim.values = {{0, 0, 0, 0, 0, 0}, {180, 60, 150, 0, 100, 50}};
  const auto times = Times(3.0, 0.05);
  const auto run = [&](long max_steps, std::vector<std::vector<double>>* q) {
    IntegratorParams ip{IntegratorParams::Method::kCvodes, 1e-6};
    ip.max_steps = max_steps;
    SimTK::State s = model.MakeInitialState();
    return IntegrateTrial(model, ip, stim, times, &s,
                          [&](const SimTK::State& st) { q->push_back(model.GetQs(st)); });
  };
  std::vector<std::vector<double>> free_run, budgeted, cut;
  const IntegrationStats stats = run(0, &free_run);
  run(stats.steps, &budgeted);  // exactly enough: the same steps, the same numbers
  EXPECT_EQ(budgeted, free_run);
  try {
    run(stats.steps / 2, &cut);
    FAIL() << "half the steps it needs did not stop the simulation";
  } catch (const std::runtime_error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("the step budget (IntegratorParams::max_steps = " +
                           std::to_string(stats.steps / 2) + ") is used up"),
              std::string::npos)
        << message;
  }
  EXPECT_LT(cut.size(), free_run.size());
}

TEST(Integrator, ScheduleHoldsValues) {
  StimulationSchedule s;
  s.times = {1.0, 2.0};
  s.values = {{10}, {20}};
  EXPECT_EQ(s.At(0.5, 1)[0], 0.0);
  EXPECT_EQ(s.At(1.0, 1)[0], 10.0);
  EXPECT_EQ(s.At(1.99, 1)[0], 10.0);
  EXPECT_EQ(s.At(7.0, 1)[0], 20.0);
}

}  // namespace
}  // namespace fesim::sim
