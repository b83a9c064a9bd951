// Work–precision of fesim against MuJoCo 2.2 (issue 26, docs/performance.md "Work–precision
// against MuJoCo"): the 60 s trial of bench/sim_bench.cc (default scenario, every channel
// stimulated, levels changing every 2 s) simulated by
//   fesim   CVODES BDF at tolerances 1e-2 … 1e-8, error against a 1e-10 fesim run;
//   MuJoCo  the MJCF of sim/mjcf.h with Euler, RK4 and implicit over time steps 0.1–10 ms, error
//           against a MuJoCo RK4 run at kMujocoReferenceStepS,
// each engine against its own reference (the two models differ: sim/mjcf.h). Error: RMS and
// maximum over the ten coordinates and the 6001 samples at 100 Hz, degrees. Cost: CPU seconds
// (CLOCK_PROCESS_CPUTIME_ID) of one whole 60 s simulation, the median of its runs over --repeats
// rounds (a cheap setting runs several times per round: RunsPerRound):
//   fesim   UpperLimbModel construction (Simbody topology) + the integration with q recorded at
//           100 Hz (sim::IntegrateTrialVariables, as the fits simulate: kCoordinates, method
//           "CVODES BDF") — the output MuJoCo's rows record — and, as rows of their own, the
//           same with RunTrial's records (the 100 Hz truth with muscle forces and the scenario's
//           sensors with noise, as `fesim simulate` makes them: kTrialRecords);
//   MuJoCo  ActivationTrack (recruitment, eq. 3) + WriteMjcf + mj_loadXML from memory (parse and
//           compile) + mj_makeData + the step loop (activation as ctrl at each step's midpoint,
//           eq. 6 in closed form) + recording q at 100 Hz.
// Neither includes reading the scenario YAML or writing files. Real-time factor = 60 s / CPU s.
// A plain executable (not Google Benchmark): one run writes one table with both engines.
//
//   mujoco_work_precision [--out DIR] [--repeats N] [--fesim-only]
// prints the table (Markdown) and writes DIR/work_precision.{csv,md,png}
// (default DIR out/mujoco_work_precision, N 3). --fesim-only: the fesim rows and reference only
// (≈ 1 minute instead of ≈ 6; the check of sim::TaskTolerances::kTrialGeneration).
#include <mujoco/mujoco.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "base/trial.h"
#include "bench/default_trial.h"
#include "render/plot.h"
#include "scenarios/scenario.h"
#include "sim/mjcf.h"
#include "sim/trial_runner.h"
#include "sim/upper_limb_model.h"

namespace {

using fesim::sim::kNumCoordinates;
using fesim::sim::MjcfIntegrator;
using Angles = std::vector<std::array<double, kNumCoordinates>>;  // rad, one row per sample

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;
constexpr double kDurationS = 60.0;
constexpr double kSampleS = 0.01;  // 100 Hz, the truth rate of RunTrial
constexpr double kFesimReferenceTolerance = 1e-10;
constexpr double kMujocoReferenceStepS = 2e-5;
// Both grids are finer near the 0.1° target (5e-3; 2.5 ms), so that neither engine's cheapest
// setting under a target is set by a coarse grid (docs/performance.md, Work–precision).
constexpr double kFesimTolerances[] = {1e-2, 5e-3, 3e-3, 1e-3, 3e-4, 1e-4, 1e-5, 1e-6, 1e-8};
// Each divides the 10 ms sample interval.
constexpr double kMujocoStepsS[] = {1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 2.5e-3, 5e-3, 1e-2};
constexpr MjcfIntegrator kMujocoIntegrators[] = {MjcfIntegrator::kEuler, MjcfIntegrator::kRk4,
                                                 MjcfIntegrator::kImplicit};
// Accuracy targets of issue 26 (RMS, degrees).
constexpr double kTargetsDeg[] = {0.01, 0.1};

struct Args {
  std::string out = "out/mujoco_work_precision";
  int repeats = 3;
  bool fesim_only = false;  // skip MuJoCo's reference and rows
};

Args ParseArgs(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (k == "--out" && i + 1 < argc) {
      a.out = argv[++i];
    } else if (k == "--repeats" && i + 1 < argc) {
      a.repeats = std::stoi(argv[++i]);
      if (a.repeats < 1) throw std::invalid_argument("--repeats must be ≥ 1");
    } else if (k == "--fesim-only") {
      a.fesim_only = true;
    } else {
      throw std::invalid_argument(
          "unknown argument " + k +
          " (usage: mujoco_work_precision [--out DIR] [--repeats N] [--fesim-only])");
    }
  }
  return a;
}

