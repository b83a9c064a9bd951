// The work machinery of `fesim benchmark` (issue 6): virtual studies generated once and cached on
// disk by content, identification fits cached by the hash of their inputs (a killed run resumes
// where it stopped), a parallel loop, and a progress bar with an estimate of the time left.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "base/json.h"
#include "base/result_cache.h"
#include "base/trial.h"
#include "cluster/cluster.h"
#include "identification/method.h"
#include "scenarios/study.h"

namespace fesim::paper_benchmark {

/// One failed work item of a loop.
struct FailedItem {
  std::string label;
  std::size_t index = 0;
  int rank = 0;  ///< the MPI rank that ran it (0 on one process).
  std::string what;
};

/// Thrown (on every rank) when items of a WorkLoop failed, after every other item finished. The
/// message names each failed item ("<label> <index>: <what>", lowest index first; with the rank
/// on an MPI job). Items that finished are in the benchmark's cache, so a rerun does the failed
/// ones (and what had not started yet) only.
class WorkItemsFailed : public cluster::CollectiveError {
 public:
  explicit WorkItemsFailed(std::vector<FailedItem> items);
  const std::vector<FailedItem>& items() const { return items_; }

 private:
  std::vector<FailedItem> items_;
};

/// Where the benchmark's loops of independent work items run (issue 9).
///
/// One process: fn(i) for every i on `threads` threads (dynamic assignment).
/// An MPI job (cluster with more than one rank): every item runs once on some rank (dynamically
/// balanced by cluster::Cluster::Map), leaving its result in the benchmark's cache; then, because
/// the sections' state must be the same on every rank, every rank runs fn(i) for all i again on
/// its threads: a replay that reads the cache. fn must therefore cache everything expensive it
/// computes (FitRunner, GenerateStudy, CachedJson do). The phase hook is told when the
/// distribution, the replay and the loop start/end, so that counters and progress count each
/// item once.
class WorkLoop {
 public:
  /// `cluster` may be null (one process).
  WorkLoop(int threads, cluster::Cluster* cluster);

  /// Item "<label> <index>" throws std::runtime_error("injected fault") instead of running: the
  /// fault injection of the failure-handling tests (`fesim benchmark`'s FESIM_FAIL_ITEM).
  void InjectFault(std::string item) { fault_ = std::move(item); }
  /// Phases of a loop on an MPI job, told to the hook set by OnPhase.
  enum class Phase { kDistribute, kReplay, kDone };
  void OnPhase(std::function<void(Phase)> hook) { phase_hook_ = std::move(hook); }

  /// Runs the loop; throws WorkItemsFailed when items failed. `threads` > 0 overrides the loop's
  /// thread count on one process (e.g. 1 when each item is parallel inside).
  void Run(const std::string& label, std::size_t n, const std::function<void(std::size_t)>& fn,
           int threads = 0) const;

  /// What one Run cost: its items' wall times (where they ran) and the loop's own wall time.
  struct LoopCost {
    std::string label;
    std::size_t items = 0;
    double item_s_total = 0.0, item_s_max = 0.0;
    double wall_s = 0.0;    ///< the whole loop, distribution and replay.
    double replay_s = 0.0;  ///< of which the replay (MPI).
  };
  /// Every Run so far, in order (on rank 0 of a job; empty on the others).
  std::vector<LoopCost> costs() const;

  int threads() const { return threads_; }
  /// True on an MPI job with more than one rank.
  bool distributed() const { return cluster_ != nullptr && cluster_->size() > 1; }
  bool is_root() const { return cluster_ == nullptr || cluster_->is_root(); }

 private:
  int threads_;
  cluster::Cluster* cluster_;
  std::string fault_;
  std::function<void(Phase)> phase_hook_;
  mutable std::mutex costs_mutex_;
  mutable std::vector<LoopCost> costs_;
};

/// WorkLoop(threads, nullptr).Run(label, n, fn).
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
  /// While muted, Done() counts nothing (an MPI replay of work already counted).
  void Mute(bool muted);

 private:
  std::function<void(double, const std::string&)> report_;
  std::mutex mutex_;
  double planned_ = 0.0, done_ = 0.0;
  bool muted_ = false;
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
/// run wrote it for the same study text, base scenario text, seed and build (BuildIdentity,
/// base/source_fingerprint.h). Trials get metadata `trial_hash` (hash of the content before it was
/// added). Files are written atomically, so an interrupted run leaves complete trials or none.
/// `timing` (may be null) receives the simulation time under "simulation".
StudyTrials GenerateStudy(const std::string& study_path, std::uint64_t seed,
                          const std::string& cache_dir, const WorkLoop& loop, Progress* progress,
                          Timing* timing = nullptr);
/// The same on `threads` threads of this process.
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
  /// While not counting (an MPI replay), fits_run/fits_cached stay as they are.
  void SetCounting(bool counting) { counting_ = counting; }

 private:
  ResultCache cache_;
  std::vector<identification::MethodEntry> methods_;
  Timing* timing_ = nullptr;
  std::mutex mutex_;
  int fits_run_ = 0, fits_cached_ = 0;
  std::atomic<bool> counting_{true};
};

/// The trial's `trial_hash` metadata (throws std::logic_error when absent).
const std::string& TrialHash(const Trial& trial);

/// Linear interpolation of `column` of `source` at `times` (NaN outside its time range).
std::vector<double> Resample(const Trial& source, const std::string& column,
                             const std::vector<double>& times);

}  // namespace fesim::paper_benchmark
