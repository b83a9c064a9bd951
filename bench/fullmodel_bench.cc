// Issue 4 benchmark: the full model (12) fit versus the Hammerstein two-step fit on one participant
// of the hand-array study ([Hand Hammerstein] §5.1, Tables 1–2: 1019 s versus 0.178 s per local
// optimisation step in MATLAB).
//
// Participant: the default participant on the hand rig (identification/fullmodel DefaultHandRig:
// arm locked, wrist and index finger free) whose candidate parameters are perturbed by a seeded
// ±20 % (the "true" participant; the fit starts from the nominal values). Data: the step grid of
// §5.1 (channels ext/flex, 50 µs spacing, u1 + u2 ≤ u_max = 300 µs, 28 points, 5 s per step,
// 140 s per data set), four data sets (both traversal orders), joint angles q.wrist_flexion,
// q.mcp_flexion, q.pip_flexion at 40 Hz with 0.3° noise; three data sets fit, the fourth
// validates. A local optimisation step = one bounded LM run from one start point.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "identification/fullmodel/full_model_fit.h"
#include "identification/hammerstein_mimo.h"
#include "identification/method_support.h"
#include "identification/metrics.h"
#include "protocols/protocols.h"
#include "sim/integrator.h"
#include "sim/trial_runner.h"
#include "sim/upper_limb_model.h"

namespace {

using fesim::Trial;
namespace fm = fesim::identification::fullmodel;
namespace id = fesim::identification;
namespace sim = fesim::sim;

constexpr double kRateHz = 40.0;
constexpr double kNoiseRad = 0.3 * 3.14159265358979323846 / 180.0;
constexpr double kDataTolerance = 1e-6;  // integrator tolerance of the data generation
constexpr double kPerturbation = 0.2;    // ± relative perturbation of the true participant

struct Study {
  sim::ModelParams rig;          // nominal (start point)
  sim::ModelParams participant;  // the "true" participant
  std::vector<Trial> train;      // three data sets
  Trial validation;              // the fourth
};

sim::ModelParams TrueParticipant(const sim::ModelParams& rig) {
  const sim::ModelParams base = fm::WithExplicitArrayWeights(rig);
  const auto candidates = fm::CandidateParameters(rig, {"ext", "flex"});
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> u(-kPerturbation, kPerturbation);
  Eigen::VectorXd x(static_cast<Eigen::Index>(candidates.size()));
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const auto& c = candidates[i];
    x(static_cast<Eigen::Index>(i)) = std::clamp(c.nominal * (1.0 + u(rng)), c.lower, c.upper);
  }
  return fm::ApplyParameters(base, candidates, x);
}

Trial SimulateProgram(const sim::ModelParams& model, const fesim::protocols::StimulationProgram& p,
                      std::uint64_t seed) {
  const sim::UpperLimbModel limb(model);
  sim::TrialRequest req;
  req.duration_s = p.duration_s;
  for (std::size_t k = 0; k < p.times_s.size(); ++k) {
    std::vector<double> u(model.channels.size(), 0.0);
    u[0] = p.values_us[k][0];
    u[1] = p.values_us[k][1];
    req.stimulation.times.push_back(p.times_s[k]);
    req.stimulation.values.push_back(u);
  }
  req.integrator.tolerance = kDataTolerance;
  req.seed = seed;
  req.sensors.angles.rate_hz = kRateHz;
  req.sensors.angles.noise_std = kNoiseRad;
  req.sensors.angles.coordinates = {sim::kWristFlexion, sim::kMcpFlexion, sim::kPipFlexion};
  req.sensors.truth_rate_hz = 1.0;
  const Trial m = sim::RunTrial(limb, req).measured;
  Trial out;
  out.time = m.time;
  for (const char* name :
       {"u.ext", "u.flex", "q.wrist_flexion", "q.mcp_flexion", "q.pip_flexion"}) {
    out.AddColumn(name, m.Column(name));
  }
  return out;
}

