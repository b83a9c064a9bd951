// Issue 8 benchmark: the full `fesim render` frame pipeline on the default participant — set the
// pose from a trial row (Simbody realise to Position), build the scene (apps/arm_scene.h: 7
// capsules, 14 muscle paths, 24 pads, overlay with 6 channels and 10 joint angles) and render it at
// 1280×720 — and the scene build alone. Wall-clock rates (UseRealTime): llvmpipe renders on its
// own threads.
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "apps/arm_scene.h"
#include "render/renderer.h"
#include "sim/default_model.h"

namespace fesim {
namespace {

constexpr int kRows = 300;  ///< trial rows (10 s at 30 fps), cycled.

/// A trial swinging the elbow 20°–100° and the wrist ±30°, with stimulation and activations.
Trial SwingTrial(const sim::UpperLimbModel& model) {
  Trial t;
  std::vector<double> elbow(kRows), wrist(kRows), u(kRows), a(kRows);
  for (int i = 0; i < kRows; ++i) {
    const double s = i / 30.0;
    t.time.push_back(s);
    elbow[i] = (60 + 40 * std::sin(2 * s)) * 3.14159265358979323846 / 180;
    wrist[i] = 0.5 * std::sin(3 * s);
    u[i] = 150 + 150 * std::sin(3 * s);
    a[i] = 0.5 + 0.5 * std::sin(2 * s);
  }
  t.AddColumn("q.elbow_flexion", elbow);
  t.AddColumn("q.wrist_flexion", wrist);
  t.AddColumn("u.ext", u);
  t.AddColumn("a.BIC", a);
  return t;
}

struct Fixture {
  Fixture() : model(sim::DefaultModelParams()), trial(SwingTrial(model)) {
    pose = FindPoseColumns(trial, "bench");
    state = model.MakeInitialState();
  }
  /// Poses row i and returns its scene.
  render::Scene Scene(int i) {
    const auto row = static_cast<std::size_t>(i % kRows);
    SetPoseFromTrialRow(model, trial, pose, row, &state);
    ArmSceneInputs in;
    in.time_s = trial.time[row];
    in.stimulation_us.assign(model.num_channels(), 0.0);
    in.stimulation_us[0] = trial.Column("u.ext")[row];
    in.activation.assign(model.num_muscles(), trial.Column("a.BIC")[row]);
    return ArmScene(model, state, in);
  }
  sim::UpperLimbModel model;
  Trial trial;
  PoseColumns pose;
  SimTK::State state;
};

void BM_ArmSceneBuild(benchmark::State& st) {
  Fixture f;
  int i = 0;
  for (auto _ : st) {
    render::Scene scene = f.Scene(i++);
    benchmark::DoNotOptimize(scene.polylines.data());
  }
}
BENCHMARK(BM_ArmSceneBuild);

void BM_ArmSceneRenderFrame(benchmark::State& st) {
  const int width = static_cast<int>(st.range(0));
  const int height = static_cast<int>(st.range(1));
  Fixture f;
  render::OffscreenRenderer renderer(width, height);
  render::Camera camera;
  camera.target = ArmCameraTarget(f.model, f.state);
  camera.distance_m = 1.3;
  render::Image image;
  int i = 0;
  for (auto _ : st) {
    renderer.Render(f.Scene(i++), camera, &image);
    benchmark::DoNotOptimize(image.rgb.data());
  }
  st.counters["fps"] =
      benchmark::Counter(static_cast<double>(st.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ArmSceneRenderFrame)->Args({1280, 720})->UseRealTime();

}  // namespace
}  // namespace fesim

BENCHMARK_MAIN();
