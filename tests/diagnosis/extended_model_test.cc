#include "diagnosis/extended_model.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "diagnosis/diagnose.h"
#include "diagnosis/mechanisms/library.h"
#include "diagnosis/person.h"
#include "identification/fullmodel/full_model_fit.h"

namespace fesim::diagnosis {
namespace {

/// Integrator accuracy of these tests (CVODES relative/absolute tolerance).
FitOptions Accurate() {
  FitOptions o;
  o.tolerance = 1e-7;
  return o;
}

/// A 6 s hand-rig trial (wrist only) with an extensor step, noise-free, from `model`.
Trial StepTrial(const sim::ModelParams& model) {
  Trial t;
  for (int i = 0; i <= 300; ++i) t.time.push_back(i / 50.0);
  std::vector<double> ext(t.size()), zero(t.size(), 0.0);
  for (std::size_t i = 0; i < t.size(); ++i)
    ext[i] = (t.time[i] >= 1.0 && t.time[i] < 4.0) ? 200 : 0;
  t.AddColumn("u.ext", ext);
  t.AddColumn("q.wrist_flexion", zero);
  const Trial sim = identification::fullmodel::SimulateLike(model, t, 1e-7);
  t.MutableColumn("q.wrist_flexion") = sim.Column("q.wrist_flexion");
  return t;
}

DataView ViewOf(const Trial& t) {
  DataView v;
  v.trials = {t};
  v.use = {std::vector<char>(t.size(), 1)};
  v.outputs = {"q.wrist_flexion"};
  return v;
}

/// The hand rig's wrist, 30 % stiffer in the data than in the rig: a one-parameter fit case
/// (k_nominal the rig's stiffness, options at 1e-7 on two threads).
struct StiffWristCase {
  sim::ModelParams rig;
  double k_nominal = 0.0;
  DataView view;
  FitOptions options;
};
StiffWristCase StiffWrist() {
  StiffWristCase w;
  w.rig = identification::fullmodel::DefaultHandRig();
  w.k_nominal = w.rig.coordinates[sim::kWristFlexion].passive.stiffness_nm_per_rad;
  sim::ModelParams truth = w.rig;
  truth.coordinates[sim::kWristFlexion].passive.stiffness_nm_per_rad = 1.3 * w.k_nominal;
  w.view = ViewOf(StepTrial(truth));
  w.options.threads = 2;
  w.options.tolerance = 1e-7;
  return w;
}

ModelParameter Stiffness(double nominal) {
  ModelParameter p;
  p.name = "k.wrist_flexion";
  p.start = nominal;
  p.lower = 0.2 * nominal;
  p.upper = 5 * nominal;
  p.scale = nominal;
  p.set = [](double v, sim::ModelParams* m) {
    m->coordinates[sim::kWristFlexion].passive.stiffness_nm_per_rad = v;
  };
  return p;
}

TEST(ExtendedModel, DriftAddsValueTimesTimeAndInputScaleZeroSilencesTheInput) {
  const sim::ModelParams rig = identification::fullmodel::DefaultHandRig();
  const DataView v = ViewOf(StepTrial(rig));
  ModelParameter drift;
  drift.name = "drift";
  drift.target = ModelParameter::Target::kOutputDrift;
  drift.column = "q.wrist_flexion";
  ModelParameter scale;
  scale.name = "u_scale.ext";
  scale.target = ModelParameter::Target::kInputScale;
  scale.column = "u.ext";
  Eigen::VectorXd x(2);
  x << 0.01, 1.0;
  const auto with = Predict(rig, {drift, scale}, x, v, Accurate(), 1);
  x << 0.0, 1.0;
  const auto without = Predict(rig, {drift, scale}, x, v, Accurate(), 1);
  const auto& a = with[0].Column("q.wrist_flexion");
  const auto& b = without[0].Column("q.wrist_flexion");
  for (std::size_t i = 0; i < a.size(); i += 50)
    EXPECT_NEAR(a[i] - b[i], 0.01 * v.trials[0].time[i], 1e-12);
  x << 0.0, 0.0;
  const auto silent = Predict(rig, {drift, scale}, x, v, Accurate(), 1);
  DataView unstimulated = v;
  for (double& u : unstimulated.trials[0].MutableColumn("u.ext")) u = 0.0;
  const auto rest = Predict(rig, {}, Eigen::VectorXd(0), unstimulated, Accurate(), 1);
  const auto& s = silent[0].Column("q.wrist_flexion");
  const auto& r = rest[0].Column("q.wrist_flexion");
  for (std::size_t i = 0; i < s.size(); ++i) EXPECT_NEAR(s[i], r[i], 1e-9);
  EXPECT_GT(std::abs(b[200] - r[200]), 0.05);  // the step moves the wrist
  EXPECT_THROW(ApplyModelParameters(rig, {drift}, Eigen::VectorXd(2)), std::invalid_argument);
}

TEST(ExtendedModel, FitRecoversAStiffnessAndHeldParametersStay) {
  const StiffWristCase w = StiffWrist();
  const sim::ModelParams& rig = w.rig;
  const double k_nominal = w.k_nominal;
  const DataView& v = w.view;
  const FitOptions& o = w.options;
  const FitResult f =
      FitParameters(rig, {Stiffness(k_nominal)}, Eigen::VectorXd::Constant(1, k_nominal), v, o);
  constexpr double kRelTol = 0.01;
  EXPECT_NEAR(f.x(0), 1.3 * k_nominal, kRelTol * k_nominal);
  EXPECT_LT(f.cost, 1e-6);
  EXPECT_GT(f.simulations, 2);
  // Held: with first_free = 1 only the drift moves, the stiffness stays at its start.
  ModelParameter drift;
  drift.name = "drift";
  drift.target = ModelParameter::Target::kOutputDrift;
  drift.column = "q.wrist_flexion";
  drift.lower = -1;
  drift.upper = 1;
  drift.scale = 1e-3;
  Eigen::VectorXd x0(2);
  x0 << k_nominal, 0.0;
  const FitResult g = FitParameters(rig, {Stiffness(k_nominal), drift}, x0, v, o, 1);
  EXPECT_EQ(g.x(0), k_nominal);
  EXPECT_TRUE(std::isnan(g.ci95(0)));
  EXPECT_GT(g.cost, 10 * f.cost);  // a drift cannot stand in for the stiffness
}

// A log-prior scale factor is fitted in z = ln x (FitParameters): the optimum and its interval
// are properties of the cost, not of the coordinates — the interval of x by the delta method
// from that of z equals the one fitted in x.
TEST(ExtendedModel, AScaleFactorFittedInLogsHasTheOptimumAndIntervalOfTheFitInX) {
  const StiffWristCase w = StiffWrist();
  ModelParameter in_x = Stiffness(w.k_nominal);
  in_x.lower = 0.01 * w.k_nominal;
  in_x.upper = 100.0 * w.k_nominal;
  ModelParameter in_log = in_x;
  in_log.log_prior = true;  // FitOptions::prior_sigma 0: no prior rows, the coordinates only
  const Eigen::VectorXd x0 = Eigen::VectorXd::Constant(1, w.k_nominal);
  const FitResult a = FitParameters(w.rig, {in_x}, x0, w.view, w.options);
  const FitResult b = FitParameters(w.rig, {in_log}, x0, w.view, w.options);
  EXPECT_NEAR(b.x(0), 1.3 * w.k_nominal, 0.01 * w.k_nominal);
  EXPECT_NEAR(b.x(0), a.x(0), 1e-3 * a.x(0));
  // The data are noise-free: each interval scales with √cost of its own end point; per √cost
  // (the (JᵀJ)⁻¹ part) they agree.
  ASSERT_GT(a.ci95(0), 0.0);
  ASSERT_GT(a.cost, 0.0);
  EXPECT_NEAR(b.ci95(0) / std::sqrt(b.cost), a.ci95(0) / std::sqrt(a.cost),
              0.02 * a.ci95(0) / std::sqrt(a.cost));
}

// Bounds are judged in the fit's coordinates: a log-prior factor's range in ln x.
TEST(ExtendedModel, RangeBoundSideMeasuresAScaleFactorsRangeInLogs) {
  ModelParameter gamma = Stiffness(1.0);
  gamma.lower = 1e-3;
  gamma.upper = 1e4;
  EXPECT_EQ(RangeBoundSide(gamma, 3.0), -1);  // in x: within 1e-3 of the 1e4 range
  gamma.log_prior = true;
  EXPECT_EQ(RangeBoundSide(gamma, 3.0), 0);
  EXPECT_EQ(RangeBoundSide(gamma, 1.01e-3), -1);  // ln 1.01 < 1e-3 × ln 1e7
  EXPECT_EQ(RangeBoundSide(gamma, 1.03e-3), 0);
  EXPECT_EQ(RangeBoundSide(gamma, 0.99e4), 1);
  EXPECT_EQ(RangeBoundSide(gamma, 1e4), 1);
}

TEST(ExtendedModel, ParabolaVertexIsTheMinimumOfAQuadraticFromThreeSamples) {
  // c = 2 (f − 1.3)² + 5, sampled unevenly around its minimum: exact.
  const auto c = [](double f) { return 2.0 * (f - 1.3) * (f - 1.3) + 5.0; };
  EXPECT_NEAR(ParabolaVertex(1.0, c(1.0), 1.5, c(1.5), 2.5, c(2.5)), 1.3, 1e-12);
  EXPECT_NEAR(ParabolaVertex(0.2, c(0.2), 1.2, c(1.2), 1.4, c(1.4)), 1.3, 1e-12);
  // Not a quadratic (|f − 0.37|^1.5 + 1, the profile's shape is not known): inside the bracket
  // and nearer the minimum than the bracket's lowest sample.
  const auto d = [](double f) { return std::pow(std::abs(f - 0.37), 1.5) + 1.0; };
  const double v = ParabolaVertex(0.25, d(0.25), 0.35, d(0.35), 0.5, d(0.5));
  EXPECT_GT(v, 0.25);
  EXPECT_LT(v, 0.5);
  EXPECT_LT(std::abs(v - 0.37), std::abs(0.35 - 0.37));
}

TEST(ExtendedModel, FitOverStartsKeepsTheLowestCostOfTheFitsFromEachStart) {
  // One LM step from a stiffness 40 % low and from one 5 % high: the result is exactly the single
  // fit of lowest cost, with all simulations.
  const StiffWristCase w = StiffWrist();
  const std::vector<ModelParameter> params = {Stiffness(w.k_nominal)};
  const std::vector<Eigen::VectorXd> starts = {Eigen::VectorXd::Constant(1, 0.6 * w.k_nominal),
                                               Eigen::VectorXd::Constant(1, 1.05 * w.k_nominal)};
  std::vector<double> costs;
  std::size_t kept = 9;
  const FitResult best = FitOverStarts(w.rig, params, starts, w.view, w.options, 1, &costs, &kept);
  ASSERT_EQ(costs.size(), 2u);
  int simulations = 0;
  for (std::size_t k = 0; k < 2; ++k) {
    const FitResult f = FitParameters(w.rig, params, starts[k], w.view, w.options, 0, 1);
    EXPECT_EQ(costs[k], f.map_cost) << k;
    simulations += f.simulations;
  }
  EXPECT_EQ(kept, 1u);  // one step from 5 % high ends lower than one from 40 % low
  EXPECT_EQ(best.cost, costs[1]);
  EXPECT_EQ(best.simulations, simulations);
  EXPECT_THROW(FitOverStarts(w.rig, params, {}, w.view, w.options, 1), std::invalid_argument);
}

TEST(ExtendedModel, AFitFromAKnownStartIsTheFitThatSimulatesIt) {
  // A fit continued from where another ended, given that fit's end residual, Jacobian and
  // predictions (FitStart), returns the same numbers and skips the 1 + p start simulations.
  const StiffWristCase w = StiffWrist();
  const sim::ModelParams& rig = w.rig;
  const double k_nominal = w.k_nominal;
  const DataView& v = w.view;
  FitOptions o = w.options;
  o.relative_tolerance = 0.0;  // no early stop: both continuations take the same steps
  const std::vector<ModelParameter> params = {Stiffness(k_nominal)};
  const FitResult first =
      FitParameters(rig, params, Eigen::VectorXd::Constant(1, k_nominal), v, o, 0, 1);
  ASSERT_EQ(first.residual.size(), v.Count());
  ASSERT_EQ(first.predictions.size(), 1u);
  EXPECT_EQ(first.residual, StackResiduals(v, Predict(rig, params, first.x, v, o)));
  const FitResult cold = FitParameters(rig, params, first.x, v, o, 0, 2);
  FitStart start;
  start.residual = first.residual;
  start.jacobian = first.jacobian;
  start.predictions = first.predictions;
  const FitResult warm = FitParameters(rig, params, first.x, v, o, 0, 2, nullptr, &start);
  EXPECT_EQ(warm.x, cold.x);
  EXPECT_EQ(warm.cost, cold.cost);
  EXPECT_EQ(warm.residual, cold.residual);
  EXPECT_EQ(warm.simulations, cold.simulations - 2);  // r(x0) and one Jacobian column, 1 trial
}

/// Relative error ‖J − J_ref‖ / ‖J_ref‖ of ResidualJacobian's column for the one parameter `p`
/// at value x (options `o`) on the wrist of `v`, against central differences ±h of 1e-10
/// simulations.
double ColumnError(const sim::ModelParams& rig, const ModelParameter& p, const DataView& v,
                   double x, double h, const FitOptions& o) {
  const std::vector<ModelParameter> params = {p};
  FitOptions exact = Accurate();
  exact.tolerance = 1e-10;
  const auto r = [&](double value, const FitOptions& opts) {
    return StackResiduals(v, Predict(rig, params, Eigen::VectorXd::Constant(1, value), v, opts));
  };
  const Eigen::VectorXd reference = (r(x + h, exact) - r(x - h, exact)) / (2.0 * h);
  const Eigen::MatrixXd j =
      ResidualJacobian(rig, params, Eigen::VectorXd::Constant(1, x), r(x, o), v, o);
  return (j.col(0) - reference).norm() / reference.norm();
}

TEST(ExtendedModel, JacobianStepFollowsTheValueSoAColumnRisesAboveTheIntegrationError) {
  // The fatigue rate of the diagnosis library (typical scale 0.01/s, for its "off" value 0) at
  // 0.3/s: a forward-difference step of fd_step × scale = 1e-4/s moves the wrist by micro-
  // radians, the size of the integration error at the diagnosis' tolerance, and the column is
  // mostly that error; the step fd_step × max(scale, |x − start|) = 3e-3/s is not.
  const sim::ModelParams rig = identification::fullmodel::DefaultHandRig();
  Trial t;
  for (int i = 0; i <= 1000; ++i) t.time.push_back(i / 50.0);
  std::vector<double> ext(t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    ext[i] = std::fmod(t.time[i], 3.0) >= 1.0 ? 200.0 : 0.0;  // 2 s on, 1 s off
  }
  t.AddColumn("u.ext", ext);
  t.AddColumn("q.wrist_flexion", std::vector<double>(t.size(), 0.0));
  const DataView v = ViewOf(t);
  ModelParameter rate;
  rate.name = "fatigue.rate_per_s";
  rate.lower = 0.0;
  rate.upper = 1.0;
  rate.scale = 0.01;
  rate.set = [](double x, sim::ModelParams* m) {
    m->mechanisms.fatigue.enabled = x > 1e-12;
    if (x > 1e-12) m->mechanisms.fatigue.fatigue_time_s = 1.0 / x;
  };
  const double x = 0.3, h = 0.01;
  FitOptions o = DiagnoseSettings::DefaultFitOptions();
  const double now = ColumnError(rig, rate, v, x, h, o);
  o.fd_step *= rate.scale / x;  // the step fd_step × scale of before
  const double before = ColumnError(rig, rate, v, x, h, o);
  std::printf(
      "fatigue-rate column vs central differences at 1e-10: %.3g (step 3e-3/s), %.3g "
      "(1e-4/s)\n",
      now, before);
  EXPECT_LT(now, 0.2);           // 0.10 seen at the default tolerance 1e-4
  EXPECT_GT(before, 5.0 * now);  // 3.1 seen
}

TEST(ExtendedModel, FrequencyStepStaysSmallBecauseTheStepFollowsTheDistanceFromTheStart) {
  // A wrist tremor at 5.35 Hz (the library's frequency: start at the residual's spectrum peak,
  // scale 0.1 Hz), fitted to 5.38 Hz. A step relative to the value (1e-2 × 5.38 = 0.054 Hz)
  // shifts the phase by 2π · 0.054 · 20 = 6.8 rad at the end of a 20 s trial: the difference
  // quotient is no derivative. Relative to the distance from the start it is 1e-3 Hz (0.13 rad).
  const sim::ModelParams rig = identification::fullmodel::DefaultHandRig();
  Trial t;
  for (int i = 0; i <= 2000; ++i) t.time.push_back(i / 100.0);
  t.AddColumn("u.ext", std::vector<double>(t.size(), 150.0));
  t.AddColumn("q.wrist_flexion", std::vector<double>(t.size(), 0.0));
  const DataView v = ViewOf(t);
  ModelParameter f;
  f.name = "tremor.frequency_hz";
  f.start = 5.35;
  f.lower = 5.2;
  f.upper = 5.5;
  f.scale = 0.1;
  f.set = [](double hz, sim::ModelParams* m) {
    m->mechanisms.tremor.enabled = true;
    m->mechanisms.tremor.coordinate = sim::kWristFlexion;
    m->mechanisms.tremor.amplitude_nm = 0.03;
    m->mechanisms.tremor.frequency_hz = hz;
  };
  const double x = 5.38, h = 1e-4;
  FitOptions o = DiagnoseSettings::DefaultFitOptions();
  const double now = ColumnError(rig, f, v, x, h, o);
  o.fd_step *= x / std::max(f.scale, x - f.start);  // the step fd_step × |x| of before
  const double relative_to_value = ColumnError(rig, f, v, x, h, o);
  std::printf(
      "frequency column vs central differences at 1e-10: %.3g (step 1e-3 Hz), %.3g "
      "(0.054 Hz)\n",
      now, relative_to_value);
  EXPECT_LT(now, 0.15);               // 0.051 seen
  EXPECT_GT(relative_to_value, 0.5);  // 1.11 seen
}

TEST(ExtendedModel, DriftJacobianColumnIsMinusTimeWithoutSimulating) {
  const sim::ModelParams rig = identification::fullmodel::DefaultHandRig();
  const double k_nominal = rig.coordinates[sim::kWristFlexion].passive.stiffness_nm_per_rad;
  DataView v = ViewOf(StepTrial(rig));
  for (std::size_t i = 0; i < 20; ++i) v.use[0][i] = 0;  // unused samples are skipped
  ModelParameter drift;
  drift.name = "drift";
  drift.target = ModelParameter::Target::kOutputDrift;
  drift.column = "q.wrist_flexion";
  drift.lower = -1;
  drift.upper = 1;
  drift.scale = 1e-3;
  const std::vector<ModelParameter> params = {Stiffness(k_nominal), drift};
  Eigen::VectorXd x(2);
  x << 1.1 * k_nominal, 2e-3;
  const FitOptions o = Accurate();
  const Eigen::VectorXd r0 = StackResiduals(v, Predict(rig, params, x, v, o));
  int sims = 0;
  const Eigen::MatrixXd J = ResidualJacobian(rig, params, x, r0, v, o, &sims);
  EXPECT_EQ(sims, 1);  // the stiffness column only
  // The forward difference of the simulated drift, as before.
  Eigen::VectorXd xh = x;
  const double h = o.fd_step * drift.scale;
  xh(1) += h;
  const Eigen::VectorXd fd = (StackResiduals(v, Predict(rig, params, xh, v, o)) - r0) / h;
  ASSERT_EQ(J.rows(), fd.size());
  EXPECT_NEAR((J.col(1) - fd).cwiseAbs().maxCoeff(), 0.0, 1e-8);
  EXPECT_DOUBLE_EQ(J(0, 1), -v.trials[0].time[20]);
  EXPECT_GT(J.col(0).norm(), 0.0);
}

TEST(ExtendedModel, ADriftOfOneTrialDriftsThatTrialAloneAndItsColumnIsZeroElsewhere) {
  // Per-trial drift rates (Candidate::drift_per_trial): the rate of trial 0 is added to trial 0
  // only, trial 1's to trial 1 only; their exact Jacobian columns are −t on their own trial's rows
  // and 0 on the other's.
  const sim::ModelParams rig = identification::fullmodel::DefaultHandRig();
  DataView v = ViewOf(StepTrial(rig));
  v.trials.push_back(v.trials[0]);
  v.use.push_back(v.use[0]);
  std::vector<ModelParameter> params(2);
  for (int t = 0; t < 2; ++t) {
    params[t].name = "drift" + std::to_string(t);
    params[t].target = ModelParameter::Target::kOutputDrift;
    params[t].column = "q.wrist_flexion";
    params[t].lower = -1;
    params[t].upper = 1;
    params[t].scale = 1e-3;
    params[t].trial = t;
  }
  Eigen::VectorXd x(2);
  x << 0.01, -0.02;
  const auto with = Predict(rig, params, x, v, Accurate(), 1);
  const auto without = Predict(rig, params, Eigen::VectorXd::Zero(2), v, Accurate(), 1);
  for (int t = 0; t < 2; ++t) {
    const auto& a = with[t].Column("q.wrist_flexion");
    const auto& b = without[t].Column("q.wrist_flexion");
    for (std::size_t i = 0; i < a.size(); i += 25)
      EXPECT_NEAR(a[i] - b[i], x(t) * v.trials[t].time[i], 1e-12) << "trial " << t;
  }
  const Eigen::VectorXd r0 = StackResiduals(v, with);
  int sims = 0;
  const Eigen::MatrixXd J = ResidualJacobian(rig, params, x, r0, v, Accurate(), &sims);
  EXPECT_EQ(sims, 0);
  const auto n = static_cast<Eigen::Index>(v.trials[0].size());
  ASSERT_EQ(J.rows(), 2 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double ti = v.trials[0].time[static_cast<std::size_t>(i)];
    EXPECT_DOUBLE_EQ(J(i, 0), -ti);
    EXPECT_DOUBLE_EQ(J(n + i, 0), 0.0);
    EXPECT_DOUBLE_EQ(J(i, 1), 0.0);
    EXPECT_DOUBLE_EQ(J(n + i, 1), -ti);
  }
}

TEST(ExtendedModel, AParameterOfOneTrialMovesThatTrialAloneInPredictionsAndJacobian) {
  // Two trials; the stiffness applies to the second alone (ModelParameter::trial = 1): the first
  // is simulated at the rig's value, and the Jacobian column is 0 on its rows and, on the
  // second's, the column of the same parameter fitted to that trial alone — by forward
  // differences and by sensitivities.
  const sim::ModelParams rig = identification::fullmodel::DefaultHandRig();
  const double k_nominal = rig.coordinates[sim::kWristFlexion].passive.stiffness_nm_per_rad;
  const Trial trial = StepTrial(rig);
  DataView both = ViewOf(trial);
  both.trials.push_back(trial);
  both.use.push_back(both.use[0]);
  const DataView second = ViewOf(trial);
  const FitOptions o = Accurate();
  for (const bool sensed : {false, true}) {
    ModelParameter k = Stiffness(k_nominal);
    k.sensitivity = sensed;
    const std::vector<ModelParameter> shared = {k};
    k.trial = 1;
    const std::vector<ModelParameter> of_second = {k};
    Eigen::VectorXd x(1);
    x << 1.3 * k_nominal;
    const std::vector<Trial> pred = Predict(rig, of_second, x, both, o);
    const auto& q0 = pred[0].Column("q.wrist_flexion");
    const auto& q1 = pred[1].Column("q.wrist_flexion");
    const std::vector<double> stiff =
        Predict(rig, shared, x, second, o)[0].Column("q.wrist_flexion");
    double first_off = 0.0, second_off = 0.0, moved = 0.0;
    for (std::size_t i = 0; i < q0.size(); ++i) {
      first_off = std::max(first_off, std::abs(q0[i] - trial.Column("q.wrist_flexion")[i]));
      second_off = std::max(second_off, std::abs(q1[i] - stiff[i]));
      moved = std::max(moved, std::abs(q1[i] - q0[i]));
    }
    EXPECT_LT(first_off, 1e-5);
    EXPECT_LT(second_off, 1e-9);
    EXPECT_GT(moved, 1e-3);

    int sims = 0;
    const Eigen::MatrixXd J =
        ResidualJacobian(rig, of_second, x, StackResiduals(both, pred), both, o, &sims);
    EXPECT_EQ(sims, 1) << "sensed " << sensed;  // the second trial only
    const Eigen::MatrixXd J1 =
        ResidualJacobian(rig, shared, x, StackResiduals(second, Predict(rig, shared, x, second, o)),
                         second, o, nullptr);
    const Eigen::Index n = J1.rows();
    ASSERT_EQ(J.rows(), 2 * n);
    EXPECT_EQ(J.col(0).head(n).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_GT(J1.norm(), 0.0);
    EXPECT_LT((J.col(0).tail(n) - J1.col(0)).norm(), 1e-9 * J1.norm()) << "sensed " << sensed;
  }
}

TEST(ExtendedModel, CollapsedParameterIsTheOneAtItsCollapseBound) {
  ModelParameter gain = Stiffness(1.0), rise = Stiffness(1.0);
  gain.name = "gain";
  rise.name = "rise";
  rise.lower = 0.5;
  rise.upper = 60.5;
  rise.collapses_at = 0.5;
  const std::vector<ModelParameter> params = {gain, rise};
  Eigen::VectorXd x(3);
  x << 7.0, 0.2, 0.5;  // a subject value first, then the two from offset 1
  EXPECT_EQ(CollapsedParameter(params, x, 1), "rise");
  x(2) = 0.5 + 0.05;  // within 1e-3 of the 60 range
  EXPECT_EQ(CollapsedParameter(params, x, 1), "rise");
  x(2) = 0.5 + 0.07;
  EXPECT_EQ(CollapsedParameter(params, x, 1), "");
  x(1) = 0.2;  // gain at its own lower bound: it has no collapse value
  EXPECT_EQ(CollapsedParameter(params, x, 1), "");
  EXPECT_THROW(CollapsedParameter(params, x, 2), std::invalid_argument);
}

// A candidate at a joint is judged with the person parameters of that joint (extension.cc,
// Judge): those at a bound of their range are named, the other joints' are not.
TEST(ExtendedModel, JointParametersAtBoundNamesTheJointsParametersAtEitherBound) {
  ModelParameter k = Stiffness(1.0), arm = Stiffness(1.0), other = Stiffness(1.0),
                 strength = Stiffness(1.0);
  k.name = "k.pip_flexion";
  k.joint = "pip_flexion";
  k.lower = 0.1;
  k.upper = 10.0;
  arm.name = "arm.ext.finger@pip_flexion";
  arm.joint = "pip_flexion";
  arm.lower = 0.5;
  arm.upper = 2.0;
  other.name = "k.mcp_flexion";
  other.joint = "mcp_flexion";
  other.lower = 0.1;
  other.upper = 10.0;
  strength.name = "strength.ext";
  strength.lower = 0.05;
  strength.upper = 20.0;
  const std::vector<ModelParameter> params = {k, arm, other, strength};
  Eigen::VectorXd x(5);
  x << 1.0, 1.0, 10.0, 0.05, 3.0;  // the fifth: a mechanism's, not a person's
  EXPECT_EQ(JointParametersAtBound(params, x, "pip_flexion"), "");
  EXPECT_EQ(JointParametersAtBound(params, x, "mcp_flexion"), "k.mcp_flexion");
  EXPECT_EQ(JointParametersAtBound(params, x, ""), "");  // whole-model mechanisms
  x(1) = 2.0 - 1e-3;                                     // within 1e-3 of the 1.5 range
  x(0) = 0.1;
  EXPECT_EQ(JointParametersAtBound(params, x, "pip_flexion"),
            "k.pip_flexion, arm.ext.finger@pip_flexion");
  x(1) = 2.0 - 2e-3;
  EXPECT_EQ(JointParametersAtBound(params, x, "pip_flexion"), "k.pip_flexion");
  EXPECT_THROW(JointParametersAtBound(params, x.head(3), "pip_flexion"), std::invalid_argument);
}

TEST(ExtendedModel, AFitInsideEveryNormalBandIsANormalPerson) {
  ModelParameter ratio = Stiffness(1.0), free = Stiffness(1.0), other = Stiffness(1.0);
  ratio.name = "ratio";
  ratio.start = 0.0;
  ratio.lower = -12.0;
  ratio.upper = 12.0;
  ratio.normal_half_width = 3.0;
  other = ratio;
  other.name = "other";
  other.normal_half_width = 1.0;
  free.name = "free";  // no band: never decides
  Eigen::VectorXd x(3);
  x << 7.0, -2.5, 11.0;  // a person value first, then ratio and free from offset 1
  EXPECT_EQ(WithinNormalVariation({ratio, free}, x, 1),
            "ratio = -2.5 within its normal variation 0 ± 3");
  x(1) = -3.5;  // beyond the band: the mechanism
  EXPECT_EQ(WithinNormalVariation({ratio, free}, x, 1), "");
  x(1) = 2.0;
  EXPECT_EQ(WithinNormalVariation({free, free}, x, 1), "");  // no band at all
  // Two banded parameters: one beyond its band is enough to be the mechanism.
  x(2) = 1.5;
  EXPECT_EQ(WithinNormalVariation({ratio, other}, x, 1), "");
  x(2) = -0.5;
  EXPECT_NE(WithinNormalVariation({ratio, other}, x, 1), "");
  EXPECT_THROW(WithinNormalVariation({ratio, other}, x, 2), std::invalid_argument);
  // With the fit's ci95, an unbanded parameter must also be indistinguishable from its start.
  x << 7.0, -2.5, 11.0;
  Eigen::VectorXd ci95(3);
  ci95 << 0.1, 0.2, 12.0;
  free.start = 0.0;  // free = 11 ± 12 includes its start 0: indistinguishable from "off"
  EXPECT_NE(WithinNormalVariation({ratio, free}, x, 1, ci95), "");
  ci95(2) = 10.0;  // 11 ± 10 excludes its start 0: the unbanded part is the mechanism
  EXPECT_EQ(WithinNormalVariation({ratio, free}, x, 1, ci95), "");
  ci95(2) = NAN;  // no interval: indistinguishable only at its start
  EXPECT_EQ(WithinNormalVariation({ratio, free}, x, 1, ci95), "");
  x(2) = 0.0;
  EXPECT_NE(WithinNormalVariation({ratio, free}, x, 1, ci95), "");
  EXPECT_THROW(WithinNormalVariation({ratio, free}, x, 1, Eigen::VectorXd(2)),
               std::invalid_argument);
}

TEST(ExtendedModel, NrmseIsZeroForAPerfectPredictionAndSkipsUnusedSamples) {
  const sim::ModelParams rig = identification::fullmodel::DefaultHandRig();
  DataView v = ViewOf(StepTrial(rig));
  std::vector<Trial> pred = {v.trials[0]};
  EXPECT_NEAR(ViewNrmse(v, pred), 0.0, 1e-15);
  pred[0].MutableColumn("q.wrist_flexion")[0] += 1.0;  // wrong only where not counted
  v.use[0][0] = 0;
  EXPECT_NEAR(ViewNrmse(v, pred), 0.0, 1e-15);
  EXPECT_EQ(StackResiduals(v, pred).size(), static_cast<long>(v.trials[0].size()) - 1);
}

/// A 4 s two-output hand-rig trial (wrist, MCP; both array channels stepped) starting at a
/// measured posture away from the rest angles.
DataView TwoOutputStepView() {
  Trial t;
  for (int i = 0; i <= 200; ++i) t.time.push_back(i / 50.0);
  std::vector<double> ext(t.size()), flex(t.size()), zero(t.size(), 0.0);
  for (std::size_t i = 0; i < t.size(); ++i) {
    ext[i] = (t.time[i] >= 0.5 && t.time[i] < 2.0) ? 180 : 0;
    flex[i] = t.time[i] >= 2.5 ? 150 : 0;
  }
  t.AddColumn("u.ext", ext);
  t.AddColumn("u.flex", flex);
  t.AddColumn("q.wrist_flexion", zero);
  t.AddColumn("q.mcp_flexion", zero);
  DataView v;
  v.trials = {t};
  v.use = {std::vector<char>(t.size(), 1)};
  v.outputs = {"q.wrist_flexion", "q.mcp_flexion"};
  v.initial_q = {{0.1, 0.4}};
  return v;
}

/// The Jacobian columns of `params` (all ModelParameter::sensitivity) at `x` from forward
/// sensitivities against central differences of whole simulations, each within `relative` of
/// the column's norm; a column the data do not see (central difference 0) only counts when
/// `must_move`. Prints each column's norm and error.
void ExpectSensedColumnsMatchCentralDifferences(const sim::ModelParams& rig,
                                                const std::vector<ModelParameter>& params,
                                                const Eigen::VectorXd& x, const std::string& what,
                                                double relative, bool must_move) {
  const DataView v = TwoOutputStepView();
  FitOptions o = Accurate();
  o.threads = 2;
  o.jacobian_tolerance_factor = 1.0;
  const Eigen::VectorXd r = StackResiduals(v, Predict(rig, params, x, v, o));
  const Eigen::MatrixXd sens = ResidualJacobian(rig, params, x, r, v, o);
  o.sensitivities = false;
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    ASSERT_TRUE(params[k].sensitivity) << what << " " << params[k].name;
    const double h = 1e-3 * params[k].scale;
    Eigen::VectorXd xp = x, xm = x;
    xp(k) += h;
    xm(k) -= h;
    const Eigen::VectorXd central = (StackResiduals(v, Predict(rig, params, xp, v, o)) -
                                     StackResiduals(v, Predict(rig, params, xm, v, o))) /
                                    (2 * h);
    std::printf("%-28s %-28s |central| %.4g, |sensitivity - central| %.3g\n", what.c_str(),
                params[k].name.c_str(), central.norm(), (sens.col(k) - central).norm());
    if (must_move) {
      EXPECT_GT(central.norm(), 0.0) << what << " " << params[k].name;
    }
    EXPECT_LT((sens.col(k) - central).norm(), relative * central.norm() + 1e-6)
        << what << " " << params[k].name << " |central| " << central.norm();
  }
}

TEST(ExtendedModel, SensitivityColumnsMatchForwardDifferencesOfWholeSimulations) {
  // Person parameters whose Jacobian columns come from CVODES forward sensitivities (strength,
  // recruitment, passive joint, moment arms), off their nominal values.
  const sim::ModelParams rig = identification::fullmodel::DefaultHandRig();
  LibraryContext ctx;
  ctx.outputs = TwoOutputStepView().outputs;
  ctx.channels = {"ext", "flex"};
  std::vector<ModelParameter> params;
  for (const auto& p : PersonParameters(rig, ctx)) {
    if (p.sensitivity) params.push_back(p);
  }
  ASSERT_GE(params.size(), 10u);
  Eigen::VectorXd x = Starts(params);
  for (Eigen::Index k = 0; k < x.size(); ++k) x(k) += 0.05 * params[k].scale;         // off nominal
  ExpectSensedColumnsMatchCentralDifferences(rig, params, x, "person", 0.01, false);  // ≤ 0.3 %
}

TEST(MechanismParameters, SensedColumnsMatchCentralDifferencesOfWholeSimulations) {
  // Every candidate parameter marked Sensed (mechanisms/library.h) of every mechanism at the
  // wrist and MCP, at the candidate's first probe (the mechanism on) moved off any bound.
  const sim::ModelParams rig = identification::fullmodel::DefaultHandRig();
  LibraryContext ctx;
  ctx.outputs = TwoOutputStepView().outputs;
  ctx.channels = {"ext", "flex"};
  int columns = 0;
  for (const Candidate& c : CandidateLibrary(rig, ctx)) {
    if (!c.applicable || c.probes.empty()) continue;
    std::vector<int> sensed;
    for (std::size_t k = 0; k < c.params.size(); ++k) {
      if (c.params[k].sensitivity) sensed.push_back(static_cast<int>(k));
    }
    if (sensed.empty()) continue;
    EXPECT_EQ(sensed.size(), c.params.size()) << c.label << ": all parameters sensed, or none";
    Eigen::VectorXd x = c.probes[0];
    for (std::size_t k = 0; k < c.params.size(); ++k) {
      const double room = 0.05 * c.params[k].scale;
      if (x(k) - c.params[k].lower < room) x(k) = c.params[k].lower + room;
      if (c.params[k].upper - x(k) < room) x(k) = c.params[k].upper - room;
    }
    if (sensed.size() != c.params.size()) continue;
    // ≤ 0.5 % seen, except 1.4 % (a wrist range limit's scale, a small column) and 2.8 % (the
    // stretch reflex's gain at the MCP: its torque has a kink at the threshold speed).
    ExpectSensedColumnsMatchCentralDifferences(rig, c.params, x, c.label, 0.05, true);
    columns += static_cast<int>(c.params.size());
  }
  EXPECT_GE(columns, 12);
}

TEST(ExtendedModel, APriorKeepsAParameterTheDataDoNotSeeAtItsStart) {
  // Two parameters, only one of which the data see: the stiffness and the flexor group's
  // strength with the flexors never stimulated. With the prior rows the unseen strength stays at
  // its start; the stiffness is fitted as without a prior.
  StiffWristCase w = StiffWrist();
  ModelParameter strength;
  strength.name = "strength.flex";
  strength.start = 1.0;
  strength.lower = 0.2;
  strength.upper = 5.0;
  strength.prior_width = 0.5;
  strength.set = [](double v, sim::ModelParams* m) {
    for (auto& mu : m->muscles) {
      if (mu.name == "FCR" || mu.name == "FCU") mu.hill.max_isometric_force_n *= v;
    }
  };
  ModelParameter k = Stiffness(w.k_nominal);
  k.prior_width = 0.5 * w.k_nominal;
  w.options.prior_sigma = 0.01;
  Eigen::VectorXd x0(2);
  x0 << w.k_nominal, 1.0;
  const FitResult fit = FitParameters(w.rig, {k, strength}, x0, w.view, w.options, 0, 10);
  EXPECT_NEAR(fit.x(0), 1.3 * w.k_nominal, 0.01 * w.k_nominal);
  // Only a trace of information: the unstimulated flexors' passive fibre force scales with F_max.
  EXPECT_NEAR(fit.x(1), 1.0, 0.01);
  // The posterior interval is at most the prior's (σ̂ / σ_p × the prior width, σ̂² the data
  // cost over N − p): data can only add information.
  EXPECT_LE(fit.ci95(1), 1.0001 * 1.96 * 0.5 * std::sqrt(fit.cost / (w.view.Count() - 2)) / 0.01);
  EXPECT_GT(fit.ci95(1), 0.0);
  EXPECT_GE(fit.map_cost, fit.cost);
}

TEST(ExtendedModel, UnstackResidualsUndoesStackResidualsPerTrialAndOutput) {
  Trial a;
  for (int i = 0; i < 5; ++i) a.time.push_back(0.1 * i);
  a.AddColumn("q.wrist_flexion", {1, 2, NAN, 4, 5});
  a.AddColumn("q.mcp_flexion", {6, 7, 8, 9, 10});
  DataView v;
  v.trials = {a, a};
  v.use = {{1, 1, 1, 1, 0}, {0, 1, 1, 1, 1}};
  v.outputs = {"q.wrist_flexion", "q.mcp_flexion"};
  Trial zero = a;
  zero.MutableColumn("q.wrist_flexion").assign(5, 0.0);
  zero.MutableColumn("q.mcp_flexion").assign(5, 0.0);
  const Eigen::VectorXd r = StackResiduals(v, {zero, zero});
  const std::vector<ResidualSeries> s = UnstackResiduals(v, r);
  ASSERT_EQ(s.size(), 4u);
  EXPECT_EQ(s[0].r, (std::vector<double>{1, 2, 4}));
  EXPECT_EQ(s[0].time_s, (std::vector<double>{0.0, 0.1, 0.30000000000000004}));
  EXPECT_EQ(s[3].trial, 1);
  EXPECT_EQ(s[3].output, "q.mcp_flexion");
  EXPECT_EQ(s[3].r, (std::vector<double>{7, 8, 9, 10}));
  EXPECT_THROW(UnstackResiduals(v, r.head(r.size() - 1)), std::invalid_argument);
  EXPECT_THROW(UnstackResiduals(v, Eigen::VectorXd::Zero(r.size() + 1)), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::diagnosis
