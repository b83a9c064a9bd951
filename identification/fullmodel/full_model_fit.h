// Fit of the full model (12) of [Hand Hammerstein] to trial records, as in its §5.1:
//   y = H_RB · R · H_hill · H_IRC · A · u                                               eq. (12)
// (1) sensitivity analysis of the output to every candidate parameter, keep the K most influential
// (the paper kept 29: the array matrix A, joint stiffness k_i, recruitment β_i, γ_i and two
// parameters of R); (2) multi-start local optimisation of the kept parameters on the simulated
// (not one-step-ahead) joint angles.
//
// The model is the ground-truth simulator itself (sim/, Simbody + CVODES): every residual
// evaluation builds an `UpperLimbModel` for the parameter vector and runs each training trial
// through `RunTrial`. This is the one identification method that depends on sim/, so it lives in
// its own target (fesim_fullmodel) and identification/'s core stays Eigen-only.
//
// Candidate parameters (all on the rig `base`, a ModelParams with its free/locked coordinates):
//   A.<channel>.<muscle>   array weight A_{muscle,channel} (eq. 1), dimensionless, [0, 1], for
//                          every stimulated array channel × forearm muscle (ECRL, ECRB, ECU, FCR,
//                          FCU, EDC, FDS, FDP that the model has)
//   k.<joint>              passive stiffness k_i (eq. 14) of every free joint, N·m/rad,
//                          [0.2, 5] × nominal
//   beta.<muscle>          recruitment steepness β (eq. 3), 1/µs, [0.3, 3] × nominal
//   gamma.<muscle>         recruitment shape γ (eq. 3), dimensionless, [0.2, 5] × nominal
//   R.wrist_extensor_scale, R.wrist_flexor_scale
//                          common scale of the wrist_flexion moment arms (eq. 9–10) of the
//                          muscles with r < 0 (extensors) / r > 0 (flexors), dimensionless,
//                          [0.5, 2]; l_MT at the rest posture is kept (the reference length moves
//                          with the scale), so fibre operating points do not jump.
//
// Departures from §5.1, stated:
// * Local optimiser: bounded Levenberg–Marquardt (identification/levenberg_marquardt.h) instead
//   of MATLAB's interior point; Jacobians by CVODES forward sensitivities (one augmented
//   simulation per distinct trial, FullModelFitOptions::sensitivities) or by forward differences
//   evaluated in parallel threads (one model build + simulation per perturbed parameter and
//   distinct trial); optionally Broyden secant updates between them (FullModelFitOptions::
//   broyden). Trials with identical stimulation and sample times share one simulation. Without
//   secant updates LM holds active bounds and starts from a dimensionless damping
//   (LmOptions::hold_active_bounds, scale_free_damping).
// * Sensitivity measure (the paper does not give one): S_j = ‖∂ŷ/∂θ_j‖ · s_j / √N with s_j the
//   nominal |θ_j| (half the bound range when θ_j = 0), one forward difference per parameter at
//   the start point — a local, one-at-a-time ranking.
// * Start points: the first at the rig's nominal values, the others log-uniform within
//   exp(±start_spread) of nominal (uniform for A entries), clamped to the bounds (seeded).
// * Parameters not kept stay at the rig's nominal values.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "base/trial.h"
#include "identification/method.h"
#include "sim/integrator.h"
#include "sim/model_params.h"

