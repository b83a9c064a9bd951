// What every stage of `fesim diagnose` (diagnose.h) shares: the rig, the prepared data, the
// settings, the fit options with the execution's threads, the typed resume cache, where items
// run, progress, and the simulation count; plus the calibration stage's result, which every
// later stage builds on.
#pragma once

#include <Eigen/Dense>
#include <atomic>
#include <string>
#include <vector>

#include "diagnosis/diagnose.h"
#include "diagnosis/measured.h"
#include "diagnosis/noise_model.h"
#include "diagnosis/stage_cache.h"

namespace fesim::diagnosis {

struct StageContext {
  const sim::ModelParams& rig;
  const MeasuredData& data;
  const LibraryContext& library;  ///< outputs, channels, tremor starts, reduced model.
  const DiagnoseSettings& settings;
  FitOptions fit;  ///< settings.fit with the execution's threads (and a reduced simulator).
  const StageCache& cache;
  const StageMap& map;  ///< empty: items on fit.threads threads here.
  const DiagnoseProgress& progress;
  RowLayout train_rows, heldout_rows;  ///< LayoutOf(data.train / data.heldout).
  std::atomic<int>* simulations;

  void Report(double fraction, const std::string& stage) const;
  /// Runs n items through `map` or on fit.threads threads here.
  std::vector<std::string> Map(std::size_t n,
                               const std::function<std::string(std::size_t)>& fn) const;
};

/// The calibrated person and what it predicts (stage "calibrate").
struct CalibrationStage {
  std::vector<std::string> fitted_names;  ///< PersonParameters calibrated (the rest nominal).
  FitResult fit;                          ///< over them (no Jacobian: `jacobian` below).
  Eigen::MatrixXd jacobian;  ///< ∂r/∂x of the fitted parameters at fit.x, training rows.
  std::vector<Trial> train_predictions, heldout_predictions;
  std::vector<PersonValue> table;
  std::vector<double> noise_rad;
  double prior_sigma_rad = 0.0;
  int starts = 0;
};
Json ToJson(const CalibrationStage& s);
void FromJson(const Json& j, CalibrationStage* s);
Json ToJson(const ReferenceResult& r);
void FromJson(const Json& j, ReferenceResult* r);

/// Stage "calibrate": CalibratePerson on the training view (person.h), held-out predictions;
/// `corner_starts_only`: the retry from the corner starts (PersonCalibrationOptions).
CalibrationStage Calibrate(const StageContext& ctx, bool corner_starts_only = false);
/// The fitted person parameters of a calibration (PersonParameters by name, in its order).
std::vector<ModelParameter> FittedPersonParameters(const StageContext& ctx,
                                                   const CalibrationStage& calibration);

/// Stage "reference": FitReference (reference.h) on the split.
ReferenceResult Reference(const StageContext& ctx);

}  // namespace fesim::diagnosis
