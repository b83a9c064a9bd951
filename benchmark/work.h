// The work machinery of `fesim benchmark` (issue 6): virtual studies generated once and cached on
// disk by content, identification fits cached by the hash of their inputs (a killed run resumes
// where it stopped), a parallel loop, and a progress bar with an estimate of the time left.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "identification/method.h"
#include "scenarios/json.h"
#include "scenarios/result_cache.h"
#include "scenarios/study.h"
#include "scenarios/trial.h"

namespace fesim::benchmark {

/// Runs fn(0) … fn(n − 1) on `threads` threads (dynamic assignment). Every index runs even when
/// some throw; afterwards the first failure (lowest index) is rethrown as std::runtime_error
/// "<label> <index>: <what>".
void ParallelFor(std::size_t n, int threads, const std::string& label,
                 const std::function<void(std::size_t)>& fn);

/// Progress over weighted work units: fraction done and the time left, extrapolated from the
/// rate so far, reported through `report` (the CLI's progress bar). Thread-safe.
class Progress {
 public:
  explicit Progress(std::function<void(double, const std::string&)> report);
  /// Adds planned work (expected seconds, any consistent unit).
  void Plan(double weight);
  /// Marks `weight` of the planned work done; `stage` labels the bar.
  void Done(double weight, const std::string& stage);

 private:
  std::function<void(double, const std::string&)> report_;
  std::mutex mutex_;
  double planned_ = 0.0, done_ = 0.0;
  std::chrono::steady_clock::time_point start_;
};

/// Thread-seconds spent per kind of work ("simulation", each method), summed over threads.
/// Thread-safe.
class Timing {
 public:
  void Add(const std::string& what, double seconds);
  std::map<std::string, double> Totals() const;

 private:
  mutable std::mutex mutex_;
  std::map<std::string, double> totals_;
};

/// A generated study: every item's measured and noiseless truth trial.
struct StudyTrials {
  Study study;
  std::vector<Trial> measured;  ///< per item (Study::items order).
  std::vector<Trial> truth;     ///< per item.
  int simulated = 0;            ///< items simulated in this run (the others came from the cache).
};

/// Loads the study and simulates every item, or reads it back from `cache_dir` when a previous
/// run wrote it for the same study text, base scenario text, seed and fesim version. Trials get
/// metadata `trial_hash` (hash of the content before it was added). Files are written
/// atomically, so an interrupted run leaves complete trials or none.
/// `timing` (may be null) receives the simulation time under "simulation".
StudyTrials GenerateStudy(const std::string& study_path, std::uint64_t seed,
                          const std::string& cache_dir, int threads, Progress* progress,
                          Timing* timing = nullptr);

/// One identification fit's outputs (the `fesim identify` outputs).
struct FitOutput {
  std::string model_yaml;
  std::vector<Trial> predictions;
  Json metrics;
  bool cached = false;
};

/// Runs identification methods with a result cache in `cache_dir`/<key>/ where key hashes the
/// method, its options and the trials' `trial_hash`es. Thread-safe.
class FitRunner {
 public:
  /// `timing` (may be null) receives each fit's wall time under the method's name.
  FitRunner(std::string cache_dir, std::vector<identification::MethodEntry> methods,
            Timing* timing = nullptr);

  /// Fits `method` on `train` with `options` (method options as trial metadata, e.g.
  /// "fullmodel.keep" → "8", set on a copy of train[0]) and evaluates on `test`.
  FitOutput Run(const std::string& method, const std::vector<Trial>& train,
                const std::vector<Trial>& test,
                const std::map<std::string, std::string>& options = {});

  /// Cache lookup / store of any JSON result under a key built from `parts` (for work that is
  /// not a registered method, e.g. the full-model fit with a shared ranking).
  bool Load(const std::vector<std::string>& parts, Json* out) const;
  void Store(const std::vector<std::string>& parts, const Json& value);

  int fits_run() const { return fits_run_; }
  int fits_cached() const { return fits_cached_; }

 private:
  ResultCache cache_;
  std::vector<identification::MethodEntry> methods_;
  Timing* timing_ = nullptr;
  std::mutex mutex_;
  int fits_run_ = 0, fits_cached_ = 0;
};

/// The trial's `trial_hash` metadata (throws std::logic_error when absent).
const std::string& TrialHash(const Trial& trial);

/// Linear interpolation of `column` of `source` at `times` (NaN outside its time range).
std::vector<double> Resample(const Trial& source, const std::string& column,
                             const std::vector<double>& times);

}  // namespace fesim::benchmark
