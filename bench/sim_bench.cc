// Real-time factor of the default model (issue 2): the default scenario's participant and arm
// support, every coordinate as the scenario says (all free), every channel stimulated with steps
// that change every 2 s, a 60 s trial, CVODES BDF at tolerance 1e-6, one core; and the same trial
// at the work–precision tolerances 3e-3 (≤ 0.1° RMS) and 3e-4 (≤ 0.01° RMS, the default), each
// with the articulated-body right-hand side (UpperLimbModel::CalcYDot, the default) and with
// Simbody's realisation (IntegratorParams::simbody_right_hand_side) in the same run.
#include <benchmark/benchmark.h>

#include <vector>

#include "bench/default_trial.h"
#include "scenarios/scenario.h"
#include "sim/chain_dynamics.h"
#include "sim/trial_runner.h"
#include "sim/upper_limb_model.h"

namespace {

fesim::Scenario DefaultScenario() {
  fesim::Scenario sc = fesim::bench::DefaultModelTrial(60.0);
  sc.trial.integrator.tolerance = 1e-6;
  return sc;
}

void BM_DefaultModel60s(benchmark::State& state) {
  const fesim::Scenario sc = DefaultScenario();
  const fesim::sim::UpperLimbModel model(sc.model);
  fesim::sim::IntegrationStats stats;
  for (auto _ : state) {
    const auto r = fesim::sim::RunTrial(model, sc.trial);
    stats = r.stats;
    benchmark::DoNotOptimize(r.truth.time.data());
  }
  state.counters["real_time_factor"] = benchmark::Counter(
      sc.trial.duration_s * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["steps"] = static_cast<double>(stats.steps);
  state.counters["rhs_evals"] = static_cast<double>(stats.rhs_evaluations);
  state.counters["jacobians"] = static_cast<double>(stats.jacobian_evaluations);
}
BENCHMARK(BM_DefaultModel60s)->Unit(benchmark::kMillisecond)->UseRealTime();

// The same trial at the tolerances of the work–precision table that meet 0.1° RMS (3e-3) and
// 0.01° RMS (3e-4, trial generation's default); CPU time of the thread, model build included.
void BM_DefaultModel60sAtTolerance(benchmark::State& state, double tolerance, bool simbody_rhs) {
  fesim::Scenario sc = fesim::bench::DefaultModelTrial(60.0);
  sc.trial.integrator.tolerance = tolerance;
  sc.trial.integrator.simbody_right_hand_side = simbody_rhs;
  fesim::sim::IntegrationStats stats;
  for (auto _ : state) {
    const fesim::sim::UpperLimbModel model(sc.model);
    const auto r = fesim::sim::RunTrial(model, sc.trial);
    stats = r.stats;
    benchmark::DoNotOptimize(r.truth.time.data());
  }
  state.counters["steps"] = static_cast<double>(stats.steps);
  state.counters["rhs_evals"] = static_cast<double>(stats.rhs_evaluations);
  state.counters["jacobians"] = static_cast<double>(stats.jacobian_evaluations);
}
// Unformatted: clang-format would space the names (tol_3e - 3).
// The same trial recording only q at 100 Hz (bench::SimulateCoordinates), model build included.
void BM_DefaultModel60sCoordinates(benchmark::State& state, double tolerance) {
  fesim::Scenario sc = fesim::bench::DefaultModelTrial(60.0);
  sc.trial.integrator.tolerance = tolerance;
  fesim::sim::IntegrationStats stats;
  std::vector<double> q;
  for (auto _ : state) {
    const fesim::sim::UpperLimbModel model(sc.model);
    stats = fesim::bench::SimulateCoordinates(model, sc, sc.trial.integrator, 100.0, &q);
    benchmark::DoNotOptimize(q.data());
  }
  state.counters["steps"] = static_cast<double>(stats.steps);
  state.counters["rhs_evals"] = static_cast<double>(stats.rhs_evaluations);
}

// clang-format off
BENCHMARK_CAPTURE(BM_DefaultModel60sAtTolerance, tol_3e-3, 3e-3, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DefaultModel60sAtTolerance, tol_3e-4, 3e-4, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DefaultModel60sAtTolerance, tol_3e-3_simbody, 3e-3, true)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DefaultModel60sAtTolerance, tol_3e-4_simbody, 3e-4, true)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DefaultModel60sCoordinates, tol_3e-3, 3e-3)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
BENCHMARK_CAPTURE(BM_DefaultModel60sCoordinates, tol_3e-4, 3e-4)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
// clang-format on

// One right-hand-side evaluation from scratch (new time and state): Simbody's realisation to
// Acceleration, or UpperLimbModel::CalcYDot.
void BM_RightHandSide(benchmark::State& state, bool simbody) {
  const fesim::Scenario sc = DefaultScenario();
  const fesim::sim::UpperLimbModel model(sc.model);
  SimTK::State s = model.MakeInitialState();
  model.SetStimulation(s, {150, 100, 120, 80, 60, 40});
  const SimTK::Vector y = s.getY();
  fesim::sim::RhsWorkspace ws;
  std::vector<double> ydot(static_cast<std::size_t>(s.getNY()));
  double t = 0.0;
  for (auto _ : state) {
    s.updY() = y;
    s.setTime(t += 1e-6);
    if (simbody) {
      model.system().realize(s, SimTK::Stage::Acceleration);
      benchmark::DoNotOptimize(s.getYDot()[0]);
    } else {
      ws.ForgetPositions();  // from scratch: the positions' terms too
      model.CalcYDot(s, &ws, ydot.data());
      benchmark::DoNotOptimize(ydot[0]);
    }
  }
}
BENCHMARK_CAPTURE(BM_RightHandSide, chain, false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_RightHandSide, simbody, true)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
