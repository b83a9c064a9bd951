// The benchmark study file of `fesim benchmark` (issue 6): which virtual studies to generate,
// which identification methods to fit to them, and how (the papers' validation schemes,
// docs/papers.md).
//
//   benchmark: text                                   (required) name of the report
//   hand_array:      {study, quick_study, methods, options, full_model, quick_full_model,
//                     independent, quick_independent}
//                                                                  [Hand Hammerstein] Tables 1–2
//   elbow_tests:     {study, quick_study, methods, options}        [Le 2010] Tables 1–3
//   tremor_wrist:    {study, quick_study, methods, options}        [Copur 2016] Table 5
//   shoulder:        {study, quick_study, methods, options}        [Spagnol 2013]
//   reaching:        {scenario, quick_scenario, sparse_scenario, quick_sparse_scenario, methods,
//                     options}                                      [Schearer 2014]
//   assumptions:     {participants: 1–1000}                        [Hand Hammerstein] Assumptions
//   1–7
// Every section is optional (at least one is required). `study`/`quick_study` are study files
// (scenarios/study.h), absolute or relative to this file; `--quick` uses `quick_study` (shorter
// protocols, two participants). `methods` lists `fesim identify` names allowed for the section
// (default: all of them). `options` are method options passed as `fesim identify` trial metadata
// (`<prefix>.<key>: value`, e.g. `tremor.eps: 1.0e-5`). `full_model` sets the full-model fit's
// budget (`quick_full_model` the one --quick uses; default: full_model's):
//   {keep: 1–39, starts: 1–100, max_iterations: 1–1000, relative_tolerance: 1e-12–0.1,
//    integrator_tolerance: 1e-8–1e-2, fd_relative_step: 1e-8–0.1, broyden: true|false, rank_once:
//    true|false}  (the forward-difference step must be well above the integrator's relative error,
//    else the Jacobian is integration noise)  (rank once per participant on the first fold, then
//    fit the same K parameters in every fold; default true)
// reaching: `scenario` is the dense protocol of paper 004's subject without SCI (Fig. 5(a)),
// the optional `sparse_scenario` the sparse one of its subject with SCI (Fig. 5(b)), on which
// the section evaluates the paper's sparse-data finding.
// The hand_array study's first protocol is the paper's step grid (the cross-validation folds
// are its repetitions); an optional second protocol is an input the models never see in
// training, used for the prediction error against the noiseless truth. `independent` (and
// `quick_independent` for --quick; default: independent's) adds a cohort of the independent
// simulator, {participants: 0–100, seed: 0–1e9} (IndependentCohort).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "sim/task_tolerances.h"

namespace fesim {

struct BenchmarkSection {
  std::string study_path;        ///< study (or, for reaching, scenario) file, resolved.
  std::string quick_study_path;  ///< for --quick, resolved; empty = same as study_path.
  /// reaching only: the sparse scenario (paper 004's subject with SCI) and its --quick variant,
  /// resolved; empty = none.
  std::string sparse_path, quick_sparse_path;
  std::vector<std::string> methods;
  std::map<std::string, std::string> options;  ///< method options (trial metadata).
};

struct FullModelBudget {
  int keep = 8;
  int starts = 1;
  int max_iterations = 4;
  /// LM stops when the cost falls by less than this fraction (FullModelFitOptions::
  /// relative_tolerance), in [1e-12, 0.1].
  double relative_tolerance = 1e-6;
  double integrator_tolerance = sim::TaskTolerances::kStudyFullModelFit;
  double fd_relative_step = 1e-2;
  bool broyden = true;  ///< secant Jacobian updates (FullModelFitOptions::broyden).
  bool rank_once = true;
};

/// The hand array's second cohort: persons of the independent simulator (foreign/, its own
/// physics) given the study's own stimulation, fitted and validated like fesim's cohort — the
/// paper's participants were not made by model (12) either (docs/papers.md).
struct IndependentCohort {
  int participants = 0;    ///< persons drawn (foreign::DrawPerson); 0 = none.
  std::uint64_t seed = 1;  ///< the first person's seed; person i has seed + i.
};

struct BenchmarkSpec {
  std::string name;
  std::string path;
  std::string source_text;
  std::optional<BenchmarkSection> hand_array, elbow_tests, tremor_wrist, shoulder, reaching;
  FullModelBudget full_model;
  FullModelBudget quick_full_model;
  IndependentCohort independent;
  IndependentCohort quick_independent;
  int assumption_participants = 0;  ///< 0 = no assumption analysis.
};

/// Loads and validates a benchmark file; errors name the file, the key path and the range.
BenchmarkSpec LoadBenchmarkSpec(const std::string& path);

/// The same from the file's text; `path` names it in errors and anchors relative study files.
BenchmarkSpec ParseBenchmarkSpec(const std::string& text, const std::string& path);

/// The methods each section accepts, in report order.
const std::map<std::string, std::vector<std::string>>& BenchmarkSectionMethods();

}  // namespace fesim
