// The sections of `fesim benchmark` (see run.h); internal to paper_benchmark/.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "base/json.h"
#include "paper_benchmark/work.h"
#include "scenarios/benchmark_spec.h"

namespace fesim::paper_benchmark {

/// What every section gets: the spec, the caches, the thread count and where plots go.
struct SectionContext {
  const BenchmarkSpec* spec = nullptr;
  bool quick = false;
  int threads = 1;
  std::uint64_t seed = 1;
  std::string cache_dir;  ///< DIR/cache.
  std::string plots_dir;  ///< DIR/plots.
  FitRunner* fits = nullptr;
  Progress* progress = nullptr;
  Timing* timing = nullptr;
  /// Where loops of independent items run (threads, or MPI ranks with a replay: work.h).
  const WorkLoop* loop = nullptr;
  /// False on the MPI ranks other than 0: they compute, rank 0 writes the plots and reports.
  bool write_outputs = true;
  int trials_simulated = 0;  ///< summed by the sections.
};

/// `compute()`'s result, or the cached one from an earlier run (or another MPI rank) under
/// `key` in ctx->fits' cache. For expensive work inside WorkLoop items that is not a fit.
Json CachedJson(SectionContext* ctx, const std::vector<std::string>& key,
                const std::function<Json()>& compute);

/// A section's figures (results.json) and its Markdown (report.md).
struct SectionResult {
  Json json = Json::Object();
  std::string markdown;
};

/// The section's study (its quick one with --quick), generated or read back from the cache; adds
/// the trials simulated to ctx->trials_simulated.
StudyTrials SectionStudy(const BenchmarkSection& section, SectionContext* ctx);

/// Items of a study as [participant][protocol][repetition] → item index (Study::items order:
/// participant-major, then protocol, then repetition).
struct StudyLayout {
  std::vector<std::string> protocols;  ///< in first-appearance order.
  int participants = 0, reps = 0;
  std::size_t Index(int p, int proto, int r) const {
    return (static_cast<std::size_t>(p) * protocols.size() + static_cast<std::size_t>(proto)) *
               static_cast<std::size_t>(reps) +
           static_cast<std::size_t>(r);
  }
};
StudyLayout LayoutOf(const Study& study);

SectionResult RunHandArray(const BenchmarkSection& section, SectionContext* ctx);
SectionResult RunElbowTests(const BenchmarkSection& section, SectionContext* ctx);
SectionResult RunTremorWrist(const BenchmarkSection& section, SectionContext* ctx);
SectionResult RunShoulder(const BenchmarkSection& section, SectionContext* ctx);
SectionResult RunReaching(const BenchmarkSection& section, SectionContext* ctx);

/// Progress weights (≈ seconds on one core) of the work units, shared by the plan in
/// RunBenchmark and the sections' Done() calls.
inline constexpr double kTrialWeightPerSecond = 0.003;  ///< per simulated second.
inline constexpr double kHammersteinFitWeight = 0.6;
inline constexpr double kSplineFitWeight = 0.1;
inline constexpr double kTremorParticipantWeight = 2.0;
inline constexpr double kShoulderFitWeight = 0.5;
inline constexpr double kReachingWeight = 5.0;
inline double FullModelFitWeight(const FullModelBudget& b) {
  return 0.3 * b.keep + 0.4 * b.max_iterations;
}

// Small shared helpers.

/// Mean of the finite values (NaN when none).
double MeanFinite(const std::vector<double>& v);
/// Sample standard deviation of the finite values (0 for fewer than two).
double StdFinite(const std::vector<double>& v);
/// Markdown number with `digits` decimals ("–" for NaN).
std::string Fixed(double v, int digits);
/// The value of top-level key `key` of an identified model's YAML (`key: {value: v, …}`), NaN
/// when absent.
double ModelYamlValue(const std::string& model_yaml, const std::string& key);
/// The values of the mapping `key` of an identified model's YAML (`key: {k1: {value: v}, …}`),
/// in file order; empty when absent.
std::vector<double> ModelYamlList(const std::string& model_yaml, const std::string& key);
/// The value at the nested key `path` of an identified model's YAML (`a: {b: {c: {value: v}}}`
/// for path {a, b, c}), NaN when absent.
double ModelYamlAt(const std::string& model_yaml, const std::vector<std::string>& path);
/// A finding: "holds"/"does not hold" and the margin, as JSON and one Markdown line.
Json Finding(const std::string& claim, bool holds, const std::string& margin);
std::string FindingLine(const Json& finding);

// The steps of RunBenchmark (run.cc).

/// The report's findings table (appended to *md: one row per finding of every section, in the
/// sections' order) and results.json "findings" (each finding with its "section").
Json FindingsSummary(const Json& sections, std::string* md);

/// What R single-threaded MPI ranks would take, from a run's loop costs (`wall_s` the run's wall
/// time; results.json "scaling_estimate", its table appended to *md), for R = 1, 2, 4, 8, 16, 64:
/// the loops' items spread over R ranks, the rest serial. Bounds for dynamic assignment of each
/// loop: at least max(longest item, sum / R), at most sum / R + longest item (1 − 1/R); each
/// loop's replay time added. Meaningful from a run with one thread per rank (item times are
/// then single-thread times).
Json ScalingEstimate(const std::vector<WorkLoop::LoopCost>& costs, double wall_s, std::string* md);

/// A rank's work counters, summed over the ranks on rank 0 of an MPI job.
struct WorkCounters {
  int trials_simulated = 0, fits_run = 0, fits_cached = 0;
  std::map<std::string, double> by_kind;  ///< thread-seconds by kind of work (Timing).
  Json ToJson() const;
};
/// The sum of the ranks' counters, each as WorkCounters::ToJson's text.
WorkCounters SumWorkCounters(const std::vector<std::string>& per_rank);

}  // namespace fesim::paper_benchmark
