// Issue 5 benchmarks: shoulder EKF update cost per sample ([Spagnol 2013] §IV) and GP /
// semiparametric GP training and leave-one-trajectory-out CV time on a 54-trajectory reaching set
// shaped like [Schearer 2014] §II-A (2 homes × 9 targets × 3 repeats, 4 joints, 5 s per trajectory
// at 50 Hz). Results and the command are in docs/performance.md.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "identification/ekf.h"
#include "identification/inverse_dynamics.h"

namespace fesim::identification {
namespace {

constexpr double kEkfDt = 0.001;   // s: 1 kHz sensor rate
constexpr double kReachDt = 0.02;  // s: 50 Hz reaching samples
constexpr unsigned kSeed = 54;

void BM_ShoulderEkfStep(benchmark::State& state) {
  ShoulderEkfConfig cfg;
  cfg.friction_c = 0.1;
  ShoulderEkf ekf(cfg, 0.0, 0.0);
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> e(0.0, 0.01);
  double t = 0.0;
  for (auto _ : state) {
    const double sa = std::fmod(t, 4.0) < 1.0 ? 0.6 : 0.0;
    const double sp = std::fmod(t, 4.0) >= 2.0 && std::fmod(t, 4.0) < 3.0 ? 0.5 : 0.0;
    ekf.Update(0.1 * std::sin(t) + e(rng), 0.1 * std::cos(t) + e(rng));
    ekf.Predict(sa, sp, 0.1 * std::cos(t), kEkfDt);
    benchmark::DoNotOptimize(ekf.state());
    t += kEkfDt;
  }
  state.SetItemsProcessed(state.iterations());
  // Time per sample versus the 1 ms sensor period: real-time margin = 1 ms / (time per sample).
  state.counters["realtime_margin_at_1kHz"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * kEkfDt, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ShoulderEkfStep);

/// 54 reaching trials, 4 joints: passive stiffness/damping + a nonlinear coupling + noise.
ReachingData ReachingSet54() {
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> e(0.0, 0.02);
  const std::vector<std::string> names = {"elevation_plane", "shoulder_elevation",
                                          "shoulder_rotation", "elbow_flexion"};
  std::vector<Trial> trials;
  const Eigen::Vector4d homes[2] = {{0.3, 0.6, 0.2, 1.6}, {0.6, 0.4, 0.1, 0.9}};
  for (int h = 0; h < 2; ++h) {
    for (int target = 0; target < 9; ++target) {
      const int row = target / 3;  // 3 × 3 grid of targets
      const int col = target % 3;
      const Eigen::Vector4d goal(0.1 + 0.3 * col, 0.3 + 0.25 * row, 0.3, 0.8 + 0.1 * target);
      for (int r = 0; r < 3; ++r) {
        Trial t;
        t.metadata["trajectory"] = std::to_string(h) + "-" + std::to_string(target);
        std::vector<std::vector<double>> q(4), qd(4), qdd(4), tau(4);
        for (double time = 0.0; time < 5.0 - 1e-9; time += kReachDt) {
          double tau_n = 0.0, s = 0.0, sd = 0.0, sdd = 0.0, dir = 1.0;
          if (time < 2.0 || time >= 3.0) {
            tau_n = time < 2.0 ? time / 2.0 : (time - 3.0) / 2.0;
            const double t2 = tau_n * tau_n, t3 = t2 * tau_n;
            s = 10 * t3 - 15 * t3 * tau_n + 6 * t3 * t2;
            sd = (30 * t2 - 60 * t3 + 30 * t3 * tau_n) / 2.0;
            sdd = (60 * tau_n - 180 * t2 + 120 * t3) / 4.0;
            if (time >= 3.0) s = 1.0 - s, dir = -1.0;
          } else {
            s = 1.0;
          }
          t.time.push_back(time);
          const Eigen::Vector4d qv = homes[h] + s * (goal - homes[h]);
          const Eigen::Vector4d qdv = dir * sd * (goal - homes[h]);
          for (int j = 0; j < 4; ++j) {
            q[j].push_back(qv(j));
            qd[j].push_back(qdv(j));
            qdd[j].push_back(dir * sdd * (goal(j) - homes[h](j)));
            // Stiffness/damping ([Schearer 2014] eq. 3) plus a coupling the parametric model lacks.
            tau[j].push_back(1.5 * (qv(j) - 0.5) + 0.3 * qdv(j) +
                             0.3 * std::sin(2.0 * qv((j + 1) % 4)) + e(rng));
          }
        }
        for (int j = 0; j < 4; ++j) {
          t.AddColumn("q." + names[j], q[j]);
          t.AddColumn("qd." + names[j], qd[j]);
          t.AddColumn("qdd." + names[j], qdd[j]);
          t.AddColumn("tau." + names[j], tau[j]);
        }
        trials.push_back(std::move(t));
      }
    }
  }
  return ExtractReachingData(trials);
}

void BM_InvDynTrain(benchmark::State& state) {
  const auto kind = static_cast<InvDynKind>(state.range(0));
  const ReachingData data = ReachingSet54();
  InvDynOptions opt;
  opt.max_training_points = static_cast<std::size_t>(state.range(1));
  for (auto _ : state) {
    const auto m = FitInvDyn(kind, data.joints, data.X, data.tau, opt);
    benchmark::DoNotOptimize(m.hyper.data());
  }
  state.counters["samples"] = static_cast<double>(data.X.rows());
  state.counters["gp_points"] = static_cast<double>(opt.max_training_points);
}

void BM_InvDynLoocv(benchmark::State& state) {
  const auto kind = static_cast<InvDynKind>(state.range(0));
  const ReachingData data = ReachingSet54();
  InvDynOptions opt;
  opt.max_training_points = static_cast<std::size_t>(state.range(1));
  const auto full = FitInvDyn(kind, data.joints, data.X, data.tau, opt);
  for (auto _ : state) {
    const auto cv = LeaveOneTrajectoryOut(kind, data, opt, full);
    benchmark::DoNotOptimize(cv.nrmse.data());
  }
  state.counters["folds"] = static_cast<double>(data.group_names.size());
}

// Args: {kind (0 parametric, 1 GP, 2 semiparametric), GP training points}.
BENCHMARK(BM_InvDynTrain)
    ->Args({0, 600})
    ->Args({1, 300})
    ->Args({1, 600})
    ->Args({2, 600})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK(BM_InvDynLoocv)
    ->Args({0, 600})
    ->Args({1, 600})
    ->Args({2, 600})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
}  // namespace fesim::identification

BENCHMARK_MAIN();
