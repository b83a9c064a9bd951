// Issue 7 benchmark: `fesim diagnose` on three 60 s hand-rig trials with three outputs (wrist,
// MCP, PIP), clean and with a planted effect, 2 simulation threads; and the cost of the unit it
// is built from, one SimulateLike of a 60 s trial. Figures go to docs/performance.md.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "diagnosis/diagnose.h"
#include "diagnosis/planted.h"
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

void BM_SimulateLike60s(benchmark::State& state) {
  const auto data = Data("");
  for (auto _ : state) {
    benchmark::DoNotOptimize(fesim::identification::fullmodel::SimulateLike(
        Rig().model, data.trials[0], std::pow(10.0, -state.range(0))));
  }
}
// Argument: −log10 of the integrator tolerance.
BENCHMARK(BM_SimulateLike60s)->Arg(4)->Arg(5)->Arg(6)->Unit(benchmark::kMillisecond)->UseRealTime();

void Diagnose(benchmark::State& state, const std::string& mechanism) {
  const auto data = Data(mechanism);
  fesim::diagnosis::DiagnoseOptions o;
  o.fit.threads = 2;
  int simulations = 0;
  // FESIM_BENCH_STAGES=1: the diagnosis' stages with their start times on stderr (breakdown).
  const bool stages = std::getenv("FESIM_BENCH_STAGES") != nullptr;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto d = fesim::diagnosis::Diagnose(
        Rig().model, data.trials, o, [&](double f, const std::string& stage) {
          if (!stages) return;
          std::fprintf(stderr, "  %7.1f s %3.0f %% %s\n",
                       std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                       100 * f, stage.c_str());
        });
    simulations = d.simulations;
    state.SetLabel("cause " + d.cause);
  }
  state.counters["simulations"] = simulations;
}
void BM_DiagnoseClean3x60s(benchmark::State& state) { Diagnose(state, ""); }
void BM_DiagnoseTremor3x60s(benchmark::State& state) { Diagnose(state, "tremor"); }
void BM_DiagnoseFatigue3x60s(benchmark::State& state) { Diagnose(state, "fatigue"); }
BENCHMARK(BM_DiagnoseClean3x60s)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_DiagnoseTremor3x60s)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_DiagnoseFatigue3x60s)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
