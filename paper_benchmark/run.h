// `fesim benchmark` (issue 6): every identifier of the papers (docs/papers.md) against the ground
// truth of a virtual cohort, with the papers' validation schemes and the layout of their tables.
//
// Sections (scenarios/benchmark_spec.h says which run and on which studies):
//  hand_array    [Hand Hammerstein] Tables 1–2: per participant and joint the normalised
//  cross-validation
//                error (fit on three of four step-grid data sets, validate on the fourth, all four
//                rotations, mean) of the full-model (12) fit and of the MIMO Hammerstein model,
//                and the time per local optimisation step.
//  elbow_tests   [Le 2010] Tables 1–3: identification, validation and cross-validation Best Fit of
//                Algorithms 1 and 2 for triangular ramp, filtered random noise, staircase, PRMS.
//  tremor_wrist  [Copur 2016] Table 5: the order sweep's validation / cross-validation Best Fit,
//  and
//                the identified tremor frequency and amplitude against the planted ones.
//  shoulder      [Spagnol 2013]: offline fit indices of models 1 and 2, EKF convergence times and
//                parameter estimates (trajectories plotted).
//  reaching      [Schearer 2014]: LOOCV normalised RMS torque error per joint of the three models
//                on the dense set (Fig. 5(a)) and the sparse set (Fig. 5(b), where the finding is
//                judged).
//  truth         what the papers could not do: prediction error of every reduced model against
//                the noiseless full model on inputs it never saw, parameter errors where a
//                parameter has a ground-truth counterpart, and (assumptions) how far the cohort's
//                ground truth is from [Hand Hammerstein]'s Assumptions, by switching that aspect of
//                the full model to the assumption and re-simulating.
// Outputs: DIR/report.md, DIR/results.json (every figure of the report), DIR/plots/*.png; the
// trials and fits are cached under DIR/cache/ so a killed run resumes.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "base/json.h"
#include "cluster/cluster.h"
#include "scenarios/benchmark_spec.h"

namespace fesim::paper_benchmark {

struct BenchmarkOptions {
  std::string out_dir = "out/benchmark";
  bool quick = false;      ///< the sections' quick studies (tests).
  int threads = 0;         ///< 0 = all cores.
  std::uint64_t seed = 1;  ///< sensor-noise seed of every study.
  /// Progress (fraction 0–1 and a label with the estimated time left); may be empty.
  std::function<void(double, const std::string&)> progress;
  /// The MPI job the run is spread over (issue 9); null or one rank: this process's threads.
  /// On a job every rank calls RunBenchmark; rank 0 writes report, results and plots; the
  /// ranks share DIR (and its cache) through the file system; `threads` is per rank (0 = 1).
  cluster::Cluster* cluster = nullptr;
  /// Fault injection for the failure-handling tests: the work item "<label> <index>" fails.
  std::string fail_item;
};

struct BenchmarkOutcome {
  Json results;        ///< what results.json holds.
  std::string report;  ///< report.md's text.
  double wall_s = 0.0;
};

/// Runs the benchmark and writes report.md, results.json and the plots atomically. Throws
/// WorkItemsFailed (work.h) when work items failed; what finished is cached for a rerun.
BenchmarkOutcome RunBenchmark(const BenchmarkSpec& spec, const BenchmarkOptions& options);

}  // namespace fesim::paper_benchmark