Study MakeStudy() {
  Study s;
  s.rig = fm::DefaultHandRig();
  s.participant = TrueParticipant(s.rig);
  fesim::protocols::StepGridParams grid;
  grid.u_max_us = 300.0;
  const auto programs = fesim::protocols::StepGridDataSets(grid, 4);
  for (std::size_t k = 0; k < programs.size(); ++k) {
    Trial t = SimulateProgram(s.participant, programs[k], 10 + k);
    if (k < 3) {
      s.train.push_back(std::move(t));
    } else {
      s.validation = std::move(t);
    }
  }
  return s;
}

id::MimoTrialData ToMimo(const Trial& t) {
  id::MimoTrialData d;
  d.sample_period_s = 1.0 / kRateHz;
  d.u_us = id::RequireColumns(t, {"u.ext", "u.flex"}, "bench");
  d.y_rad = id::RequireColumns(t, {"q.wrist_flexion", "q.mcp_flexion", "q.pip_flexion"}, "bench");
  return d;
}

double MeanNormalisedError(const Trial& data, const Trial& prediction) {
  double sum = 0.0;
  for (const char* j : {"q.wrist_flexion", "q.mcp_flexion", "q.pip_flexion"}) {
    sum += id::NormalisedError(data.Column(j), prediction.Column(j));
  }
  return sum / 3.0;
}

/// One 140 s step-grid data set through the full model (the unit cost of every residual).
void BM_SimulateDataSet(benchmark::State& state) {
  const Study s = MakeStudy();
  const double tol = std::pow(10.0, -static_cast<double>(state.range(0)));
  for (auto _ : state) {
    benchmark::DoNotOptimize(fm::SimulateLike(s.participant, s.train[0], tol));
  }
  state.counters["simulated_s"] = s.train[0].time.back();
}
BENCHMARK(BM_SimulateDataSet)->Arg(4)->Arg(6)->Unit(benchmark::kMillisecond)->Iterations(3);

/// The same data set integrated with sim::RunTrial directly: integrator work per simulation
/// (steps, right-hand sides, Jacobians) and the cost of the 40 Hz report grid (range(1) = 0:
/// angles only at the end, no per-sample observation).
void BM_SimulateDataSetStats(benchmark::State& state) {
  const Study s = MakeStudy();
  const double tol = std::pow(10.0, -static_cast<double>(state.range(0)));
  fesim::protocols::StepGridParams grid;
  grid.u_max_us = 300.0;
  const auto program = fesim::protocols::StepGridDataSets(grid, 1).front();
  const sim::UpperLimbModel limb(s.participant);
  sim::TrialRequest req;
  req.duration_s = program.duration_s;
  for (std::size_t k = 0; k < program.times_s.size(); ++k) {
    std::vector<double> u(s.participant.channels.size(), 0.0);
    u[0] = program.values_us[k][0];
    u[1] = program.values_us[k][1];
    req.stimulation.times.push_back(program.times_s[k]);
    req.stimulation.values.push_back(u);
  }
  req.integrator.tolerance = tol;
  req.sensors.angles.rate_hz = state.range(1) ? kRateHz : 1.0 / program.duration_s;
  req.sensors.angles.coordinates = {sim::kWristFlexion, sim::kMcpFlexion, sim::kPipFlexion};
  req.sensors.truth_rate_hz = 1.0 / program.duration_s;
  sim::IntegrationStats stats;
  for (auto _ : state) stats = sim::RunTrial(limb, req).stats;
  state.counters["steps"] = static_cast<double>(stats.steps);
  state.counters["rhs"] = static_cast<double>(stats.rhs_evaluations);
  state.counters["jacobians"] = static_cast<double>(stats.jacobian_evaluations);
}
BENCHMARK(BM_SimulateDataSetStats)
    ->Args({4, 1})
    ->Args({4, 0})
    ->Args({3, 1})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);

