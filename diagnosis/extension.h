// Stages "extend" and "refit" of `fesim diagnose` (diagnose.h): candidate mechanisms fitted on
// top of the calibrated person, judged, and the model extended with those that pass.
//
// Control. When the calibration stopped at its iteration limit, the person alone is refitted as
// many LM steps as a candidate's fit gets; that refit, not the calibration, is what the candidates
// are judged against (otherwise any candidate is credited with the calibration's own progress).
// A candidate fitted from a profile start (below) may lead the person to a better minimum than
// the calibration's (a foreign wander's calibration stopped at held-out NRMSE 0.63, the person
// fitted with crosstalk held at 0.15 and then released reached 0.17 with crosstalk ≈ 0): the
// person alone is refitted from where that fit ended. The candidate must pass against the control
// and against that person (the weaker judgement counts); when that person beats the control on
// training Σr² and on held-out NRMSE it becomes the control every candidate of that batch and
// after is judged against (baseline_note says so). A person refitted to a lower training Σr² but
// a worse held-out NRMSE (a clean foreign person: 0.142 against the calibration's 0.118) would
// otherwise credit the candidate with the calibration's better prediction. Every candidate fit
// frees the person too: when a fit of a batch, its candidate switched off (the ablation of
// Judgement::own_gain), predicts the held-out trial better than the control by more than
// clear_heldout_gain, the person alone is refitted from there and offered the same way (foreign
// moment_arm_posture 1006: the calibration's held-out NRMSE 0.517, the person from the
// passive_asymmetry@mcp fit 0.359). A person fitted beside a candidate can take part of a real
// effect: adopted at 4.4 % better, such persons left foreign potentiation (1002) and
// force_length_velocity (1007) too little gain to be named. When the first screen adopts a
// control and no candidate passes, the score tests are run again at the control and the screen
// is repeated once (RescreenAtControl): the tests that chose which candidates to fit were at the
// calibration's residual.
//
// Screening. The candidates whose robust score test passes (p_adj < alpha), the best-scoring
// joint per id, up to max_screened, are fitted in batches of max_fitted while none passes: their
// own parameters from the test's Gauss–Newton step (Candidate::start_from_step), fitted together
// with all the person parameters (screen_iterations LM steps, person priors on; their columns
// from the forward-sensitivity integration). A mechanism whose
// joint is chosen by the fit (Mechanism::joint_by_fit: tremor) is fitted at each joint of a
// significant test, here and on top, and only its fit of lowest training Σr² is judged: the
// choice uses the training data alone, so the held-out test stays one test per mechanism
// (DiagnoseForeign.AWristTremorIsNamedAtTheWristWhereAFingerJointScoresHigher). When the calibrated
// model predicts some output worse than the black box (`reference_gap`: held-out NRMSE above
// DiagnoseSettings::profile_gate × the black box's, verdict.h ReferenceGaps), a
// candidate with profile starts (Candidate::profile_starts: arm_support, crosstalk) is fitted
// whatever its score test, and also from the lowest of the person fits with it held at each
// (two parabolic refinements when one parameter varies, ParabolaVertex); the lower Σr² is kept:
// a mechanism that the person parameters mimic along a curved valley (a strong crosstalk that
// stronger, stiffer muscles half-reproduce) leaves little along its direction at "off", where
// the test looks, and much beyond it — and leaves the calibrated model short of the black box
// (DiagnoseForeign.ACrosstalkThePersonAbsorbsIsProfiledWhereTheModelIsWorseThanTheBlackBox).
// Without such a gap the profile is not run (its person fits, up to the calibration's iteration
// limit each, cost more than the rest of the screen: 130 of 285 s on the clean
// BM_DiagnoseClean3x60s, docs/performance.md).
//
// Acceptance (Judgement): a fit passes when
//   robust LR (noise_model.h) of its training residual against the model it extends:
//     p_adj(χ²_p) < alpha;
//   held-out gain g = (x − y)/x of the held-out NRMSE: g > 0 with a Diebold–Mariano p_adj <
//     alpha (× max_screened fits), or g > clear_heldout_gain without: with one held-out trial a
//     slow gain (fatigue, potentiation) has an effective sample of about one and cannot reach
//     significance, while a clean person's misfit absorbed by a candidate gains ~2 % with an
//     insignificant test (DiagnoseForeign.ACleanPersonIsNone…). A significant gain needs no size:
//     near the noise floor a real effect's share of the held-out NRMSE is small (an in-family
//     crosstalk at 4.4 × noise on a calibrated model at 0.053: 1.6 %, z 6.3; docs/diagnosis.md);
//   its own part (Judgement::own_gain) > 0 with a Diebold–Mariano p_adj < alpha (the fit
//     against itself with the candidate off), or > min_heldout_gain without: a tremor's
//     spectral line at the noise RMS is all its own gain and small (foreign 6008: 1.7 %, z 6.9);
//   no parameter ended where the mechanism collapses into the person (collapses_at), and none at
//     a bound of its plausible range other than its "off" start (ParameterAtRangeBound): a
//     posture ratio of ±6 or a 5-fold v_max is no person's, it is the fit soaking up a misfit the
//     person calibration leaves (clean foreign persons, docs/diagnosis.md).
// The passing candidate of largest held-out gain is accepted (its fit, refitted when LM had not
// converged). Then forward selection up to max_accepted: the score tests repeated at the
// extended model (its parameters' Jacobian projected out; candidates insignificant with the first
// round's directions at twice their statistic are not probed again), the best max_fitted fitted on
// top (start: their own first-round fit when it passed its training test, else the new test's
// step), the passing one of largest held-out gain over the extended model accepted; then a
// backward step drops an earlier mechanism that no longer passes on top of the others (refitted
// without it), for good.
//
// Controls (mechanisms/mechanism.h Mechanism::control) go through all of this like mechanisms
// and may be accepted; they do not count towards max_accepted, and the cause is the first
// accepted candidate that is not a control (ExtensionOutcome::cause).
//
// Refit: when an accepted mechanism lists further difference steps or scanned starts
// (Candidate::refit_fd_steps, refit_scan_*: stiction), the extended model is refitted from its
// fit at each step and from the scanned point of lowest training Σr²; the lowest Σr² is kept.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "diagnosis/screening.h"

