// Issue 28: `fesim identify --method tremor-arx` on one long 100 Hz trial (the method entry the
// command calls, default options: orders 12/7/1, tremor frequency estimated), and the summed
// periodogram of its frequency search alone. Targets: 10 min ≤ 2 s, 3 h ≤ 60 s.
// Data: the planted wrist model of tests/identification/tremor_arx_test.cc (double pole at 0.8,
// 5 Hz tremor) driven by a 0.2–4 Hz multisine, 0.002 rad equation noise, fixed seed.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "identification/spectrum.h"
#include "identification/tremor_arx.h"

namespace fesim::identification {
namespace {

constexpr double kT = 0.01;  // s (100 Hz)
constexpr double kTwoPi = 6.283185307179586;

TremorModel Planted() {
  TremorModel m;
  m.orders = {2, 1, 1, 3};
  m.u_scale_us = 200.0;
  m.beta = Eigen::Vector4d(0.1, 0.5, 0.1, 0.3);
  m.a = Eigen::Vector2d(-1.6, 0.64);
  m.b = Eigen::Vector2d(0.6, 0.4) * 0.04;
  m.lambda1 = 0.02;
  m.lambda2 = -0.01;
  m.tremor_hz = 5.0;
  m.sample_period_s = kT;
  return m;
}

/// A trial of `seconds` with columns u.fcr, u.ecr (co-activation 30 / 45 µs) and q.wrist.
Trial LongTrial(double seconds) {
  const TremorModel m = Planted();
  const auto n = static_cast<Eigen::Index>(std::lround(seconds / kT));
  std::mt19937 rng(28);
  std::uniform_real_distribution<double> phase(0.0, kTwoPi);
  std::normal_distribution<double> noise(0.0, 0.002);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(n), y = Eigen::VectorXd::Zero(n);
  for (double f : {0.2, 0.5, 0.9, 1.4, 2.1, 3.0, 4.0}) {
    const double p = phase(rng);
    for (Eigen::Index k = 0; k < n; ++k) {
      u(k) += 200.0 / 7.0 * std::sin(kTwoPi * f * static_cast<double>(k) * kT + p);
    }
  }
  const double w = kTwoPi * m.tremor_hz * kT;
  for (Eigen::Index k = 2; k < n; ++k) {
    double v = m.lambda1 * std::cos(w * k) + m.lambda2 * std::sin(w * k) + noise(rng);
    v -= m.a(0) * y(k - 1) + m.a(1) * y(k - 2);
    v += m.b(0) * TremorRecruitment(m, u(k - 1)) + m.b(1) * TremorRecruitment(m, u(k - 2));
    y(k) = v;
  }
  const Coactivation c{30.0, 45.0};
  Trial t;
  std::vector<double> fcr, ecr;
  for (Eigen::Index k = 0; k < n; ++k) {
    t.time.push_back(kT * static_cast<double>(k));
    const Eigen::Vector2d s = CoactivationSplit(c, u(k));
    fcr.push_back(s(0));
    ecr.push_back(s(1));
  }
  t.AddColumn("u.fcr", fcr);
  t.AddColumn("u.ecr", ecr);
  t.AddColumn("q.wrist", std::vector<double>(y.data(), y.data() + n));
  return t;
}

void BM_TremorArxIdentify(benchmark::State& state) {
  const Trial t = LongTrial(static_cast<double>(state.range(0)));
  const MethodEntry method = TremorArxMethod();
  for (auto _ : state) {
    const MethodResult r = method.run({t}, {}, nullptr);
    benchmark::DoNotOptimize(r.model_yaml.data());
  }
  state.counters["samples"] = static_cast<double>(t.size());
}
// 10 minutes and 3 hours at 100 Hz.
BENCHMARK(BM_TremorArxIdentify)->Arg(600)->Arg(10800)->Unit(benchmark::kSecond)->Iterations(1);

void BM_SummedPeriodogram(benchmark::State& state) {
  const Trial t = LongTrial(static_cast<double>(state.range(0)));
  const std::vector<double>& q = t.Column("q.wrist");
  const std::vector<Eigen::VectorXd> signals = {
      Eigen::Map<const Eigen::VectorXd>(q.data(), static_cast<Eigen::Index>(q.size()))};
  for (auto _ : state) {
    const Periodogram p = SummedPeriodogram(signals, kT, 3.0, 12.0);
    benchmark::DoNotOptimize(p.power.data());
  }
  state.counters["samples"] = static_cast<double>(q.size());
}
BENCHMARK(BM_SummedPeriodogram)->Arg(600)->Arg(10800)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace fesim::identification

BENCHMARK_MAIN();