/// The first `count` candidate parameters of the hand rig at their nominal values, perturbed for
/// sim::IntegrateTrialSensitivities, and one 140 s step-grid data set (schedule, 40 Hz times).
struct SensitivityProblem {
  sim::ModelParams model;
  std::vector<sim::ParameterPerturbation> perturbed;
  sim::StimulationSchedule schedule;
  std::vector<double> times;
};
SensitivityProblem MakeSensitivityProblem(int count) {
  const sim::ModelParams rig = fm::DefaultHandRig();
  const sim::ModelParams base = fm::WithExplicitArrayWeights(rig);
  auto candidates = fm::CandidateParameters(rig, {"ext", "flex"});
  candidates.resize(static_cast<std::size_t>(count));
  Eigen::VectorXd x(static_cast<Eigen::Index>(candidates.size()));
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    x(static_cast<Eigen::Index>(i)) = candidates[i].nominal;
  }
  SensitivityProblem p;
  for (Eigen::Index c = 0; c < x.size(); ++c) {
    const double scale = std::max(std::abs(x(c)), 1e-3);
    Eigen::VectorXd xp = x;
    xp(c) += 1e-7 * scale;
    p.perturbed.push_back({fm::ApplyParameters(base, candidates, xp), 1e-7 * scale, scale});
  }
  fesim::protocols::StepGridParams grid;
  grid.u_max_us = 300.0;
  const auto program = fesim::protocols::StepGridDataSets(grid, 1).front();
  p.model = fm::ApplyParameters(base, candidates, x);
  for (std::size_t k = 0; k < program.times_s.size(); ++k) {
    std::vector<double> u(p.model.channels.size(), 0.0);
    u[0] = program.values_us[k][0];
    u[1] = program.values_us[k][1];
    p.schedule.times.push_back(program.times_s[k] + p.model.mechanisms.electromechanical_delay_s);
    p.schedule.values.push_back(u);
  }
  for (int i = 0; i <= static_cast<int>(program.duration_s * kRateHz); ++i) {
    p.times.push_back(i / kRateHz);
  }
  return p;
}

/// dq/dθ at every sample ([sample][c · P + k]) of `p` at `tolerance`, the state Jacobian formed
/// at every `every`-th step.
std::vector<std::vector<double>> Sensitivities(const SensitivityProblem& p, double tolerance,
                                               int every, sim::IntegrationStats* stats = nullptr) {
  const sim::UpperLimbModel limb(p.model);
  SimTK::State st = limb.MakeInitialState();
  std::vector<std::vector<double>> out;
  const auto s = sim::IntegrateTrialSensitivities(
      limb, {sim::IntegratorParams::Method::kCvodes, tolerance}, p.schedule, p.times, p.perturbed,
      &st, [&](double, const double*, const std::vector<double>& dq) { out.push_back(dq); }, every);
  if (stats) *stats = s;
  return out;
}

