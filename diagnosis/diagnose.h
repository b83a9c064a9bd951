// `fesim diagnose` (PRODUCT.md "Diagnosis"): given measured trials of a person the model has never
// seen and the rig they came from, what the calibrated full model (12) of
// papers/000_0a6c0de9fc69df7c.txt gets wrong, which mechanism explains it, and what extending the
// model with it gains on held-out data — or `none`, or `unexplained` with the reason. The method
// is written out in docs/diagnosis.md; Diagnose() runs it as typed stages, each a free function:
//
//   split       measured.h    rows that count, checks against the rig, training / held-out split
//                             (several trials: the last held out whole; one: its last 30 %)
//   calibrate   person.h      the person: identifiable parameters, MAP fit with priors, intervals
//   reference   reference.h   the best black-box (reduced) model of the same training data and its
//                             held-out error: the fit quality a calibrated model should reach
//   signatures  signatures.h  descriptive residual figures for the report and the tremor start
//   screen      screening.h   robust score tests of every candidate (noise_model.h) against the
//                             calibrated model's coloured residual
//   extend      extension.h   candidate fits, forward selection with a backward step, refits,
//                             acceptance by robust LR and held-out Diebold–Mariano tests
//   verdict     verdict.h     the cause, its confidence, the reason in words
//
// With DiagnoseSettings::model set to a reduced model (`--model NAME`) that model is identified
// on the training part and takes the full model's place (reduced_model.h).
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <string>
#include <vector>

#include "base/result_cache.h"
#include "base/trial.h"
#include "diagnosis/extended_model.h"
#include "diagnosis/mechanisms/mechanism.h"
#include "diagnosis/person.h"
#include "diagnosis/signatures.h"
#include "sim/model_params.h"

