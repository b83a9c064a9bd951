// `fesim diagnose` (PRODUCT.md "Diagnosis", issue 7): what the calibrated full model (12) of
// papers/000_0a6c0de9fc69df7c.txt gets wrong on measured trials, which mechanism explains it, and
// what extending the model with it gains on held-out data. With DiagnoseOptions::model set to a
// reduced model (`--model NAME`), that model is identified on the training part first and takes
// the full model's place below (reduced_model.h: which mechanisms can extend it, and how).
//
// 1. Split. Several trials: the last one is held out whole, the others train. One trial: blocked
//    segments — the first (1 − holdout_fraction) of the record trains, the rest is held out, so
//    time-dependent effects are judged later in time than the fit.
// 2. Baseline. The subject parameters (candidates.h: joint stiffness k_j, per-channel input
//    scale) are fitted by bounded LM on the training part (extended_model.h), from each of
//    SubjectStarts (the nominal values; on an elbow / shoulder output also the strength–stiffness
//    corners, where the forearm's weight makes Σr² multimodal), the lowest Σr² kept.
// 3. Signatures. For every candidate the residual signature is a score (Lagrange multiplier)
//    test of "mechanism off": with r the training residual, D the change of the residual along
//    the candidate's probe directions and D̃ = (I − J_s (J_sᵀJ_s)⁻¹ J_sᵀ) D its part that the
//    subject parameters cannot produce (J_s their Jacobian),
//        S = rᵀ D̃ (D̃ᵀD̃)⁻¹ D̃ᵀ r / σ²,   σ² = rᵀr / (N − p_s),   S ~ χ²_dof under "off";
//    one-sided probes (rates, frictions, gains) whose Gauss–Newton coefficient
//    θ = −(D̃ᵀD̃)⁻¹ D̃ᵀ r comes out negative are dropped. False alarms across the M applicable
//    candidates are controlled by Bonferroni: p_adj = min(1, M p). Descriptive signatures
//    (signatures.h: spectrum peak, trend, lag, velocity/posture correlation) fill `evidence`.
// 4. Extension. The best `max_fitted` candidates with p_adj < alpha (one joint per id) are fitted
//    (their own parameters from θ, the subject parameters held; while none of those fitted
//    passes, or the best that passes leaves structure in the held-out residual
//    (batches_while_structured), the next `max_fitted` by score, up to `max_screened` in all:
//    default-suite crosstalk seed 1041 ranked 4th behind candidates that fail, and on the grid
//    4th–5th behind moment_arm_posture, which passed with structure left), and scored: training
//    likelihood ratio LR = N ln(RSS₀/RSS₁) ~ χ²_p (Bonferroni-adjusted as above, an information
//    criterion) and held-out gain g = (x − y)/x of the held-out NRMSE. Accepted when p_adj(LR) <
//    alpha and g > min_heldout_gain, unless a parameter of its fit ended where the mechanism
//    collapses into a subject parameter (ModelParameter::collapses_at: potentiation's shortest rise
//    time, a constant gain that stood in for the calibration on default-suite crosstalk seed 1042);
//    greedily, the best g first (then refitted with the subject
//    parameters, unless its polished screening fit below stopped on LM's tolerance: then that
//    is the refit). Then forward selection on top of the extended model, up to max_accepted
//    mechanisms: the score tests of step 3 are repeated at the extended model (its residual, the
//    Jacobian of all its parameters projected out, same Bonferroni M) for the ids not accepted
//    yet, screened first with step 3's probe directions (no simulation): a candidate whose
//    statistic with them stays insignificant at twice its value keeps that statistic, the
//    others are tested with directions simulated on top of the extended model. The
//    best-scoring max_fitted (one joint per id) are fitted on top of it (profiled and
//    polished as below; start: the candidate's own screening fit when it passed its training
//    test, else the Gauss–Newton step of the new test), and the one with the largest held-out
//    gain over the extended model among those that pass LR (against the extended model's RSS)
//    and g > min_heldout_gain is accepted; its polished fit is the new extended model. A
//    backward step follows: an earlier mechanism that no longer passes both tests on top of
//    the others (compared with their refit without it) is dropped for good (a first pick that
//    stood in for the later ones), and the search goes on. (The second round once took its
//    candidates from the baseline's ranking and, through the cache text, lost the Jacobian it
//    meant to profile with, so its fits froze the subject parameters and the first mechanism:
//    run C's and session 5's pair misses, docs/diagnosis.md.)
//    Last, when an accepted mechanism lists further difference steps or scanned starts
//    (Candidate::refit_fd_steps, refit_scan_*: stiction), the extended model is refitted
//    (refit_iterations LM steps each) from its fit at each step, and from the scanned point of
//    lowest training Σr² (one parameter × each factor) at each step and the default one; the
//    lowest Σr² of all is kept: its parameters, held-out NRMSE and gain are reported (the names
//    accepted do not change). (Stiction's static excess stalled 22–42 % off on 5 of the 10
//    default-suite datasets at the default step; within 8 % on 10/10 with this refit;
//    docs/diagnosis.md, sessions 10–11.)
//    A candidate with profile starts (Candidate::profile_starts: arm_support's force at 10, 20,
//    …, 50 % of the forearm weight) is also fitted from the lowest of the subject fits with it
//    held there (from every subject start and the calibration; when the lowest is an inner
//    profile point, two more at the vertex of the parabola through it and its neighbours), all
//    parameters free; the screening keeps the lower Σr² of that and the profiled fit (sessions
//    12–13: arm_support 0/10 → 9/10 → 10/10).
//    During a candidate's own fit (screening) the subject parameters are profiled, not frozen:
//    re-optimised to first order through their baseline Jacobian J_s (variable projection,
//    FitParameters' `nuisance`), so the fit minimises ‖(I − P_s) r‖² like the score test; then,
//    from the subject parameters moved by their linearised step, all parameters are polished
//    together (refit_iterations LM steps) and LR and held-out gain use that fit. (Freezing
//    them lost crosstalk: the baseline had taken its gain on the reached muscles into
//    strength_scale, so any crosstalk fraction made the frozen fit worse.) The second-round fit
//    treats the first extension's parameters the same way.
//    Simulations are not repeated: a fit that starts where another ended (the refit of an
//    accepted extension from its polished screening fit) takes that fit's residual and
//    Jacobian (FitStart), the baseline's training predictions are its fit's, and output drifts
//    (sensor_drift) are added to the baseline's simulations (probes) and differentiated
//    analytically (Jacobian column −t) instead of simulated. The screening fits of the
//    candidates run side by side.
// 5. Verdict. Nothing accepted: `none`, unless the held-out residual of the baseline keeps
//    structure (StructuredVarianceFraction > max_structure on some output): `unexplained`.
//    Otherwise the first accepted mechanism, confidence
//        c = (1 − p_adj(LR)) · (1 − g_alt / g),  g_alt = best held-out gain of another id not
//    accepted (on the baseline, less the NRMSE share it still removes when fitted on top of the
//    accepted ones, which it does not explain in their place),
//    capped at 0.4 when structure remains after the extension (never a confident wrong name).
//    `none`: c = 1 − 0.5 min(1, g_best / min_heldout_gain); `unexplained`: c = min(1, 0.5 +
//    0.5 s / max_structure) with s the remaining structured fraction.
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <string>
#include <vector>