/// One 140 s data set with CVODES forward sensitivities to range(0) candidate parameters (the
/// first of CandidateParameters: A entries, k, β, γ, R scales) at tolerance 10^−range(1), the
/// state Jacobian formed every range(2)-th step: the unit cost of a Jacobian with
/// FullModelFitOptions::sensitivities (compare range(0) × BM_SimulateDataSet/4 for forward
/// differences; with residuals at 1e-4 the fit's iterations use tolerance 1e-2, its confidence
/// intervals 1e-3, both with the rigid-body part of ∂f/∂y every 16th step).
void BM_SensitivityDataSet(benchmark::State& state) {
  const SensitivityProblem p = MakeSensitivityProblem(static_cast<int>(state.range(0)));
  const double tol = std::pow(10.0, -static_cast<double>(state.range(1)));
  sim::IntegrationStats stats;
  for (auto _ : state) {
    benchmark::DoNotOptimize(Sensitivities(p, tol, static_cast<int>(state.range(2)), &stats));
  }
  state.counters["steps"] = static_cast<double>(stats.steps);
  state.counters["rhs"] = static_cast<double>(stats.rhs_evaluations);
  state.counters["jacobians"] = static_cast<double>(stats.jacobian_evaluations);
  // Accuracy on the three measured joints against tolerance 1e-7, state Jacobian at every step:
  // relative RMS error of the whole Jacobian and of its worst column.
  const auto ref = Sensitivities(p, 1e-7, 1);
  const auto got = Sensitivities(p, tol, static_cast<int>(state.range(2)));
  const std::size_t np = p.perturbed.size();
  double worst = 0.0, total_num = 0.0, total_den = 0.0;
  for (std::size_t k = 0; k < np; ++k) {
    double num = 0.0, den = 0.0;
    for (std::size_t i = 0; i < ref.size(); ++i) {
      for (int c : {sim::kWristFlexion, sim::kMcpFlexion, sim::kPipFlexion}) {
        const double e = got[i][c * np + k] - ref[i][c * np + k];
        num += e * e;
        den += ref[i][c * np + k] * ref[i][c * np + k];
      }
    }
    total_num += num;
    total_den += den;
    if (den > 0.0) worst = std::max(worst, std::sqrt(num / den));
  }
  state.counters["jacobian_rel_rms_err"] = std::sqrt(total_num / total_den);
  state.counters["worst_column_rel_rms_err"] = worst;
}
BENCHMARK(BM_SensitivityDataSet)
    ->Args({29, 4, 1})
    ->Args({29, 4, 4})
    ->Args({29, 3, 4})
    ->Args({29, 3, 8})
    ->Args({29, 3, 16})  // the confidence intervals' Jacobian with residuals at 1e-4
    ->Args({29, 2, 16})  // the iterations' Jacobians with residuals at 1e-4
    ->Args({6, 3, 16})   // cost against the parameter count (docs/performance.md, diagnose)
    ->Args({12, 3, 16})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);

/// The full-model fit: sensitivity ranking of all candidates, then `starts` local optimisations
/// of the 29 most influential, each capped at range(0) LM iterations; range(1) = 1: Broyden
/// secant Jacobian updates, 0: a Jacobian per accepted step; range(2) = 1: Jacobians from CVODES
/// forward sensitivities (the default), 0: forward differences (step 1e-2).
void BM_FullModelFit(benchmark::State& state) {
  const Study s = MakeStudy();
  fm::FullModelFitOptions o;
  o.keep_parameters = 29;
  o.starts = 1;
  o.max_iterations = static_cast<int>(state.range(0));
  o.integrator_tolerance = 1e-4;
  o.fd_relative_step = 1e-2;
  o.relative_tolerance = 1e-4;
  o.threads = 2;
  o.broyden = state.range(1) != 0;
  o.jacobian = state.range(2) != 0 ? fm::JacobianMethod::kSensitivities
                                   : fm::JacobianMethod::kForwardDifferences;
  fm::FullModelFit fit;
  for (auto _ : state) fit = fm::FitFullModel(s.rig, s.train, o);
  const auto& run = fit.runs.front();
  state.counters["candidates"] = static_cast<double>(fit.candidates.size());
  state.counters["fitted"] = static_cast<double>(fit.kept.size());
  state.counters["sensitivity_s"] = fit.sensitivity_wall_s;
  state.counters["local_step_s"] = run.wall_s;
  state.counters["local_step_cpu_s"] = run.cpu_s;
  state.counters["lm_iterations"] = run.iterations;
  state.counters["per_iteration_s"] = run.wall_s / std::max(1, run.iterations);
  state.counters["evaluations"] = run.evaluations;
  state.counters["fd_jacobians"] = run.jacobians;
  state.counters["converged"] = run.converged ? 1.0 : 0.0;
  state.counters["distinct_sims"] = fit.distinct_simulations;
  state.counters["cost"] = run.cost;
  state.SetLabel(run.stop_reason);
  state.counters["total_s"] = fit.total_wall_s;
  // Convergence trace of the local run: residual evaluations used → cost after that step.
  std::fprintf(stderr, "BM_FullModelFit/%d/%d/%d trace (evaluations:cost):", int(state.range(0)),
               int(state.range(1)), int(state.range(2)));
  for (std::size_t k = 0; k < run.cost_history.size(); ++k) {
    std::fprintf(stderr, " %d:%.5f", run.evaluations_history[k], run.cost_history[k]);
  }
  std::fprintf(stderr, "\n");
  // Fit measures of Table 1: normalised error, train (mean of the three sets) and validation.
  double start_ne = MeanNormalisedError(s.validation, fm::SimulateLike(s.rig, s.validation, 1e-6));
  state.counters["validation_ne_start"] = start_ne;
  state.counters["validation_ne"] =
      MeanNormalisedError(s.validation, fm::SimulateLike(fit.model, s.validation, 1e-6));
}
BENCHMARK(BM_FullModelFit)
    ->Args({50, 1, 0})  // forward differences with Broyden secant updates (opt-in)
    ->Args({50, 0, 0})  // a forward-difference Jacobian per accepted step
    ->Args({50, 0, 1})  // a sensitivity Jacobian per accepted step (the default)
    ->Args({50, 1, 1})  // sensitivity Jacobians with Broyden secant updates
    ->Unit(benchmark::kSecond)
    ->Iterations(1);

