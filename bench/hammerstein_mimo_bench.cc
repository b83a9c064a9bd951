// Issue 4: wall time per local optimisation step and in total of the two-step Hammerstein fit of
// [Hand Hammerstein] §4 (Table 2 reports 0.178 s per local step in MATLAB). Data: the step-grid
// protocol of §5.1 (n = 2 inputs, 50 µs grid over u1 + u2 ≤ 300, 5 s steps, both traversals, 40 Hz,
// q = 3 joints, l = 2), generated noise-free by the model itself with 0.3° of angle noise added.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "identification/hammerstein_mimo.h"

namespace fesim::identification {
namespace {

constexpr double kT = 0.025;

HammersteinMimoParams Planted() {
  HammersteinMimoParams p;
  CutoffParams a, b;
  a.u_db_us = Eigen::Vector2d(60.0, 200.0);
  a.u_sat_us = 180.0;
  b.u_db_us = Eigen::Vector2d(220.0, 80.0);
  b.u_sat_us = 400.0;
  p.psi = {a, b};
  p.d_rad.resize(3, 2);
  p.d_rad << 0.8, -0.5, 0.3, 0.6, -0.4, 0.9;
  p.omega_rad_s = 4.0;
  p.mu_s = Eigen::Vector3d(0.15, 0.3, 0.2);
  p.rest_rad = Eigen::Vector3d(0.1, 0.5, 0.3);
  return p;
}

std::vector<MimoTrialData> Trials() {
  std::mt19937 rng(5);
  std::normal_distribution<double> e(0.0, 0.005);
  std::vector<MimoTrialData> out;
  for (bool tr : {false, true}) {
    std::vector<Eigen::Vector2d> pts;
    for (int i = 0; i <= 6; ++i) {
      for (int jj = 0; jj <= 6 - i; ++jj) {
        const int j = (i % 2 == 0) ? jj : 6 - i - jj;
        pts.emplace_back(tr ? 50.0 * j : 50.0 * i, tr ? 50.0 * i : 50.0 * j);
      }
    }
    const int per = 200;  // 5 s at 40 Hz
    MimoTrialData d;
    d.sample_period_s = kT;
    d.u_us.resize(static_cast<Eigen::Index>(pts.size()) * per, 2);
    for (std::size_t s = 0; s < pts.size(); ++s) {
      d.u_us.middleRows(static_cast<Eigen::Index>(s) * per, per).rowwise() = pts[s].transpose();
    }
    d.y_rad = SimulateHammersteinMimo(Planted(), d.u_us, kT);
    for (Eigen::Index k = 0; k < d.y_rad.size(); ++k) d.y_rad.data()[k] += e(rng);
    out.push_back(d);
  }
  return out;
}

void BM_StaticLocalStep(benchmark::State& state) {
  const auto trials = Trials();
  const SteadyStateSet set = ExtractSteadyState(trials, 1.0, 0.2);
  HammersteinMimoOptions o;
  o.starts = 1;
  unsigned seed = 1;
  double iters = 0, steps = 0;
  for (auto _ : state) {
    o.seed = seed++;  // a different start point each step, as in the multi-start search
    const auto fit = FitHammersteinStatic(set, Planted().rest_rad, o);
    iters += fit.static_step_iterations[0];
    steps += 1;
    benchmark::DoNotOptimize(fit.static_cost);
  }
  state.counters["lm_iterations_per_step"] = iters / steps;
  state.counters["steady_state_points"] = static_cast<double>(set.u_us.rows());
}
BENCHMARK(BM_StaticLocalStep)->Unit(benchmark::kMillisecond);

/// range(0) = 0: exact sensitivities (the default), 1: forward-difference Jacobian.
void BM_DynamicLocalStep(benchmark::State& state) {
  const auto trials = Trials();
  const SteadyStateSet set = ExtractSteadyState(trials, 1.0, 0.2);
  HammersteinMimoOptions o;
  const HammersteinMimoFit stat = FitHammersteinStatic(set, Planted().rest_rad, o);
  o.dynamic_starts = 1;
  o.dynamic_jacobian = state.range(0) != 0 ? DynamicJacobian::kForwardDifference
                                           : DynamicJacobian::kExactSensitivities;
  double iters = 0, sims = 0, steps = 0, lm_cpu_s = 0;
  for (auto _ : state) {
    HammersteinMimoFit fit = stat;
    FitHammersteinDynamic(trials, o, &fit);
    iters += fit.dynamic_step_iterations[0];
    sims += fit.dynamic_step_evaluations[0];
    lm_cpu_s += fit.dynamic_step_cpu_s[0];
    steps += 1;
    benchmark::DoNotOptimize(fit.dynamic_cost);
  }
  state.counters["lm_iterations_per_step"] = iters / steps;
  state.counters["simulations_per_step"] = sims / steps;
  // The LM run alone (the fit's dynamic_step_cpu_s, as BM_HammersteinTwoStep reports it); the
  // benchmark's own time also holds the set-up of the dynamic problem (ẑ, records).
  state.counters["lm_cpu_ms"] = 1e3 * lm_cpu_s / steps;
  state.counters["samples"] = static_cast<double>(trials[0].u_us.rows() * 2);
}
BENCHMARK(BM_DynamicLocalStep)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_TwoStepTotal(benchmark::State& state) {
  const auto trials = Trials();
  const HammersteinMimoOptions o;  // 20 static starts + 3 dynamic starts
  for (auto _ : state) {
    const auto fit = FitHammersteinMimo(trials, o);
    benchmark::DoNotOptimize(fit.dynamic_cost);
  }
}
BENCHMARK(BM_TwoStepTotal)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace fesim::identification

BENCHMARK_MAIN();
