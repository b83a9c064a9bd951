// `fesim render TRIAL.csv --scenario S.yaml (--out MOVIE.mp4 | --frames DIR) [--width W]
//  [--height H] [--fps F] [--camera front|side|top|orbit] [--compare OTHER.csv]`
//
// Replays a trial's joint angles through the scenario model's kinematics (apps/arm_scene.h) and
// renders them off-screen (render/). Frames are at t0 + k/F for every k with t0 + k/F ≤ t_end
// (t0, t_end: the trial's first and last sample times); the trial is resampled to them by
// ResampleTrial (linear, NaN gaps hold the last valid value).
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "apps/arm_scene.h"
#include "apps/cli.h"
#include "apps/commands.h"
#include "base/trial.h"
#include "render/renderer.h"
#include "render/video.h"
#include "scenarios/scenario.h"
#include "sim/upper_limb_model.h"

namespace fesim {
namespace {

constexpr int kDefaultWidthPx = 1280;
constexpr int kDefaultHeightPx = 720;
constexpr double kDefaultFps = 30.0;
constexpr double kMaxFps = 1000.0;
/// Camera distance from the arm's centre, m (the whole arm and the thorax fit in a 45° view).
constexpr double kCameraDistance_m = 1.3;
/// Frames per progress-bar update.
constexpr int kProgressEvery = 5;

void PrintHelp() {
  std::printf(
      "usage: fesim render TRIAL.csv --scenario SCENARIO.yaml (--out MOVIE.mp4 | --frames DIR)\n"
      "                    [--width W] [--height H] [--fps F] [--camera front|side|top|orbit]\n"
      "                    [--compare OTHER.csv] [--quiet]\n\n"
      "Replays the trial's q.<coordinate> columns (rad) through the scenario model's kinematics\n"
      "and renders them off-screen: shaded segments, muscle paths coloured by activation\n"
      "(a.<muscle> columns; neutral grey without them), electrode pads coloured by stimulation\n"
      "(u.<channel>, µs), arm-support bands, an overlay with time, channels and joint angles.\n"
      "Coordinates without a column stay at the scenario's initial angle.\n\n"
      "  --out MOVIE.mp4   H.264 MP4 through ffmpeg (width and height even)\n"
      "  --frames DIR      PNG sequence DIR/frame_000000.png, ... (DIR new or empty)\n"
      "  --width, --height image size, pixels, 1-%d (default %dx%d)\n"
      "  --fps F           frames per second of trial time, (0, %g] (default %g)\n"
      "  --camera NAME     front (default), side, top or orbit\n"
      "  --compare B.csv   a second trial drawn as a translucent ghost arm (same frame times;\n"
      "                    its first/last pose is held outside its time range)\n"
      "Frames are at t0 + k/F up to the trial's last time; the trial is interpolated linearly\n"
      "(NaN gaps hold the last valid value). Nothing is written when an input is invalid.\n",
      render::kMaxImageSidePx, kDefaultWidthPx, kDefaultHeightPx, kMaxFps, kDefaultFps);
}

/// Image side from --width / --height: 1–kMaxImageSidePx, even for MP4.
int ImageSide(const cli::Args& args, const std::string& key, int fallback, bool mp4) {
  const long v = args.GetInt(key, fallback);
  const int lo = mp4 ? 2 : 1;
  if (v < lo || v > render::kMaxImageSidePx || (mp4 && v % 2 != 0)) {
    throw std::runtime_error("option --" + key + ": " + std::to_string(v) + " must be in [" +
                             std::to_string(lo) + ", " + std::to_string(render::kMaxImageSidePx) +
                             "]" + (mp4 ? " and even for MP4 (yuv420p)" : "") + ", pixels");
  }
  return static_cast<int>(v);
}

double Fps(const cli::Args& args) {
  if (!args.Has("fps")) return kDefaultFps;
  const std::string s = args.Get("fps");
  double v = std::nan("");
  try {
    std::size_t pos = 0;
    v = std::stod(s, &pos);
    if (pos != s.size()) v = std::nan("");
  } catch (const std::exception&) {
  }
  if (!(v > 0.0 && v <= kMaxFps)) {
    throw std::runtime_error("option --fps: '" + s + "' is outside (0, " +
                             std::to_string(static_cast<int>(kMaxFps)) + "] frames per second");
  }
  return v;
}

std::string BaseName(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

/// A trial resampled to the frame times with its pose columns.
struct FrameTrial {
  Trial frames;
  PoseColumns pose;
  std::vector<int> channel_column;  ///< per model channel: column of u.<channel>, or −1.
  std::vector<int> muscle_column;   ///< per model muscle: column of a.<muscle>, or −1.
};

FrameTrial PrepareTrial(const Trial& trial, const std::string& source,
                        const sim::ModelParams& params, const std::vector<double>& times) {
  FrameTrial out;
  out.pose = FindPoseColumns(trial, source);
  out.frames = ResampleTrial(trial, times);
  const auto column_of = [&trial](const std::string& name) {
    for (std::size_t c = 0; c < trial.names.size(); ++c) {
      if (trial.names[c] == name) return static_cast<int>(c);
    }
    return -1;
  };
  for (const auto& ch : params.channels) out.channel_column.push_back(column_of("u." + ch.name));
  for (const auto& m : params.muscles) out.muscle_column.push_back(column_of("a." + m.name));
  return out;
}

/// Values of the mapped columns at one frame; `fallback` where a column is absent or NaN.
std::vector<double> RowValues(const FrameTrial& t, const std::vector<int>& columns, std::size_t row,
                              double fallback) {
  std::vector<double> v(columns.size(), fallback);
  for (std::size_t k = 0; k < columns.size(); ++k) {
    if (columns[k] >= 0 && std::isfinite(t.frames.columns[columns[k]][row])) {
      v[k] = t.frames.columns[columns[k]][row];
    }
  }
  return v;
}

}  // namespace

int RunRender(int argc, char** argv) {
  const auto args =
      cli::Parse(argc, argv, 2, {"help", "quiet"},
                 {"scenario", "out", "frames", "width", "height", "fps", "camera", "compare"});
  if (args.Has("help")) {
    PrintHelp();
    return 0;
  }
  // Options first (cheap), then the input files; no output exists before all of them pass.
  if (args.positional.size() != 1) {
    throw std::runtime_error("expected one TRIAL.csv argument (see --help)");
  }
  if (!args.Has("scenario")) throw std::runtime_error("--scenario SCENARIO.yaml is required");
  if (!args.Has("out") && !args.Has("frames")) {
    throw std::runtime_error("--out MOVIE.mp4 or --frames DIR is required (see --help)");
  }
  cli::OutPath(args, "out", "");  // refuses an empty path
  cli::OutPath(args, "frames", "");
  const bool mp4 = args.Has("out");
  const int width = ImageSide(args, "width", kDefaultWidthPx, mp4);
  const int height = ImageSide(args, "height", kDefaultHeightPx, mp4);
  const double fps = Fps(args);
  render::Camera camera;
  try {
    camera.preset = render::ParseCameraPreset(args.Get("camera", "front"));
  } catch (const std::invalid_argument&) {
    throw std::runtime_error("option --camera: '" + args.Get("camera") +
                             "' is not one of front, side, top, orbit");
  }

  const std::string trial_path = args.positional[0];
  const Trial trial = ReadTrialCsv(trial_path);
  if (trial.size() == 0) throw std::runtime_error(trial_path + ": the trial has no samples");
  FindPoseColumns(trial, trial_path);  // fail before the (slower) scenario and model
  Trial compare;
  if (args.Has("compare")) {
    compare = ReadTrialCsv(args.Get("compare"));
    if (compare.size() == 0) {
      throw std::runtime_error(args.Get("compare") + ": the trial has no samples");
    }
    FindPoseColumns(compare, args.Get("compare"));
  }
  const Scenario scenario = LoadScenario(args.Get("scenario"));
  const sim::UpperLimbModel model(scenario.model);

  // Frame times: t0 + k/fps up to the last sample (a tolerance keeps the end frame exact).
  const double t0 = trial.time.front();
  const double span = trial.time.back() - t0;
  const std::size_t n_frames = static_cast<std::size_t>(std::floor(span * fps + 1e-9)) + 1;
  std::vector<double> times(n_frames);
  for (std::size_t k = 0; k < n_frames; ++k) times[k] = t0 + static_cast<double>(k) / fps;

  const FrameTrial main_frames = PrepareTrial(trial, trial_path, scenario.model, times);
  std::unique_ptr<FrameTrial> ghost_frames;
  if (args.Has("compare")) {
    ghost_frames = std::make_unique<FrameTrial>(
        PrepareTrial(compare, args.Get("compare"), scenario.model, times));
  }

  SimTK::State state = model.MakeInitialState();
  SimTK::State ghost = model.MakeInitialState();
  model.system().realize(state, SimTK::Stage::Position);
  camera.target = ArmCameraTarget(model, state);
  camera.distance_m = kCameraDistance_m;

  render::OffscreenRenderer renderer(width, height);
  std::unique_ptr<render::Mp4Writer> movie;
  std::unique_ptr<render::PngSequenceWriter> pngs;
  if (mp4) movie = std::make_unique<render::Mp4Writer>(args.Get("out"), width, height, fps);
  if (args.Has("frames")) pngs = std::make_unique<render::PngSequenceWriter>(args.Get("frames"));

  ArmSceneInputs inputs;
  inputs.title = BaseName(trial_path) +
                 (args.Has("compare") ? " (ghost: " + BaseName(args.Get("compare")) + ")" : "");
  render::Image image;
  const cli::Progress progress(cli::ProgressFor(args));
  for (std::size_t k = 0; k < n_frames; ++k) {
    SetPoseFromTrialRow(model, main_frames.frames, main_frames.pose, k, &state);
    inputs.time_s = times[k];
    inputs.stimulation_us = RowValues(main_frames, main_frames.channel_column, k, 0.0);
    inputs.activation = RowValues(main_frames, main_frames.muscle_column, k, std::nan(""));
    inputs.ghost = nullptr;
    if (ghost_frames) {
      SetPoseFromTrialRow(model, ghost_frames->frames, ghost_frames->pose, k, &ghost);
      inputs.ghost = &ghost;
    }
    renderer.Render(ArmScene(model, state, inputs), camera, &image);
    if (movie) movie->AddFrame(image);
    if (pngs) pngs->AddFrame(image);
    if (k % kProgressEvery == 0 || k + 1 == n_frames) {
      progress(static_cast<double>(k + 1) / n_frames,
               "frame " + std::to_string(k + 1) + "/" + std::to_string(n_frames));
    }
  }
  if (movie) movie->Finish();
  if (pngs) pngs->Finish();
  std::fprintf(stderr, "fesim render: %zu frames (%dx%d, %g fps) written to %s%s%s\n", n_frames,
               width, height, fps, mp4 ? args.Get("out").c_str() : "", mp4 && pngs ? " and " : "",
               pngs ? args.Get("frames").c_str() : "");
  return 0;
}

}  // namespace fesim
