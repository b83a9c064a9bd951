// `fesim diagnose` on three 60 s hand-rig trials with three outputs (wrist, MCP, PIP) of a person
// the model has never seen (the independent simulator, foreign/dataset.h: steps, grid, steps),
// clean and with a planted effect, 2 simulation threads, calibration and black box included; and
// the cost of the unit it is built from, one SimulateLike of a 60 s trial. Figures go to
// docs/performance.md.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "diagnosis/diagnose.h"
#include "diagnosis/planted.h"
#include "diagnosis/report.h"
#include "foreign/dataset.h"
#include "identification/fullmodel/full_model_fit.h"
#include "scenarios/scenario.h"

namespace {

const fesim::Scenario& Rig() {
  static const fesim::Scenario rig =
      fesim::LoadScenario(std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/hand_rig.yaml");
  return rig;
}

fesim::diagnosis::PlantedDataset Data(const std::string& mechanism) {
  fesim::diagnosis::PlantedSpec spec;
  if (!mechanism.empty()) spec.mechanisms = {mechanism};
  spec.effect_scale = 1.5;
  spec.trials = 3;
  spec.duration_s = 60.0;
  spec.seed = 7;
  return fesim::diagnosis::MakePlantedDataset(Rig(), spec);
}

// One 60 s trial of the benchmark's data set simulated like a diagnosis does, at tolerance
// 10^−range(0) and speed time scale range(1) ms (sim::IntegratorParams::speed_time_scale_s; 0:
// speeds held to the angles' absolute tolerance). Counter: the largest q error against the same
// simulation at tolerance 1e-9 (rad). `simbody_rhs`: sim::IntegratorParams::
// simbody_right_hand_side (the diagnosis uses the articulated-body one, diagnosis::FitOptions).
void SimulateLike(benchmark::State& state, const fesim::sim::ModelParams& model,
                  bool simbody_rhs = true) {
  const auto data = Data("");
  fesim::sim::IntegratorParams integrator;
  integrator.simbody_right_hand_side = simbody_rhs;
  integrator.tolerance = std::pow(10.0, -static_cast<double>(state.range(0)));
  integrator.speed_time_scale_s = 1e-3 * static_cast<double>(state.range(1));
  fesim::Trial out;
  for (auto _ : state) {
    out = fesim::identification::fullmodel::SimulateLike(model, data.trials[0], integrator);
  }
  const auto ref = fesim::identification::fullmodel::SimulateLike(model, data.trials[0], 1e-9);
  double worst = 0.0;
  for (const auto& name : ref.NamesWithPrefix("q.")) {
    const auto& a = ref.Column(name);
    const auto& b = out.Column(name);
    for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(a[i] - b[i]));
  }
  state.counters["max_q_error_rad"] = worst;
}
void BM_SimulateLike60s(benchmark::State& state) { SimulateLike(state, Rig().model); }
// The same with the articulated-body right-hand side (UpperLimbModel::CalcYDot).
void BM_SimulateLike60sChainRhs(benchmark::State& state) {
  SimulateLike(state, Rig().model, false);
}
// The same with the wrist tremor that BM_DiagnoseTremor3x60s's fits put in the model
// (0.12 N·m at 5.35 Hz): the oscillation limits the step size.
void BM_SimulateLikeTremor60s(benchmark::State& state) {
  fesim::sim::ModelParams model = Rig().model;
  model.mechanisms.tremor.enabled = true;
  model.mechanisms.tremor.coordinate = fesim::sim::kWristFlexion;
  model.mechanisms.tremor.amplitude_nm = 0.12;
  model.mechanisms.tremor.frequency_hz = 5.35;
  SimulateLike(state, model);
}
BENCHMARK(BM_SimulateLike60s)
    ->ArgsProduct({{4, 5, 6}, {0, 100}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_SimulateLikeTremor60s)
    ->ArgsProduct({{4, 5, 6}, {0, 100}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_SimulateLike60sChainRhs)->Args({4, 0})->Unit(benchmark::kMillisecond)->UseRealTime();

/// The benchmark's data: foreign person 7, three 60 s trials, `effect` at the noise RMS.
fesim::foreign::Dataset ForeignData(const std::string& effect) {
  fesim::foreign::DatasetSpec spec;
  spec.person_seed = 7;
  spec.seed = 7;
  if (!effect.empty()) spec.effects = {{effect, 1.0}};
  return fesim::foreign::MakeDataset(spec);
}

// `simbody_rhs`: diagnosis::FitOptions::simbody_right_hand_side (false, the default: the
// articulated-body right-hand side; true: Simbody's, for the side-by-side figure).
void Diagnose(benchmark::State& state, const std::string& mechanism, bool simbody_rhs = false) {
  const auto data = ForeignData(mechanism);
  fesim::diagnosis::DiagnoseSettings settings;
  settings.fit.simbody_right_hand_side = simbody_rhs;
  fesim::diagnosis::DiagnoseExecution e;
  e.threads = 2;
  int simulations = 0;
  // FESIM_BENCH_STAGES=1: the diagnosis' stages with their start times on stderr (breakdown).
  const bool stages = std::getenv("FESIM_BENCH_STAGES") != nullptr;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    e.progress = [&](double f, const std::string& stage) {
      if (!stages) return;
      std::fprintf(stderr, "  %7.1f s %3.0f %% %s\n",
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                   100 * f, stage.c_str());
    };
    const auto d = fesim::diagnosis::Diagnose(Rig().model, data.trials, settings, e);
    simulations = d.simulations;
    if (stages) {
      for (const auto& cr : d.candidates) {
        if (!cr.applicable) continue;
        std::fprintf(stderr, "    %s\n", fesim::diagnosis::CandidateLogLine(cr).c_str());
      }
    }
    state.SetLabel("cause " + d.cause);
    state.counters["baseline_nrmse"] = d.baseline_heldout_nrmse;
    state.counters["blackbox_nrmse"] = d.reference.heldout_nrmse;
  }
  state.counters["simulations"] = simulations;
}
void BM_DiagnoseClean3x60s(benchmark::State& state) { Diagnose(state, ""); }
void BM_DiagnoseTremor3x60s(benchmark::State& state) { Diagnose(state, "tremor"); }
void BM_DiagnoseFatigue3x60s(benchmark::State& state) { Diagnose(state, "fatigue"); }
BENCHMARK(BM_DiagnoseClean3x60s)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_DiagnoseTremor3x60s)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_DiagnoseFatigue3x60s)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);
void BM_DiagnoseClean3x60sSimbodyRhs(benchmark::State& state) { Diagnose(state, "", true); }
void BM_DiagnoseTremor3x60sSimbodyRhs(benchmark::State& state) { Diagnose(state, "tremor", true); }
void BM_DiagnoseFatigue3x60sSimbodyRhs(benchmark::State& state) {
  Diagnose(state, "fatigue", true);
}
BENCHMARK(BM_DiagnoseClean3x60sSimbodyRhs)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_DiagnoseTremor3x60sSimbodyRhs)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_DiagnoseFatigue3x60sSimbodyRhs)
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