namespace fesim::diagnosis {

/// What the verdict needs of the extension.
struct ExtensionOutcome {
  /// The model the candidates were judged against: the calibration, or — when its LM stopped at
  /// the iteration limit — the person refitted screen_iterations more steps (baseline_refit).
  bool baseline_refit = false;
  /// Why the control is not the calibration ("": it is), for the report's notes.
  std::string baseline_note;
  FitResult baseline_fit;
  std::vector<Trial> baseline_heldout_predictions;
  std::vector<int> accepted;           ///< library indices, in acceptance order.
  std::vector<ModelParameter> params;  ///< person ⊕ accepted mechanisms' parameters.
  FitResult fit;                       ///< the extended model's (empty when none accepted).
  std::vector<Trial> heldout_predictions;
  double heldout_nrmse = NAN;
  /// The cause: the first accepted candidate that is not a control (library index; −1: none —
  /// no candidate, or controls only). Its training-test p and held-out gain as accepted (on the
  /// calibrated model when it was screened there and passed first, else on top of the candidates
  /// accepted before it).
  int cause = -1;
  double cause_lr_p = 1.0, cause_gain = 0.0;
  /// Held-out NRMSE of the model a candidate was fitted on top of (second round), by library
  /// index (NaN: not fitted on top).
  std::vector<double> on_top_reference;
};

/// The held-out part of the acceptance (above): a gain g > 0 (held-out NRMSE, dimensionless)
/// whose Diebold–Mariano p_adj (over max_screened fits) is below settings.alpha, or g >
/// settings.clear_heldout_gain whatever the test. NaN figures do not pass.
bool HeldoutGainAccepted(double gain, double dm_p_adjusted, const DiagnoseSettings& settings);

/// The own-part condition of the acceptance (above): the candidate's own part g_own of the
/// held-out gain (NaN: not measured, which passes) is positive with a Diebold–Mariano p_adj (the
/// fit against itself with the candidate switched off, over max_screened fits) below
/// settings.alpha, or exceeds settings.min_heldout_gain whatever the test.
bool OwnGainAccepted(double own_gain, double dm_p_adjusted, const DiagnoseSettings& settings);

/// Screening, forward selection with the backward step, and the refit (see above). Fills the
/// fit figures of `results` (library order). `baseline_directions`: the first screen's probe
/// directions (empty when it came from the resume cache: probed again when needed).
ExtensionOutcome Extend(const StageContext& ctx, const std::vector<Candidate>& library,
                        const CalibrationStage& calibration,
                        const std::vector<ModelParameter>& person, const ScreenStage& screen,
                        std::map<int, Eigen::MatrixXd> baseline_directions, bool reference_gap,
                        std::vector<CandidateResult>* results);

}  // namespace fesim::diagnosis