/// The Hammerstein two-step fit on the same three data sets (20 static + 3 dynamic starts);
/// range(0) = 0: exact sensitivities in the dynamic step (the default), 1: forward differences.
void BM_HammersteinTwoStep(benchmark::State& state) {
  const Study s = MakeStudy();
  std::vector<id::MimoTrialData> train;
  for (const auto& t : s.train) train.push_back(ToMimo(t));
  id::HammersteinMimoOptions o;
  o.dynamic_jacobian = state.range(0) != 0 ? id::DynamicJacobian::kForwardDifference
                                           : id::DynamicJacobian::kExactSensitivities;
  id::HammersteinMimoFit fit;
  for (auto _ : state) fit = id::FitHammersteinMimo(train, o);
  const auto mean = [](const auto& v) {
    double sum = 0.0;
    for (double x : v) sum += x;
    return sum / static_cast<double>(std::max<std::size_t>(1, v.size()));
  };
  state.counters["static_step_ms"] = 1e3 * mean(fit.static_step_wall_s);
  state.counters["dynamic_step_ms"] = 1e3 * mean(fit.dynamic_step_wall_s);
  state.counters["static_step_cpu_ms"] = 1e3 * mean(fit.static_step_cpu_s);
  state.counters["dynamic_step_cpu_ms"] = 1e3 * mean(fit.dynamic_step_cpu_s);
  state.counters["static_step_iterations"] = mean(fit.static_step_iterations);
  state.counters["dynamic_step_iterations"] = mean(fit.dynamic_step_iterations);
  state.counters["dynamic_step_simulations"] = mean(fit.dynamic_step_evaluations);
  state.counters["dynamic_cost"] = fit.dynamic_cost;
  state.counters["omega_rad_s"] = fit.params.omega_rad_s;  // Θ, to compare fits across changes
  for (Eigen::Index i = 0; i < fit.params.mu_s.size(); ++i) {
    state.counters["mu_" + std::to_string(i) + "_s"] = fit.params.mu_s(i);
  }
  state.counters["total_ms"] = 1e3 * fit.total_wall_s;
  const id::MimoTrialData v = ToMimo(s.validation);
  const Eigen::MatrixXd yh = id::SimulateHammersteinMimo(fit.params, v.u_us, v.sample_period_s);
  double ne = 0.0;
  for (int i = 0; i < 3; ++i) {
    const std::vector<double> y(v.y_rad.col(i).data(), v.y_rad.col(i).data() + v.y_rad.rows());
    const std::vector<double> h(yh.col(i).data(), yh.col(i).data() + yh.rows());
    ne += id::NormalisedError(y, h) / 3.0;
  }
  state.counters["validation_ne"] = ne;
}
BENCHMARK(BM_HammersteinTwoStep)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