namespace fesim::identification::fullmodel {

/// Which block of eq. (12) a fit parameter belongs to.
enum class FitParameterKind {
  kArrayWeight,       ///< A_{muscle,channel} of eq. (1), dimensionless.
  kJointStiffness,    ///< k_i of eq. (14), N·m/rad.
  kRecruitmentBeta,   ///< β of eq. (3), 1/µs.
  kRecruitmentGamma,  ///< γ of eq. (3), dimensionless.
  kMomentArmScale,    ///< common scale of a group's wrist_flexion moment arms, dimensionless.
};

/// One candidate parameter, its place in ModelParams, nominal value and bounds.
struct FitParameter {
  std::string name;  ///< e.g. "A.ext.ECRL", "k.wrist_flexion", "beta.FCR", "R.wrist_flexor_scale".
  std::string unit;  ///< "1", "N*m/rad", "1/us".
  FitParameterKind kind = FitParameterKind::kArrayWeight;
  int channel = -1;        ///< model channel index (kArrayWeight).
  int muscle = -1;         ///< model muscle index (kArrayWeight, kRecruitment*).
  int coordinate = -1;     ///< sim::Coordinate (kJointStiffness).
  bool extensors = false;  ///< kMomentArmScale: the r < 0 group (else r > 0).
  double nominal = 0.0;    ///< value in `base`, in `unit`.
  double lower = 0.0;      ///< bound, in `unit`.
  double upper = 0.0;      ///< bound, in `unit`.
};

/// The rig with every stimulated array channel rewritten as explicit muscle weights (pads
/// cleared, weights = the geometry's A column), so A's entries can be parameters.
sim::ModelParams WithExplicitArrayWeights(const sim::ModelParams& base);

/// Candidate parameters of the rig (before WithExplicitArrayWeights) for the stimulated channels
/// (model channel names); A entries only for channels that drive array pads (electrode pairs
/// keep their explicit weights). Throws std::invalid_argument naming an unknown channel.
std::vector<FitParameter> CandidateParameters(const sim::ModelParams& base,
                                              const std::vector<std::string>& channels);

/// `base` with parameters[k] set to values[k] (sizes checked, std::invalid_argument).
sim::ModelParams ApplyParameters(const sim::ModelParams& base,
                                 const std::vector<FitParameter>& parameters,
                                 const Eigen::VectorXd& values);

/// The rig `fesim identify --method full-model` uses without --scenario: DefaultModelParams()
/// (1.75 m, 75 kg) with shoulder (3 coordinates), elbow and pro/supination locked at their rest
/// posture — the hand rig of [Hand Hammerstein] §5.1.
sim::ModelParams DefaultHandRig();

/// Jacobian of the simulated outputs with respect to the fitted parameters.
enum class JacobianMethod { kAuto, kSensitivities, kForwardDifferences };

struct FullModelFitOptions {
  int keep_parameters = 29;  ///< K, the most influential candidates fitted, ≥ 1.
  /// Fit exactly these candidates (by name) instead of the K best ranked (ranking still reported).
  std::vector<std::string> fit_names;
  /// With fit_names given, false skips the sensitivity ranking (FullModelFit::ranking empty):
  /// callers that ranked once (e.g. `fesim benchmark`, per participant) save its simulations.
  bool rank = true;
  int starts = 2;                    ///< multi-start local optimisations, ≥ 1.
  unsigned seed = 1;                 ///< start points.
  double start_spread = 0.3;         ///< log half-width of the random starts (see header), ≥ 0.
  int max_iterations = 30;           ///< LM accepted steps per local optimisation.
  double relative_tolerance = 1e-6;  ///< LM stops when the cost falls by less than this fraction.
  double fd_relative_step = 1e-3;    ///< forward-difference step relative to max(|θ|, 1e-3).
  /// CVODES relative/absolute accuracy of every simulation (`fesim benchmark`'s budget:
  /// sim::TaskTolerances::kStudyFullModelFit).
  double integrator_tolerance = sim::TaskTolerances::kLibraryFit;
  int threads = 0;  ///< worker threads for simulations; 0 = hardware concurrency.
  /// Secant (Broyden) Jacobian updates between finite-difference Jacobians (LmOptions::broyden):
  /// a finite-difference Jacobian at the start, after 3 rejected secant steps and to confirm a
  /// stop. Off (default): one finite-difference Jacobian per accepted LM step. Opt-in because with
  /// tight tolerances (relative 1e-10) the secant steps and the confirming Jacobians can cycle for
  /// many more evaluations than the plain method (seen in the planted-parameter tests).
  bool broyden = false;
  /// How Jacobians (and the sensitivity ranking) are computed: CVODES forward sensitivities
  /// (sim::IntegrateTrialSensitivities: one augmented simulation per distinct trial, ≈ 1.5
  /// simulations' cost on the hand rig at the default jacobian_tolerance_factor) or forward
  /// differences with fd_relative_step (one perturbed simulation per parameter and trial, spread
  /// over the threads); kAuto takes sensitivities for ≥ 4 parameters (the rule was set when an
  /// augmented simulation cost 3.6 plain ones and is kept; it ignores the thread count, so the
  /// figures do not depend on how the fit is run). A sensitivity integration that fails, or a rig
  /// with the stretch reflex's states, falls back to forward differences.
  JacobianMethod jacobian = JacobianMethod::kAuto;
  /// The sensitivity simulations of the iterations run at this multiple of integrator_tolerance
  /// (residuals, hence the cost and the stop, at integrator_tolerance itself): LM needs the
  /// Jacobian for its step direction only. At 100 (the default) the hand-array Jacobian is within
  /// 9 % (relative RMS; worst column 31 %) of the exact one and costs half of one at 10 (0.2 %,
  /// 1.5 %); the 29-parameter local step reaches the same cost in no more iterations (19 at 100;
  /// 21 at 10 with gain-ratio damping, before the predicted-decrease stop; docs/performance.md
  /// "Full-model fit local step").
  /// The confidence intervals get one Jacobian at 10 at the minimiser. ≥ 1; the Jacobians'
  /// tolerance is capped at 1e-2 (unless the residuals' is coarser).
  double jacobian_tolerance_factor = 100.0;
};

/// One ranked candidate.
struct SensitivityEntry {
  std::string name;
  double sensitivity = 0.0;  ///< S_j (see header), rad.
};

struct LocalRun {
  Eigen::VectorXd start;    ///< kept parameters at the start, in their units.
  Eigen::VectorXd x;        ///< at the end.
  double cost = 0.0;        ///< Σ‖y − ŷ‖², rad².
  int iterations = 0;       ///< accepted LM steps.
  int evaluations = 0;      ///< residual evaluations (trial-set simulations).
  int jacobians = 0;        ///< finite-difference Jacobians evaluated (not secant-updated).
  double wall_s = 0.0;      ///< wall time of this local optimisation step, s.
  double cpu_s = 0.0;       ///< process CPU time (all threads) of this step, s.
  bool converged = false;   ///< LM met a tolerance (see LmStopReason).
  std::string stop_reason;  ///< LmStopReasonName, e.g. "iteration_limit".
  /// Cost at the start and after each accepted step, and the residual evaluations used by then.
  std::vector<double> cost_history;
  std::vector<int> evaluations_history;
};

struct FullModelFit {
  std::vector<FitParameter> candidates;   ///< all candidates, nominal = start point.
  std::vector<SensitivityEntry> ranking;  ///< all candidates, most influential first.
  std::vector<FitParameter> kept;         ///< the fitted subset.
  Eigen::VectorXd values;                 ///< best kept values, in their units.
  Eigen::VectorXd ci95_half_width;        ///< 95 % half-widths (NaN: not estimable).
  sim::ModelParams model;                 ///< the rig with the best values applied.
  double cost = 0.0;                      ///< Σ‖y − ŷ‖² at the best values, rad².
  long residuals = 0;                     ///< number of residuals N.
  /// Simulations per residual evaluation: the training trials with distinct stimulation, times
  /// and joints (identical ones share one deterministic simulation).
  int distinct_simulations = 0;
  std::vector<LocalRun> runs;       ///< one per start.
  std::size_t best_run = 0;         ///< index in `runs` of the values kept.
  double sensitivity_wall_s = 0.0;  ///< ranking, s.
  double total_wall_s = 0.0;        ///< ranking + all starts, s.
};

/// Simulates `trial`'s stimulation (u.<channel> columns, zero-order hold between samples) on
/// `model` from its initial state, the stimulation delayed by the electromechanical delay as in
/// sim::RunTrial, and returns the u.* and simulated q.<joint> columns of `trial` (same names,
/// q read at exactly the trial's times, no sensor noise). Throws std::runtime_error on an unknown
/// channel or joint, time before 0, fewer than 2 samples, or integration failure.
Trial SimulateLike(const sim::ModelParams& model, const Trial& trial, double integrator_tolerance);
/// The same with every integrator setting given (method CVODES BDF unless set otherwise).
Trial SimulateLike(const sim::ModelParams& model, const Trial& trial,
                   const sim::IntegratorParams& integrator);

/// SimulateLike with CVODES forward sensitivities (sim::IntegrateTrialSensitivities) to the
/// parameters of `perturbed` (each the model with one parameter moved by its step; only what
/// sim::ParameterPerturbation lists may differ): the simulated trial and, per q column of `trial`
/// (same order), the samples × P matrix ∂q̂/∂θ_k (rad per unit of θ_k). Throws like SimulateLike,
/// and std::invalid_argument for a model it cannot differentiate (the stretch reflex's states,
/// Simbody's RKM).
struct SimulationSensitivities {
  Trial trial;
  std::vector<Eigen::MatrixXd> dq_dtheta;
};
SimulationSensitivities SimulateLikeSensitivities(
    const sim::ModelParams& model, const Trial& trial,
    const std::vector<sim::ParameterPerturbation>& perturbed,
    const sim::IntegratorParams& integrator);

/// The Gauss–Newton quantities of FitFullModel's residuals r = y − ŷ on `train` (q.* columns,
/// NaN samples skipped) at parameter values x of `params` (applied to `rig` as the fit applies
/// them): J = ∂r/∂x from CVODES forward sensitivities at `jacobian_tolerance`, and JᵀJ and Jᵀr
/// accumulated without J, per distinct simulation in its worker, as the fit's sensitivity
/// iterations take them; r from simulations at `tolerance`. Throws like FitFullModel.
struct GaussNewtonQuantities {
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  Eigen::MatrixXd jtj;
  Eigen::VectorXd jtr;
};
GaussNewtonQuantities SensitivityGaussNewton(const sim::ModelParams& rig,
                                             const std::vector<Trial>& train,
                                             const std::vector<FitParameter>& params,
                                             const Eigen::VectorXd& x, double tolerance,
                                             double jacobian_tolerance, int threads);

/// Sensitivity ranking + multi-start local optimisation on `train` (the q.* columns; NaN samples
/// are skipped). `progress` may be empty. Throws std::runtime_error with a one-line reason on
/// unusable data.
FullModelFit FitFullModel(const sim::ModelParams& rig, const std::vector<Trial>& train,
                          const FullModelFitOptions& options, const ProgressFn& progress = {});

/// CLI entry "full-model". `scenario_path` empty: DefaultHandRig(); else the scenario's model.
/// Trials' metadata key `scenario_path` (set by `fesim identify --scenario`) overrides it.
/// Options from the first training trial's metadata: fullmodel.keep, .starts, .seed, .spread,
/// .max_iterations, .tolerance, .integrator_tolerance, .threads, .broyden (0 or 1),
/// .jacobian (0 auto, 1 sensitivities, 2 forward differences), .jacobian_tolerance_factor.
MethodEntry FullModelMethod(const std::string& scenario_path = "");

}  // namespace fesim::identification::fullmodel