/// The trial of bench/sim_bench.cc (bench/default_trial.h), recorded at 1 / kSampleS.
fesim::Scenario BenchmarkScenario() {
  fesim::Scenario sc = fesim::bench::DefaultModelTrial(kDurationS);
  sc.trial.sensors.truth_rate_hz = 1.0 / kSampleS;
  return sc;
}

double CpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// One simulation: q at 100 Hz, its CPU time and step count; ok = false when it failed or
/// diverged (`note` says how).
struct Run {
  Angles q;
  double cpu_s = 0.0;
  long steps = 0;
  bool ok = true;
  std::string note;
  double min_band_length_m = INFINITY;  // MuJoCo: shortest band over the samples
  long constrained_steps = 0;           // MuJoCo: steps with a joint limit engaged
  double build_cpu_s = 0.0;             // of cpu_s: building the model (see the header)
};

/// What a fesim run records besides integrating (the file header).
enum class FesimRecord { kCoordinates, kTrialRecords };

/// The method label of a fesim row.
std::string FesimMethod(FesimRecord record) {
  return record == FesimRecord::kCoordinates ? "CVODES BDF" : "CVODES BDF + trial records";
}

Run RunFesim(const fesim::Scenario& sc, double tolerance, FesimRecord record) {
  fesim::sim::TrialRequest trial = sc.trial;
  trial.integrator.tolerance = tolerance;
  Run run;
  const double t0 = CpuSeconds();
  try {
    const fesim::sim::UpperLimbModel model(sc.model);
    run.build_cpu_s = CpuSeconds() - t0;
    if (record == FesimRecord::kCoordinates) {
      std::vector<double> q;
      run.steps =
          fesim::bench::SimulateCoordinates(model, sc, trial.integrator, 1.0 / kSampleS, &q).steps;
      run.cpu_s = CpuSeconds() - t0;
      run.q.resize(q.size() / kNumCoordinates);
      for (std::size_t i = 0; i < run.q.size(); ++i) {
        for (int c = 0; c < kNumCoordinates; ++c) run.q[i][c] = q[i * kNumCoordinates + c];
      }
    } else {
      const fesim::sim::TrialResult r = fesim::sim::RunTrial(model, trial);
      run.cpu_s = CpuSeconds() - t0;
      run.steps = r.stats.steps;
      run.q.resize(r.truth.size());
      for (int c = 0; c < kNumCoordinates; ++c) {
        const auto& col = r.truth.Column("q." + fesim::sim::CoordinateNames()[c]);
        for (std::size_t i = 0; i < col.size(); ++i) run.q[i][c] = col[i];
      }
    }
  } catch (const std::exception& e) {
    run.cpu_s = CpuSeconds() - t0;
    run.ok = false;
    run.note = e.what();
  }
  return run;
}

struct MjDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
  void operator()(mjData* d) const { mj_deleteData(d); }
  void operator()(mjVFS* v) const {
    mj_deleteVFS(v);
    delete v;
  }
};