#include "diagnosis/candidates.h"
#include "diagnosis/extended_model.h"
#include "diagnosis/measured.h"
#include "identification/method.h"
#include "scenarios/result_cache.h"
#include "scenarios/trial.h"
#include "sim/model_params.h"

namespace fesim::diagnosis {

struct DiagnoseOptions {
  double holdout_fraction = 0.3;  ///< one trial: held-out tail share, (0, 0.8].
  int max_fitted = 3;             ///< candidates fitted per batch (and on top), ≥ 1.
  /// First round: candidates fitted at most, in batches of max_fitted while none passes, ≥ 1.
  int max_screened = 6;
  /// First round: a further batch also while the best candidate that passes leaves structure
  /// (StructuredVarianceFraction > max_structure on some output) in the held-out residual.
  bool batches_while_structured = true;
  int max_accepted = 2;            ///< mechanisms accepted at most, ≥ 1.
  double alpha = 0.01;             ///< family-wise false-alarm level over the candidates.
  double min_heldout_gain = 0.02;  ///< smallest held-out NRMSE gain accepted, dimensionless.
  double max_structure = 0.15;     ///< structured residual variance share above which structure
                                   ///< "remains", dimensionless.
  int baseline_iterations = 4;     ///< LM steps of the subject calibration.
  /// Difference steps of the subject calibration (FitOptions::fd_step for that fit only; 0:
  /// fit.fd_step), non-empty: one calibration from the nominal start per entry, side by side;
  /// the lowest training Σr² is kept.
  std::vector<double> baseline_fd_steps = {0.0};
  int screen_iterations = 5;             ///< LM steps of a candidate's own parameters.
  int refit_iterations = 3;              ///< LM steps of the accepted extension with the subject.
  FitOptions fit = DefaultFitOptions();  ///< integrator, threads, finite differences.
  /// The simulation calibrated and extended: "full" (the full model (12)), or the name of a
  /// reduced model (reduced_model.h), which `reduced_fit` identifies on the training part first.
  std::string model = "full";
  identification::FitSimulatorFn reduced_fit;  ///< required unless model == "full".
  /// Resume cache (null: none). The baseline calibration, the score tests and every extension
  /// fit (screening, refits) are stored as they finish, keyed by `cache_inputs` (the caller's
  /// identity of the rig and the measured data, e.g. hashes of the files), these options (not
  /// `fit.threads`, which does not change results) and the stage's own inputs; a rerun reads
  /// them back instead of simulating, so an interrupted diagnosis resumes where it stopped.
  ResultCache* cache = nullptr;
  std::string cache_inputs;
  /// Where the independent items of a stage run (issue 9): the score tests' probe simulations
  /// and the screening fit of each candidate. Called with n and an item function that returns
  /// the item's result as text; returns the n results in index order (on every process that
  /// calls Diagnose) or throws naming the failed items. Empty: on fit.threads threads here
  /// (probes; screening fits, each with its simulations on fit.threads threads again).
  /// apps/diagnose_cmd.cc sets it to spread the items over the ranks of an MPI job
  /// (cluster::Cluster::MapAll).
  std::function<std::vector<std::string>(std::size_t,
                                         const std::function<std::string(std::size_t)>&)>
      map;
  static FitOptions DefaultFitOptions() {
    FitOptions f;
    f.tolerance = 1e-5;
    // Speeds held to the angles' absolute tolerance (speed_time_scale_s = 0). 0.1 s makes
    // simulations with a tremor 1.9× and clean ones 1.6× cheaper, but stiction's fitted
    // frictions then come out 23–94 % off (1–8 % at 0): velocity-dependent forces need accurate
    // speeds (docs/performance.md, issue 7).
    f.relative_tolerance = 1e-3;
    return f;
  }
};

/// One named value with its 95 % half-width (NaN: not estimable).
struct NamedValue {
  std::string name, unit;
  double value = 0.0, ci95 = NAN;
};

struct CandidateResult {
  std::string id, joint, label;
  bool applicable = true;
  std::string not_applicable_reason;
  double score_statistic = 0.0;  ///< S of the score test.
  int dof = 0;                   ///< its degrees of freedom (probes kept).
  double p_adjusted = 1.0;       ///< Bonferroni-adjusted p of S.
  double score = 0.0;            ///< −log10 p_adjusted (0 = no evidence), for ranking.
  bool fitted = false;
  double lr_p_adjusted = 1.0;  ///< Bonferroni-adjusted p of the training LR.
  double heldout_nrmse = NAN;  ///< of the extended model (this candidate on the baseline).
  double heldout_gain = NAN;   ///< relative to the baseline.
  bool accepted = false;
  /// Second round (on top of the mechanism(s) accepted before it): S of its score test at the
  /// extended model (NaN: not tested there) and its held-out gain over that model (NaN: not
  /// fitted there).
  double score_on_accepted = NAN, heldout_gain_on_accepted = NAN;
  std::vector<NamedValue> parameters;  ///< fitted extension parameters.
  /// The parameter whose fit ended at its ModelParameter::collapses_at bound, where the
  /// mechanism is one the subject parameters already describe: not accepted ("": none).
  std::string collapsed;
  std::string evidence;  ///< signature figures, one line.
};

/// Residual summaries of one output (training part unless stated).
struct OutputSignature {
  std::string output;
  double rms_rad = 0.0;
  double spectrum_peak_hz = 0.0, spectrum_peak_ratio = 0.0;  ///< 3–12 Hz.
  double corr_time = 0.0, corr_cumulative_stimulation = 0.0;
  double corr_velocity = 0.0, corr_velocity_sign = 0.0, corr_posture = 0.0;
  double input_lag_s = 0.0, input_lag_corr = 0.0;  ///< strongest input–residual lag.
  std::string input_lag_column;
  double structure_heldout_baseline = 0.0, structure_heldout_extended = 0.0;
};

struct Diagnosis {
  std::string model = "full";  ///< DiagnoseOptions::model.
  std::string model_yaml;      ///< a reduced model as identified on the training part.
  std::string cause;           ///< a MechanismIds() entry, "none" or "unexplained".
  double confidence = 0.0;
  double baseline_heldout_nrmse = 0.0, extended_heldout_nrmse = 0.0, gain = 0.0;
  std::vector<std::string> mechanisms;  ///< accepted candidate labels, in acceptance order.
  std::vector<std::string> mechanism_ids;
  std::vector<NamedValue> extension_parameters;  ///< of the final extended model.
  std::vector<NamedValue> subject_parameters;    ///< baseline calibration.
  std::vector<CandidateResult> candidates;       ///< ranked by score, then held-out gain.
  std::vector<OutputSignature> signatures;
  std::string split;  ///< how the data were split, one line.
  std::vector<std::string>
      notes;         ///< pre-processing done to the input (resampling), one line each.
  DataView heldout;  ///< for plots.
  std::vector<Trial> heldout_baseline, heldout_extended;  ///< predictions on the held-out trials.
  int simulations = 0;                                    ///< trial simulations spent in this run.
  int cached_results = 0;  ///< stages read back from DiagnoseOptions::cache instead.
  double wall_s = 0.0;
};

using DiagnoseProgress = std::function<void(double fraction, const std::string& stage)>;

/// Runs the whole diagnosis. `rig` is the scenario's model (free/locked coordinates, channels).
/// Throws std::runtime_error with a one-line reason on unusable trials (no q.* output, a joint
/// not free in the rig, unknown channel, too few samples, differing outputs across trials).
Diagnosis Diagnose(const sim::ModelParams& rig, const std::vector<Trial>& measured,
                   const DiagnoseOptions& options, const DiagnoseProgress& progress = {});

}  // namespace fesim::diagnosis