namespace fesim::diagnosis {

/// What the diagnosis computes: every field changes results and enters the resume cache's key.
struct DiagnoseSettings {
  double holdout_fraction = 0.3;  ///< one trial: held-out tail share, (0, 0.8].
  /// Several trials: how many of the last are held out whole, ≥ 1 and < the number of trials.
  int heldout_trials = 1;
  int max_fitted = 3;    ///< candidates fitted per batch (and on top), ≥ 1.
  int max_screened = 6;  ///< first round: candidates fitted at most, ≥ 1.
  int max_accepted = 2;  ///< mechanisms accepted at most, ≥ 1.
  double alpha = 0.01;   ///< family-wise false-alarm level over the candidates.
  /// Smallest own part of a held-out NRMSE gain accepted (Judgement::own_gain), smallest gain of
  /// a structure outside the library, and of a cause named beside an about-equal alternative
  /// (verdict.h), dimensionless.
  double min_heldout_gain = 0.02;
  /// A held-out gain accepted without a significant Diebold–Mariano test, dimensionless.
  double clear_heldout_gain = 0.1;
  /// A calibrated model whose held-out NRMSE on an output exceeds reference_gate × the black
  /// box's plus reference_margin does not reach the black box there (verdict.h).
  double reference_gate = 1.5;
  double reference_margin = 0.02;
  /// Candidates with profile starts are profiled and fitted whatever their score test when the
  /// calibrated model's held-out NRMSE on some output exceeds profile_gate × the black box's
  /// (extension.h), ≥ 1.
  double profile_gate = 1.0;
  PersonCalibrationOptions person;
  int screen_iterations = 5;  ///< LM steps of a candidate's own parameters.
  int refit_iterations = 3;   ///< LM steps of an extension with the person parameters.
  /// Integrator and LM settings of every fit (FitOptions::threads is set from
  /// DiagnoseExecution::threads and is not part of the key).
  FitOptions fit = DefaultFitOptions();
  /// "full" (the full model (12)) or the name of a reduced model (reduced_model.h).
  std::string model = "full";
  static FitOptions DefaultFitOptions() {
    FitOptions f;
    // CVODES tolerance 1e-4 (sim::TaskTolerances::kDiagnosis): far below the 0.01 rad of a hand
    // tracker's noise, and the calibration of a foreign person reached a lower cost in half the
    // time of 1e-5 (an integration error much above it, speed_time_scale_s = 0.1 s, stopped LM at
    // 7× the cost; docs/diagnosis.md "Speed").
    f.tolerance = sim::TaskTolerances::kDiagnosis;
    // Speeds held to the angles' absolute tolerance (speed_time_scale_s = 0): stiction's fitted
    // frictions need accurate speeds (docs/performance.md, "`fesim diagnose` wall time").
    f.relative_tolerance = 1e-3;
    return f;
  }
  /// The settings as cache-key text.
  std::string KeyText() const;
};

/// Where items of a stage run: n items, each returning its result as text, results in index
/// order on every process that calls Diagnose (apps/diagnose_cmd.cc spreads them over MPI ranks
/// with cluster::Cluster::MapAll); throws naming the failed items.
using StageMap = std::function<std::vector<std::string>(
    std::size_t, const std::function<std::string(std::size_t)>&)>;

using DiagnoseProgress = std::function<void(double fraction, const std::string& stage)>;

/// How the diagnosis runs: nothing here changes a figure.
struct DiagnoseExecution {
  int threads = 2;  ///< simulation threads, ≥ 1.
  /// Resume cache (null: none): every stage's result is stored as it finishes, keyed by
  /// `cache_inputs` (the caller's identity of the rig and the measured data, e.g. file hashes),
  /// the settings and the stage's own inputs; a rerun reads them back instead of simulating.
  ResultCache* cache = nullptr;
  std::string cache_inputs;
  StageMap map;  ///< empty: the items run on `threads` threads here.
  DiagnoseProgress progress;
};

/// One candidate's figures.
struct CandidateResult {
  std::string id, joint, label;
  bool control = false;  ///< a control (mechanisms/mechanism.h Mechanism::control), never a cause.
  bool applicable = true;
  std::string not_applicable_reason;
  double score_statistic = 0.0;     ///< S of the robust score test (noise_model.h).
  int dof = 0;                      ///< its degrees of freedom (directions kept).
  double p_value = 1.0;             ///< of S (χ²_dof).
  double p_adjusted = 1.0;          ///< Bonferroni-adjusted over the applicable candidates.
  double score = 0.0;               ///< −log10 p_adjusted (0 = no evidence), for ranking.
  double variance_inflation = 1.0;  ///< noise variance along its directions / white variance.
  bool fitted = false;
  /// Fitted, but another joint of its mechanism had the lower training Σr² and was judged
  /// instead (Mechanism::joint_by_fit, extension.h): its figures are reported; it is neither a
  /// cause nor an alternative to one (verdict.h).
  bool not_judged = false;
  double lr_statistic = 0.0;   ///< robust LR of its fit on the calibrated model.
  double lr_p_adjusted = 1.0;  ///< Bonferroni-adjusted p of it (χ²_p).
  double heldout_nrmse = NAN;  ///< of the extended model (this candidate on the calibrated one).
  double heldout_gain = NAN;   ///< relative to the calibrated model.
  double heldout_z = NAN;      ///< Diebold–Mariano statistic of that gain.
  double heldout_p_adjusted = 1.0;  ///< its Bonferroni-adjusted one-sided p.
  /// Its own part of that gain: the fitted model with the candidate switched off against the
  /// fitted model, over the calibrated model's NRMSE (extension.h; NaN: not measured).
  double heldout_own_gain = NAN;
  double heldout_own_z = NAN;  ///< Diebold–Mariano statistic of the own part (NaN: not measured).
  /// The person's parameters of its joint at a bound of their range that kept it from being
  /// accepted (extension.h, Mechanism::mimics_joint_person); "": none.
  std::string person_at_bound;
  bool accepted = false;
  /// Second round (on top of the mechanism(s) accepted before it): S of its score test at the
  /// extended model (NaN: not tested there) and its held-out gain over that model (NaN: not
  /// fitted there).
  double score_on_accepted = NAN, heldout_gain_on_accepted = NAN;
  std::vector<NamedValue> parameters;  ///< fitted extension parameters.
  /// The parameter whose fit ended at its ModelParameter::collapses_at bound, where the
  /// mechanism is one the person parameters already describe: not accepted ("": none).
  std::string collapsed;
  /// Why the residual it was to explain contradicts its signature (Mechanism::
  /// shape_contradiction; "": consistent or not checked): not accepted.
  std::string shape;
  std::string decision;  ///< why accepted or not, one phrase.
  std::string evidence;  ///< test and signature figures, one line.
};

/// The black-box reference of one method (reference.h).
struct ReferenceResult {
  std::string method;          ///< best method ("" when none could be identified).
  double heldout_nrmse = NAN;  ///< mean over outputs.
  std::vector<double> heldout_nrmse_per_output;
  /// Every method tried: name and mean held-out NRMSE, or the reason it failed.
  std::vector<std::pair<std::string, std::string>> tried;
};

struct Diagnosis {
  std::string model = "full";  ///< DiagnoseSettings::model.
  std::string model_yaml;      ///< a reduced model as identified on the training part.
  std::string cause;           ///< a MechanismIds() entry, "none" or "unexplained".
  double confidence = 0.0;
  std::string reason;  ///< the verdict in words (always set; for `unexplained`: which outputs).
  double baseline_heldout_nrmse = 0.0, extended_heldout_nrmse = 0.0, gain = 0.0;
  std::vector<double> baseline_heldout_nrmse_per_output, extended_heldout_nrmse_per_output;
  std::vector<std::string> mechanisms;  ///< accepted candidate labels, in acceptance order.
  std::vector<std::string> mechanism_ids;
  std::vector<NamedValue> extension_parameters;  ///< of the final extended model.
  std::vector<PersonValue> person;               ///< the calibration (person.h).
  bool person_converged = false;  ///< its LM met a tolerance (not the iteration limit).
  std::vector<double> noise_rad;  ///< measured noise σ per output, rad.
  ReferenceResult reference;
  std::vector<CandidateResult> candidates;  ///< accepted first, then by score.
  std::vector<OutputSignature> signatures;
  std::string split;               ///< how the data were split, one line.
  std::vector<std::string> notes;  ///< pre-processing done to the input (resampling), one each.
  DataView heldout;                ///< for plots.
  std::vector<Trial> heldout_baseline, heldout_extended;  ///< predictions on the held-out trials.
  int simulations = 0;                                    ///< trial simulations in this run.
  int cached_results = 0;  ///< stages read back from the resume cache instead.
  double wall_s = 0.0;
};

/// Runs the whole diagnosis. `rig` is the scenario's model (free/locked coordinates, channels).
/// Throws std::runtime_error with a one-line reason on unusable trials (no q.* output, a joint
/// not free in the rig, unknown channel, too few samples, differing outputs across trials) and
/// std::invalid_argument on an unknown DiagnoseSettings::model.
Diagnosis Diagnose(const sim::ModelParams& rig, const std::vector<Trial>& measured,
                   const DiagnoseSettings& settings, const DiagnoseExecution& execution = {});

}  // namespace fesim::diagnosis
