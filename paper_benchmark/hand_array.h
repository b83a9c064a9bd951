// The steps of the hand-array section (RunHandArray, sections.h); internal to paper_benchmark/,
// declared here for tests/paper_benchmark/hand_array_test.cc.
#pragma once

#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "base/json.h"
#include "paper_benchmark/sections.h"
#include "sim/model_params.h"

namespace fesim::paper_benchmark {

/// Per-joint figures of one fold of one model.
struct FoldFigures {
  std::vector<double> error;        ///< vs the held-out measured data set, per joint.
  std::vector<double> truth_error;  ///< vs the noiseless truth of the unseen input, per joint.
  double step_wall_s = NAN;         ///< time per local optimisation step.
  int iterations = 0;  ///< LM iterations of the (first) local optimisation; 0 = not an LM fit.
  std::map<std::string, double> parameters;  ///< identified values with a truth counterpart.
};

/// A fold's figures as cached (FoldFromJson reads them back).
Json FoldJson(const FoldFigures& f);
FoldFigures FoldFromJson(const Json& j);

/// Throws, naming the study file `path`, unless the study has at least two data sets per
/// participant (the folds) and at most two protocols (the step grid and an unseen input).
void CheckHandArrayLayout(const std::string& path, const StudyLayout& layout);

/// The A5 switch: every moment arm constant at its value in the rig's initial posture, lengths
/// unchanged there (Assumption 5 of [Hand Hammerstein], docs/papers.md: R(y) ≈ fixed R).
void FixTendonMatrix(sim::ModelParams* m);

/// One of the Assumptions of [Hand Hammerstein] that the simulator can switch on in the truth.
struct AssumptionSwitch {
  std::string id, text;
  std::function<void(sim::ModelParams*)> apply;
};
/// A3, A5, A6 and A7 (force-velocity part).
std::vector<AssumptionSwitch> AssumptionSwitches();

/// One model's column group in Tables 1–2: its name ("full model (12)") and every fold's figures
/// ([participant × folds + fold]); `on` false when the section does not fit it.
struct HandArrayModel {
  std::string name;
  const std::vector<FoldFigures>* folds = nullptr;
  bool on = false;
};

/// Tables 1–2 of [Hand Hammerstein]: per participant the mean over folds of every joint's
/// normalised error and of the local step time, the mean row and the paper's row.
struct HandArrayTables {
  Json rows = Json::Array();    ///< results.json "table": one object per participant.
  Json means = Json::Object();  ///< results.json "mean".
  std::string markdown;         ///< header, participant rows, mean row, paper row.
  /// [model][joint]: mean over participants of the fold means (0 for a model that is off).
  std::vector<std::vector<double>> mean_error;
  std::vector<std::vector<double>> steps;  ///< [model]: every fold's local step time.
};
/// models[0] is the full model (step times with 1 decimal), models[1] the Hammerstein model (4);
/// `joints` are the q.* columns.
HandArrayTables TablesOneTwo(const std::array<HandArrayModel, 2>& models,
                             const std::vector<std::string>& joints, int participants, int folds);

/// Mean activation natural frequency Ω_i (rad/s) of the muscles that cross a forearm joint
/// (wrist or finger, coordinate index ≥ 5): the value Assumption 6's common Ω stands for.
double ForearmMeanOmega(const sim::ModelParams& model);

/// The upper median (element size/2 after sorting) of `v`; NaN when empty.
double UpperMedian(std::vector<double> v);

}  // namespace fesim::paper_benchmark