/// Compiles MJCF text from memory (a one-file virtual file system). Throws on a compile error.
std::unique_ptr<mjModel, MjDeleter> CompileMjcf(const std::string& xml) {
  std::unique_ptr<mjVFS, MjDeleter> vfs(new mjVFS);
  mj_defaultVFS(vfs.get());
  if (mj_makeEmptyFileVFS(vfs.get(), "fesim.xml", static_cast<int>(xml.size())) != 0) {
    throw std::runtime_error("MuJoCo: cannot make the in-memory MJCF file");
  }
  std::memcpy(vfs->filedata[vfs->nfile - 1], xml.data(), xml.size());
  char error[1000] = "";
  std::unique_ptr<mjModel, MjDeleter> m(mj_loadXML("fesim.xml", vfs.get(), error, sizeof error));
  if (!m) throw std::runtime_error(std::string("MuJoCo: ") + error);
  return m;
}

Run RunMujoco(const fesim::Scenario& sc, MjcfIntegrator integrator, double step_s) {
  Run run;
  const double t0 = CpuSeconds();
  const fesim::sim::ActivationTrack track(sc.model, sc.trial.stimulation);
  const std::string xml = fesim::sim::WriteMjcf(sc.model, {step_s, integrator, "fesim_default"});
  const auto m = CompileMjcf(xml);
  const std::unique_ptr<mjData, MjDeleter> d(mj_makeData(m.get()));
  mj_resetDataKeyframe(m.get(), d.get(), 0);
  run.build_cpu_s = CpuSeconds() - t0;
  mj_forward(m.get(), d.get());  // tendon lengths of the initial state for record()
  const long per_sample = std::lround(kSampleS / step_s);
  const long n_steps = std::lround(kDurationS / step_s);
  const int band = mj_name2id(m.get(), mjOBJ_TENDON, "band0");
  const auto record = [&] {
    std::array<double, kNumCoordinates> q{};
    for (int c = 0; c < kNumCoordinates; ++c) q[c] = d->qpos[c];
    run.q.push_back(q);
    if (band >= 0) run.min_band_length_m = std::min(run.min_band_length_m, d->ten_length[band]);
  };
  record();
  for (long k = 0; k < n_steps; ++k) {
    // ctrl is held over the step (also over RK4's stages): the activation at its midpoint.
    track.At((static_cast<double>(k) + 0.5) * step_s, d->ctrl);
    mj_step(m.get(), d.get());
    if (d->nefc > 0) ++run.constrained_steps;
    // MuJoCo resets the state when it finds a bad position, speed or acceleration: unstable.
    if (d->warning[mjWARN_BADQACC].number + d->warning[mjWARN_BADQVEL].number +
            d->warning[mjWARN_BADQPOS].number >
        0) {
      run.ok = false;
      run.note = "unstable at t = " + std::to_string(static_cast<double>(k + 1) * step_s) + " s";
      break;
    }
    if ((k + 1) % per_sample == 0) record();
  }
  run.cpu_s = CpuSeconds() - t0;
  run.steps = n_steps;
  return run;
}

struct Error {
  double rms_deg = NAN, max_deg = NAN;
};

Error Compare(const Angles& q, const Angles& ref) {
  if (q.size() != ref.size()) {
    throw std::runtime_error("sample counts differ: " + std::to_string(q.size()) + " vs " +
                             std::to_string(ref.size()));
  }
  double sum = 0.0, mx = 0.0;
  for (std::size_t i = 0; i < q.size(); ++i) {
    for (int c = 0; c < kNumCoordinates; ++c) {
      const double e = (q[i][c] - ref[i][c]) * kRadToDeg;
      sum += e * e;
      mx = std::max(mx, std::abs(e));
    }
  }
  Error out;
  out.rms_deg = std::sqrt(sum / static_cast<double>(q.size() * kNumCoordinates));
  out.max_deg = mx;
  return out;
}

/// One row of the table.
struct Point {
  std::string engine;   // "fesim" or "MuJoCo"
  std::string method;   // "CVODES BDF", "Euler", "RK4", "implicit"
  std::string setting;  // "tol 1e-6", "h 0.5 ms"
  double value = 0.0;   // tolerance or step (s)
  Error error;
  double cpu_s = NAN;  // median
  long steps = 0;
  bool ok = true;
  std::string note;
};

