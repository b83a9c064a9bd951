// Issue 8 benchmark: frames per second of the off-screen renderer at 1280×720 (OSMesa/llvmpipe)
// for the demo arm (12 capsules, 14 polylines, 24 pads, overlay), render only and render + encode.
// Wall-clock rates (UseRealTime): llvmpipe renders on its own threads and ffmpeg encodes in a
// separate process, so CPU time of the calling thread would flatter both.
#include <benchmark/benchmark.h>
#include <stdlib.h>  // NOLINT(modernize-deprecated-headers): POSIX mkdtemp(), not in <cstdlib>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "render/demo_scene.h"
#include "render/renderer.h"
#include "render/video.h"

namespace fesim::render {
namespace {

constexpr int kClipFrames = 60;  ///< frames per encoded clip (2 s at 30 fps).

/// The demo arm at frame i of a 30 fps clip, elbow swinging 20°–100°.
Scene Frame(int i) {
  DemoArmOptions options;
  options.time_s = i / 30.0;
  options.elbow_flexion_deg = 60 + 40 * std::sin(options.time_s * 2.0);
  options.pulse_width_us = 150 + 150 * std::sin(options.time_s * 3.0);
  return DemoArmScene(options);
}

std::string TempDirectory() {
  std::string pattern =
      (std::filesystem::temp_directory_path() / "fesim_render_bench_XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) return "/tmp";
  return pattern;
}

void BM_RenderFrame(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  OffscreenRenderer renderer(width, height);
  Camera camera;
  Image image;
  int i = 0;
  for (auto _ : state) {
    renderer.Render(Frame(i++), camera, &image);
    benchmark::DoNotOptimize(image.rgb.data());
  }
  state.counters["fps"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderFrame)->Args({1280, 720})->Args({640, 360})->UseRealTime();

/// One iteration = a whole 60-frame MP4 (start ffmpeg, render + send each frame, Finish()).
void BM_RenderAndEncodeMp4(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  OffscreenRenderer renderer(width, height);
  const std::string dir = TempDirectory();
  Camera camera;
  Image image;
  for (auto _ : state) {
    Mp4Writer writer(dir + "/bench.mp4", width, height, 30);
    for (int i = 0; i < kClipFrames; ++i) {
      renderer.Render(Frame(i), camera, &image);
      writer.AddFrame(image);
    }
    writer.Finish();
  }
  std::filesystem::remove_all(dir);
  state.counters["fps"] = benchmark::Counter(static_cast<double>(state.iterations()) * kClipFrames,
                                             benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderAndEncodeMp4)
    ->Args({1280, 720})
    ->Iterations(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

/// One iteration = a 60-frame PNG sequence (--frames DIR).
void BM_RenderAndWritePngs(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  OffscreenRenderer renderer(width, height);
  const std::string dir = TempDirectory();
  Camera camera;
  Image image;
  for (auto _ : state) {
    std::filesystem::remove_all(dir + "/frames");
    PngSequenceWriter writer(dir + "/frames");
    for (int i = 0; i < kClipFrames; ++i) {
      renderer.Render(Frame(i), camera, &image);
      writer.AddFrame(image);
    }
    writer.Finish();
  }
  std::filesystem::remove_all(dir);
  state.counters["fps"] = benchmark::Counter(static_cast<double>(state.iterations()) * kClipFrames,
                                             benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderAndWritePngs)
    ->Args({1280, 720})
    ->Iterations(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace fesim::render

BENCHMARK_MAIN();