Point MakePoint(std::string engine, std::string method, std::string setting, double value) {
  Point p;
  p.engine = std::move(engine);
  p.method = std::move(method);
  p.setting = std::move(setting);
  p.value = value;
  return p;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// A setting of the sweep: its row and how to simulate it.
struct Setting {
  Point point;
  std::function<Run()> simulate;
  const Angles* reference = nullptr;
  std::vector<double> cpu_s;  // one per run
  int runs_per_round = 0;     // set by the first run (RunsPerRound)
};

/// Runs of a setting per round: as many as fill kRoundSeconds at the first run's CPU time, at
/// most kMaxRunsPerRound. A 60 ms simulation timed once per round varied by ≈ 15 % between
/// neighbouring rows (docs/performance.md, Work–precision against MuJoCo); the median over more
/// runs of the cheap settings steadies them while the expensive ones keep one run per round.
int RunsPerRound(double first_cpu_s) {
  constexpr double kRoundSeconds = 0.5;
  constexpr int kMaxRunsPerRound = 8;
  if (!(first_cpu_s > 0.0)) return 1;
  return std::clamp(static_cast<int>(std::ceil(kRoundSeconds / first_cpu_s)), 1, kMaxRunsPerRound);
}

/// Runs every setting in `repeats` rounds (RunsPerRound times in each), the settings interleaved
/// within each round so that a change of the shared machine's load spreads over all of them: the
/// median CPU time of all runs, the first run's error (runs are deterministic; a differing repeat
/// is noted). A failed or unstable setting is not repeated.
std::vector<Point> MeasureInterleaved(std::vector<Setting> settings, int repeats) {
  std::vector<Angles> first(settings.size());
  for (int r = 0; r < repeats; ++r) {
    for (std::size_t k = 0; k < settings.size(); ++k) {
      Setting& s = settings[k];
      for (int i = 0; s.point.ok && i < std::max(1, s.runs_per_round); ++i) {
        Run run = s.simulate();
        s.cpu_s.push_back(run.cpu_s);
        s.point.steps = run.steps;
        if (!run.ok) {
          s.point.ok = false;
          s.point.note = run.note;
        } else if (first[k].empty()) {
          s.point.error = Compare(run.q, *s.reference);
          first[k] = std::move(run.q);
          s.runs_per_round = RunsPerRound(run.cpu_s);
        } else if (run.q != first[k]) {
          s.point.note = "repeats differ";
        }
        std::fprintf(
            stderr, "round %d/%d %-6s %-10s %-12s rms %.3g deg  max %.3g deg  cpu %.3f s %s\n",
            r + 1, repeats, s.point.engine.c_str(), s.point.method.c_str(), s.point.setting.c_str(),
            s.point.error.rms_deg, s.point.error.max_deg, run.cpu_s, s.point.note.c_str());
      }
    }
  }
  std::vector<Point> points;
  for (Setting& s : settings) {
    s.point.cpu_s = Median(s.cpu_s);
    points.push_back(s.point);
  }
  return points;
}

std::string Fmt(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::string MarkdownTable(const std::vector<Point>& points) {
  std::string md =
      "| engine | method | setting | RMS error (deg) | max error (deg) | CPU s (median) | "
      "real-time factor | steps |\n|---|---|---|---|---|---|---|---|\n";
  for (const Point& p : points) {
    md += "| " + p.engine + " | " + p.method + " | " + p.setting + " | " +
          (p.ok ? Fmt("%.2g", p.error.rms_deg) : p.note) + " | " +
          (p.ok ? Fmt("%.2g", p.error.max_deg) : "—") + " | " +
          (p.ok ? Fmt("%.3f", p.cpu_s) : "—") + " | " +
          (p.ok ? Fmt("%.0f", kDurationS / p.cpu_s) + "×" : "—") + " | " + std::to_string(p.steps) +
          " |\n";
  }
  return md;
}

std::string Csv(const std::vector<Point>& points) {
  std::string csv =
      "engine,method,setting,value,rms_error_deg,max_error_deg,cpu_s,real_time_factor,steps,ok\n";
  for (const Point& p : points) {
    csv += p.engine + "," + p.method + "," + p.setting + "," + Fmt("%.6g", p.value) + "," +
           Fmt("%.6g", p.error.rms_deg) + "," + Fmt("%.6g", p.error.max_deg) + "," +
           Fmt("%.6g", p.cpu_s) + "," + Fmt("%.6g", kDurationS / p.cpu_s) + "," +
           std::to_string(p.steps) + "," + (p.ok ? "1" : "0") + "\n";
  }
  return csv;
}

/// Error (log y) against log10 CPU seconds, one point series per engine and method.
void WritePlot(const std::string& path, const std::vector<Point>& points) {
  std::vector<fesim::render::Series> series;
  int colour = 0;
  for (const Point& p : points) {
    const std::string label = p.engine + " " + p.method;
    if (series.empty() || series.back().label != label) {
      series.push_back({label, {}, {}, fesim::render::PaletteColour(colour++), true});
    }
    series.back().x.push_back(p.ok ? std::log10(p.cpu_s) : NAN);
    series.back().y.push_back(p.ok ? p.error.rms_deg : NAN);
  }
  double x_lo = INFINITY, x_hi = -INFINITY;
  for (const auto& s : series) {
    for (double x : s.x) {
      if (!std::isfinite(x)) continue;
      x_lo = std::min(x_lo, x);
      x_hi = std::max(x_hi, x);
    }
  }
  for (double target : kTargetsDeg) {  // the accuracy targets as horizontal lines
    series.push_back({"target " + Fmt("%g", target) + " deg",
                      {x_lo, x_hi},
                      {target, target},
                      fesim::render::PaletteColour(7),
                      false});
  }
  fesim::render::Axes axes;
  axes.title = "Work-precision, default model, 60 s trial";
  axes.x_label = "log10 CPU seconds per 60 s simulation (incl. model build)";
  axes.y_label = "RMS error vs own reference, deg";
  axes.log_y = true;
  axes.width_px = 900;
  axes.height_px = 560;
  fesim::render::WriteLinePlotPng(path, axes, series);
}

/// Whether point p is of `engine` and, unless `method` is empty, of `method`.
bool Of(const Point& p, const std::string& engine, const std::string& method) {
  return p.engine == engine && (method.empty() || p.method == method);
}

/// The cheapest point of an engine (and method, unless empty) whose RMS error is ≤ target, or
/// nullptr.
const Point* Cheapest(const std::vector<Point>& points, const std::string& engine,
                      const std::string& method, double target) {
  const Point* best = nullptr;
  for (const Point& p : points) {
    if (!Of(p, engine, method) || !p.ok || !(p.error.rms_deg <= target)) continue;
    if (!best || p.cpu_s < best->cpu_s) best = &p;
  }
  return best;
}

/// An engine's CPU seconds at exactly RMS error `target`: per method (or only `method`, unless
/// empty), between the two neighbouring settings of its grid whose errors bracket the target,
/// log-cost interpolated linearly in log-error; the cheapest over the methods and bracketing
/// pairs (NaN: no pair brackets it). Free of where a grid point happens to fall below the target.
double InterpolatedCost(const std::vector<Point>& points, const std::string& engine,
                        const std::string& method, double target) {
  double best = NAN;
  for (std::size_t i = 0; i + 1 < points.size(); ++i) {
    const Point& a = points[i];
    const Point& b = points[i + 1];
    if (!Of(a, engine, method) || !Of(b, engine, method) || a.method != b.method || !a.ok ||
        !b.ok) {
      continue;
    }
    const double ea = a.error.rms_deg, eb = b.error.rms_deg;
    if (!(std::min(ea, eb) <= target && target < std::max(ea, eb))) continue;
    const double w = (std::log(target) - std::log(ea)) / (std::log(eb) - std::log(ea));
    const double cost = std::exp(std::log(a.cpu_s) + w * (std::log(b.cpu_s) - std::log(a.cpu_s)));
    if (!(cost >= best)) best = cost;
  }
  return best;
}

/// Per accuracy target and fesim recording: both engines' costs, interpolated and at the
/// cheapest grid point, and their ratio.
std::string Summary(const std::vector<Point>& points) {
  std::string md;
  for (double target : kTargetsDeg) {
    const double mi = InterpolatedCost(points, "MuJoCo", "", target);
    const Point* m = Cheapest(points, "MuJoCo", "", target);
    for (FesimRecord record : {FesimRecord::kCoordinates, FesimRecord::kTrialRecords}) {
      const std::string method = FesimMethod(record);
      const double fi = InterpolatedCost(points, "fesim", method, target);
      if (std::isfinite(fi) && std::isfinite(mi)) {
        md += "- RMS = " + Fmt("%g", target) + "° interpolated (InterpolatedCost): fesim " +
              method + " " + Fmt("%.3f", fi) + " s, MuJoCo " + Fmt("%.3f", mi) + " s; fesim is " +
              Fmt("%.2f", mi / fi) + "× MuJoCo's speed\n";
      }
      const Point* f = Cheapest(points, "fesim", method, target);
      md += "- RMS ≤ " + Fmt("%g", target) + "°: fesim " + method + " " +
            (f ? f->setting + " (" + Fmt("%.3f", f->cpu_s) + " s, " +
                     Fmt("%.0f", kDurationS / f->cpu_s) + "× real time)"
               : std::string("none")) +
            ", MuJoCo " +
            (m ? m->method + " " + m->setting + " (" + Fmt("%.3f", m->cpu_s) + " s, " +
                     Fmt("%.0f", kDurationS / m->cpu_s) + "×)"
               : std::string("none"));
      if (f && m) md += "; fesim is " + Fmt("%.2f", m->cpu_s / f->cpu_s) + "× MuJoCo's speed";
      md += "\n";
    }
  }
  return md;
}

/// Whether both fesim recordings gave the same errors and steps at every tolerance (they
/// integrate one trajectory; only what is recorded differs).
std::string RecordingsAgree(const std::vector<Point>& points) {
  for (const Point& a : points) {
    if (!Of(a, "fesim", FesimMethod(FesimRecord::kCoordinates))) continue;
    for (const Point& b : points) {
      if (!Of(b, "fesim", FesimMethod(FesimRecord::kTrialRecords)) || b.value != a.value) continue;
      if (a.error.rms_deg != b.error.rms_deg || a.error.max_deg != b.error.max_deg ||
          a.steps != b.steps) {
        return "- the two fesim recordings differ at " + a.setting + "\n";
      }
    }
  }
  return "- the two fesim recordings give the same errors and steps at every tolerance (one "
         "trajectory; only the records differ)\n";
}

/// Where the two models' trajectories differ (each engine's reference against the other's) and
/// whether the MJCF's departures were exercised: band slack, joint limits.
std::string ModelNotes(const fesim::Scenario& sc, const Run& fesim_ref, const Run& mujoco_ref) {
  std::string md;
  const Error diff = Compare(fesim_ref.q, mujoco_ref.q);
  md += "- fesim reference vs MuJoCo reference (model difference, not an integration error): RMS " +
        Fmt("%.2f", diff.rms_deg) + "°, max " + Fmt("%.1f", diff.max_deg) +
        "°; per coordinate RMS:";
  for (int c = 0; c < kNumCoordinates; ++c) {
    double s = 0.0;
    for (std::size_t i = 0; i < fesim_ref.q.size(); ++i) {
      const double e = (fesim_ref.q[i][c] - mujoco_ref.q[i][c]) * kRadToDeg;
      s += e * e;
    }
    md += " " + fesim::sim::CoordinateNames()[c] + " " +
          Fmt("%.2f", std::sqrt(s / static_cast<double>(fesim_ref.q.size()))) + "°" +
          (c + 1 < kNumCoordinates ? "," : "\n");
  }
  double margin = INFINITY;  // fesim: closest approach to a range end, rad
  std::string closest;
  for (const auto& q : fesim_ref.q) {
    for (int c = 0; c < kNumCoordinates; ++c) {
      const auto& j = sc.model.coordinates[c].passive;
      const double d = std::min(q[c] - j.min_angle_rad, j.max_angle_rad - q[c]);
      if (d < margin) {
        margin = d;
        closest = fesim::sim::CoordinateNames()[c];
      }
    }
  }
  md += "- fesim reference: closest approach to a range end " + Fmt("%.1f", margin * kRadToDeg) +
        "° (" + closest + "); MuJoCo reference: a joint limit engaged in " +
        std::to_string(mujoco_ref.constrained_steps) + " of " + std::to_string(mujoco_ref.steps) +
        " steps\n";
  if (!sc.model.bands.empty()) {
    md += "- MuJoCo reference: shortest band length " + Fmt("%.3f", mujoco_ref.min_band_length_m) +
          " m (slack length " + Fmt("%.3f", sc.model.bands[0].slack_length_m) + " m: the band " +
          (mujoco_ref.min_band_length_m > sc.model.bands[0].slack_length_m ? "stayed taut"
                                                                           : "went slack") +
          ")\n";
  }
  return md;
}

std::vector<Point> MeasureAll(const fesim::Scenario& sc, int repeats, bool fesim_only,
                              Run* fesim_ref, Run* mujoco_ref) {
  *fesim_ref = RunFesim(sc, kFesimReferenceTolerance, FesimRecord::kCoordinates);
  if (!fesim_ref->ok) throw std::runtime_error("fesim reference failed: " + fesim_ref->note);
  std::fprintf(stderr, "fesim reference (tol %g): %.3f s CPU\n", kFesimReferenceTolerance,
               fesim_ref->cpu_s);
  if (!fesim_only) {
    *mujoco_ref = RunMujoco(sc, MjcfIntegrator::kRk4, kMujocoReferenceStepS);
    if (!mujoco_ref->ok) throw std::runtime_error("MuJoCo reference failed: " + mujoco_ref->note);
    std::fprintf(stderr, "MuJoCo reference (RK4, %g ms): %.3f s CPU\n", kMujocoReferenceStepS * 1e3,
                 mujoco_ref->cpu_s);
  }
  std::vector<Setting> settings;
  for (FesimRecord record : {FesimRecord::kCoordinates, FesimRecord::kTrialRecords}) {
    for (double tol : kFesimTolerances) {
      // The shipped default of trial generation (sim/task_tolerances.h) is marked in the table.
      const bool shipped = tol == fesim::sim::TaskTolerances::kTrialGeneration;
      settings.push_back({MakePoint("fesim", FesimMethod(record),
                                    "tol " + Fmt("%.0e", tol) + (shipped ? " (default)" : ""), tol),
                          [&sc, tol, record] { return RunFesim(sc, tol, record); },
                          &fesim_ref->q,
                          {}});
    }
  }
  for (MjcfIntegrator integrator :
       fesim_only ? std::vector<MjcfIntegrator>{}
                  : std::vector<MjcfIntegrator>(std::begin(kMujocoIntegrators),
                                                std::end(kMujocoIntegrators))) {
    for (double h : kMujocoStepsS) {
      settings.push_back({MakePoint("MuJoCo", fesim::sim::MjcfIntegratorName(integrator),
                                    "h " + Fmt("%g", h * 1e3) + " ms", h),
                          [&sc, integrator, h] { return RunMujoco(sc, integrator, h); },
                          &mujoco_ref->q,
                          {}});
    }
  }
  return MeasureInterleaved(std::move(settings), repeats);
}

/// The 1-minute load average of the machine (NaN when unavailable).
double LoadAverage() {
  double load[1] = {NAN};
  return getloadavg(load, 1) == 1 ? load[0] : NAN;
}

/// MuJoCo's warning hook: one line on stderr, instead of its default stdout plus a
/// MUJOCO_LOG.TXT in the working directory.
void MujocoWarning(const char* message) { std::fprintf(stderr, "MuJoCo: %s\n", message); }

}  // namespace

int main(int argc, char** argv) {
  mju_user_warning = MujocoWarning;  // MuJoCo's process-wide hook (set before any MuJoCo call)
  try {
    const Args args = ParseArgs(argc, argv);
    const fesim::Scenario sc = BenchmarkScenario();
    Run fesim_ref, mujoco_ref;
    const double load_start = LoadAverage();
    const std::vector<Point> points =
        MeasureAll(sc, args.repeats, args.fesim_only, &fesim_ref, &mujoco_ref);
    const Run fesim_check = RunFesim(sc, 10 * kFesimReferenceTolerance, FesimRecord::kCoordinates);
    const Error fesim_ref_check = Compare(fesim_check.q, fesim_ref.q);

    std::string md = "Work–precision, default model, 60 s trial (" + std::to_string(args.repeats) +
                     " rounds, median CPU time of each setting's runs, up to 8 per round for "
                     "settings under 0.5 s; " +
                     (args.fesim_only ? std::string("fesim only")
                                      : "MuJoCo " + std::string(mj_versionString())) +
                     ")\n\n" + MarkdownTable(points) + "\n" + Summary(points) +
                     RecordingsAgree(points);
    md += "- references: fesim tol " + Fmt("%.0e", kFesimReferenceTolerance) + " (" +
          Fmt("%.2f", fesim_ref.cpu_s) + " s; tol " + Fmt("%.0e", 10 * kFesimReferenceTolerance) +
          " is " + Fmt("%.1e", fesim_ref_check.rms_deg) + "° RMS from it)";
    if (!args.fesim_only) {
      // The reference's own error: RK4 at twice its step against it.
      const Run check = RunMujoco(sc, MjcfIntegrator::kRk4, 2 * kMujocoReferenceStepS);
      const Error ref_check = Compare(check.q, mujoco_ref.q);
      md += ", MuJoCo RK4 h " + Fmt("%g", kMujocoReferenceStepS * 1e3) + " ms (" +
            Fmt("%.2f", mujoco_ref.cpu_s) + " s; RK4 at twice the step is " +
            Fmt("%.1e", ref_check.rms_deg) + "° RMS from it)";
    }
    md += "\n- model build, included in every CPU time above: fesim " +
          Fmt("%.1f", fesim_ref.build_cpu_s * 1e3) + " ms (UpperLimbModel)";
    if (!args.fesim_only) {
      md += ", MuJoCo " + Fmt("%.1f", mujoco_ref.build_cpu_s * 1e3) +
            " ms (ActivationTrack, WriteMjcf, mj_loadXML, mj_makeData)";
    }
    md += ", in the reference runs\n";
    md += "- machine load (1-minute average, 2 cores): " + Fmt("%.1f", load_start) +
          " at the start, " + Fmt("%.1f", LoadAverage()) + " at the end\n";
    if (!args.fesim_only) md += ModelNotes(sc, fesim_ref, mujoco_ref);
    std::cout << md;
    std::filesystem::create_directories(args.out);
    fesim::WriteFileAtomic(args.out + "/work_precision.md", md);
    fesim::WriteFileAtomic(args.out + "/work_precision.csv", Csv(points));
    WritePlot(args.out + "/work_precision.png", points);
    std::cerr << "written " << args.out << "/work_precision.{md,csv,png}\n";
  } catch (const std::exception& e) {
    std::cerr << "mujoco_work_precision: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
