// The simulation as a function of named parameters, for calibration and for model extensions in
// `fesim diagnose` (issue 7). A parameter acts on the full model (12) of
// papers/000_0a6c0de9fc69df7c.txt in one of three places:
//   kModel        a field of sim::ModelParams (joint stiffness, a mechanism of sim/mechanisms.h …)
//   kInputScale   u.<channel> is multiplied by the value before simulating (a per-channel gain on
//                 the pulse width, dimensionless: electrode placement / threshold differences)
//   kOutputDrift  value · t is added to the simulated q.<joint> (sensor offset drift, rad/s, as
//                 sim/sensors.h plants it: drift · t)
// Predictions simulate each trial's u.* from t = 0 with identification/fullmodel's SimulateLike,
// the output joints starting at the trial's measured initial posture (DataView::initial_q);
// fitting is the bounded Levenberg–Marquardt of identification/levenberg_marquardt.h, in ln x
// for the parameters with a log-normal prior (scale factors spanning decades). Jacobian
// columns come from CVODES forward sensitivities (one augmented simulation per trial for all the
// columns whose ModelParameter::sensitivity is set) and forward differences for the others, in
// parallel threads. A parameter with a prior (ModelParameter::prior_width) adds the row
// σ_p (x − start) / width (log_prior: σ_p ln(x / start) / width) to the least-squares problem
// (FitOptions::prior_sigma): the fit is then
// the maximum a-posteriori estimate under a Gaussian prior, and directions the data do not see
// stay at the start. This generalises FitFullModel's parameter kinds (which stay as they are) to
// the person calibration (person.h) and the mechanisms (mechanisms/).
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "base/trial.h"
#include "sim/model_params.h"

namespace fesim::diagnosis {

struct ModelParameter {
  enum class Target { kModel, kInputScale, kOutputDrift };
  std::string name;  ///< e.g. "k.wrist_flexion", "fatigue.rate_per_s", "drift.q.wrist_flexion".
  std::string unit;  ///< e.g. "N*m/rad", "1/s", "rad/s".
  Target target = Target::kModel;
  std::string column;  ///< "u.<channel>" (kInputScale) or "q.<joint>" (kOutputDrift).
  double start = 0.0;  ///< start value (also the "mechanism off" value for extensions).
  double lower = 0.0;  ///< bound.
  double upper = 0.0;  ///< bound, > lower.
  double scale = 1.0;  ///< typical magnitude, > 0 (finite-difference steps: FitOptions::fd_step).
  /// A bound at which the mechanism collapses into what the subject parameters already describe
  /// (potentiation's shortest rise time: a constant extra gain on the active force); NaN: none.
  /// A candidate fit that ends there is not accepted (diagnose.h step 4).
  double collapses_at = NAN;
  /// Person parameters that are functions of one joint's angle (its passive k, k₃, rest angle, a
  /// group's moment-arm scale there): the joint's coordinate name; "" otherwise (also the
  /// joint's damping b, a function of its speed).
  std::string joint;
  /// The bounds are the plausible range of the parameter (true), not a search window around a
  /// start (false: a tremor's phase and frequency). A mechanism whose fit ends at a plausible-
  /// range bound other than its "off" start is not accepted (extension.h).
  bool range_is_plausible = true;
  /// Half-width of a normal person's variation of this mechanism parameter around its "off"
  /// start, in its unit: a candidate whose parameters with a band all end inside it describes a
  /// normal person, not the mechanism, and is not accepted (WithinNormalVariation). NaN: no band.
  double normal_half_width = NAN;
  /// 1σ width of a Gaussian prior around `start`, in the parameter's unit, > 0; NaN: no prior.
  /// Used when FitOptions::prior_sigma > 0.
  double prior_width = NAN;
  /// The prior is log-normal: on ln(x / start), prior_width in natural-log units (for scale
  /// factors, start > 0 and lower > 0: a factor 2 and a factor ½ are equally far).
  bool log_prior = false;
  /// kModel only: `set` changes nothing but what sim::IntegrateTrialSensitivities differentiates
  /// (recruitment, the electrode matrix, activation rates Ω, Hill and passive joint parameters,
  /// muscle paths, the tremor torque), so its Jacobian column may come from forward
  /// sensitivities.
  bool sensitivity = false;
  /// kModel only: the value applies to trial `trial` of the view it is simulated on alone (−1:
  /// to every trial) — a value no two trials share, such as the phase of a tremor that starts
  /// afresh in each recording (Candidate::phase_per_trial).
  int trial = -1;
  /// kModel: writes the value into the model (called on a copy of the base).
  std::function<void(double, sim::ModelParams*)> set;
};

/// [a; b].
Eigen::VectorXd Concat(const Eigen::VectorXd& a, const Eigen::VectorXd& b);
/// a followed by b (a model's parameters with an extension's).
std::vector<ModelParameter> Join(const std::vector<ModelParameter>& a,
                                 const std::vector<ModelParameter>& b);

/// The name of the first of `params` (their values x(offset), x(offset + 1), …) that sits at its
/// collapses_at bound (within 1e-3 of its range), or "" when none does.
std::string CollapsedParameter(const std::vector<ModelParameter>& params, const Eigen::VectorXd& x,
                               Eigen::Index offset);

/// Where v sits in p's range: −1 within 1e-3 of the range of its lower bound, +1 of its upper,
/// 0 inside. The range is measured in the coordinates FitParameters fits in (ln x for a
/// log-prior scale factor: γ at 3 in [10⁻³, 10⁴] is not at its lower bound).
int RangeBoundSide(const ModelParameter& p, double v);

/// The name of the first of `params` (values from x(offset)) with range_is_plausible that sits
/// at a bound (RangeBoundSide) that is not its start, or "" when none does.
std::string ParameterAtRangeBound(const std::vector<ModelParameter>& params,
                                  const Eigen::VectorXd& x, Eigen::Index offset);

/// The names, comma-separated, of the person parameters of joint `joint` (ModelParameter::joint;
/// values x(0), x(1), … of `params`) that sit within 1e-3 of their range at a bound; "" when none
/// does or `joint` is "".
std::string JointParametersAtBound(const std::vector<ModelParameter>& params,
                                   const Eigen::VectorXd& x, const std::string& joint);

/// "name = v within its normal variation ±w" of the first of `params` (values from x(offset))
/// with a normal_half_width when every such parameter ends within start ± normal_half_width;
/// "" when one ends beyond its band or none has a band. With `ci95` (the fit's 95 % half-widths,
/// indexed as x; empty: not used) a parameter without a band must also end within its ci95 of
/// its start (NaN: at its start): a mechanism whose unbanded part is indistinguishable from "off"
/// and whose banded part is within a normal person's variation is a normal person (crosstalk, whose
/// wide current spread has no band and whose antagonist reach has one).
std::string WithinNormalVariation(const std::vector<ModelParameter>& params,
                                  const Eigen::VectorXd& x, Eigen::Index offset,
                                  const Eigen::VectorXd& ci95 = {});

/// The data one fit or evaluation sees: trials simulated from t = 0, and per trial the samples
/// that count (training segment or held-out segment). Outputs are the q.* columns named here.
struct DataView {
  std::vector<Trial> trials;
  std::vector<std::vector<char>> use;  ///< use[t][i]: sample i of trial t counts (and is finite).
  std::vector<std::string> outputs;    ///< q.<joint> names, present in every trial.
  /// initial_q[t][o]: the measured angle of output o at the start of trial t, rad (the median of
  /// its first finite samples, measured.h), the simulation's initial posture of that joint; NaN
  /// or an empty list: the model's initial angle.
  std::vector<std::vector<double>> initial_q;
  /// Number of counted finite output samples.
  long Count() const;
};

/// Simulates one trial: the q.* outputs (same time column) of model `m` for the u.* inputs of
/// `inputs` (already scaled by the kInputScale parameters), from t = 0, at relative/absolute
/// accuracy `tolerance`. Throws std::runtime_error when the simulation fails.
using TrialSimulator =
    std::function<Trial(const sim::ModelParams& m, const Trial& inputs, double tolerance)>;

/// `base` with the kModel parameters applied (values x, sizes checked): for trial `trial` of a
/// view, those of every trial and those of that trial (ModelParameter::trial); −1: all of them in
/// order.
sim::ModelParams ApplyModelParameters(const sim::ModelParams& base,
                                      const std::vector<ModelParameter>& params,
                                      const Eigen::VectorXd& x, int trial = -1);
/// Whether parameter `param` changes the simulation of trial `trial` (ModelParameter::trial).
bool AppliesToTrial(const ModelParameter& param, int trial);

struct FitOptions;

/// Simulated outputs (the q.* columns of `view.outputs`, same times) of every trial of `view`
/// for parameters x, by options.simulator at options.tolerance on `threads` workers (0:
/// options.threads). A failed simulation throws std::runtime_error.
std::vector<Trial> Predict(const sim::ModelParams& base, const std::vector<ModelParameter>& params,
                           const Eigen::VectorXd& x, const DataView& view,
                           const FitOptions& options, int threads = 0);

/// Adds value · t to the simulated q.<joint> column of every kOutputDrift parameter (values x)
/// of `prediction` (a simulation of the model without the drifts) that applies to trial `trial`
/// of its view (AppliesToTrial; −1: every drift parameter).
void AddOutputDrift(const std::vector<ModelParameter>& params, const Eigen::VectorXd& x,
                    Trial* prediction, int trial = -1);

/// Stacked residuals y − ŷ over the counted samples (trial-major, then output, then time).
Eigen::VectorXd StackResiduals(const DataView& view, const std::vector<Trial>& predictions);

/// One output of one trial of a view: its counted samples' times and residuals.
struct ResidualSeries {
  int trial = 0;
  std::string output;
  std::vector<double> time_s, r;  ///< s, rad.
};
/// The stacked residual r (StackResiduals' order and size, std::invalid_argument otherwise) per
/// trial and output of `view`.
std::vector<ResidualSeries> UnstackResiduals(const DataView& view, const Eigen::VectorXd& r);

/// Mean over outputs of the normalised error ‖y − ŷ‖ / ‖y − ȳ‖ (identification/metrics.h) on the
/// counted samples of all trials pooled per output, dimensionless.
double ViewNrmse(const DataView& view, const std::vector<Trial>& predictions);
/// The same per output, in view.outputs order.
std::vector<double> ViewNrmsePerOutput(const DataView& view, const std::vector<Trial>& predictions);

/// `base` with the output joints of trial t of `view` starting at its measured posture
/// (view.initial_q[t]; NaN entries keep the model's).
sim::ModelParams WithInitialPosture(const sim::ModelParams& base, const DataView& view,
                                    std::size_t t);

struct FitOptions {
  int max_iterations = 8;            ///< accepted LM steps.
  double relative_tolerance = 1e-4;  ///< LM stops when the cost falls by less than this fraction.
  /// Forward-difference step, × max(ModelParameter::scale, |x − start|): relative to how far the
  /// value has moved from its start once that exceeds its typical scale. A mechanism's scale is
  /// sized for its "off" value 0; a step of 1e-2 × scale at a fitted value 30× larger moved the
  /// outputs by less than the integration error, and that column was mostly error
  /// (ExtendedModel.JacobianStepFollowsTheValue…). Measured from the start, not from 0: a
  /// location parameter such as a tremor's frequency (5.35 Hz, scale 0.1 Hz) keeps its small
  /// step (× |x| it was 0.05 Hz, 20 rad of phase over a 60 s trial: ExtendedModel.
  /// FrequencyStepStaysSmall…).
  double fd_step = 1e-2;
  /// CVODES relative/absolute accuracy (`fesim diagnose`: sim::TaskTolerances::kDiagnosis).
  double tolerance = sim::TaskTolerances::kLibraryFit;
  double speed_time_scale_s = 0.0;  ///< sim::IntegratorParams::speed_time_scale_s, s, ≥ 0.
  /// Internal integrator steps per simulated second at most (sim::IntegratorParams::max_steps =
  /// this × the trial's duration; 0: no limit). A simulation that needs more fails (LM rejects
  /// that point; a Jacobian column is left at 0). Hand-rig trials take ≈ 100 steps/s, ≈ 440
  /// with a 5 Hz tremor (bench/diagnosis_bench.cc BM_SimulateLike*).
  double max_steps_per_s = 10000.0;
  int threads = 2;  ///< simulation workers, ≥ 1.
  /// σ_p of the prior rows σ_p (x − start) / prior_width, rad (the measured noise level, so that
  /// Σr² + Σ rows² is σ² times the negative log posterior); 0: priors off.
  double prior_sigma = 0.0;
  /// Jacobian columns of ModelParameter::sensitivity parameters from forward sensitivities
  /// (false: all by forward differences).
  bool sensitivities = true;
  /// The sensitivity integrations run at this multiple of `tolerance` (≥ 1): LM needs the
  /// Jacobian for its step direction only (as FullModelFitOptions::jacobian_tolerance_factor).
  double jacobian_tolerance_factor = 10.0;
  /// sim::IntegratorParams::simbody_right_hand_side of every fit simulation. False: the
  /// articulated-body right-hand side (UpperLimbModel::CalcYDot), the same dynamics as Simbody's
  /// realisation to round-off and a diagnosis 2.4–3.1× faster (docs/performance.md). The two gave
  /// the same cause on 16 of the 18 foreign suite data sets with the calibration's converged stop,
  /// against 12 of 18 without it (docs/diagnosis.md "Known limits", "Verdicts that turn on
  /// round-off").
  bool simbody_right_hand_side = false;
  /// identification::LmOptions::stop_needs_predicted_decrease and hold_active_bounds of the LM
  /// run (PersonCalibrationOptions::converged_stop sets both for the calibration).
  bool stop_needs_predicted_decrease = false;
  bool hold_active_bounds = false;
  /// The simulation. Empty: the full model (12) by identification/fullmodel's SimulateLike;
  /// `fesim diagnose --model NAME` sets a reduced model (reduced_model.h).
  TrialSimulator simulator;
};

struct FitResult {
  Eigen::VectorXd x;     ///< best values, in the parameters' units.
  Eigen::VectorXd ci95;  ///< 95 % half-widths (NaN: not estimable or held).
  double cost = 0.0;  ///< Σ (y − ŷ)², rad² (profiled: ‖(I − P) r‖², see FitParameters).
  /// cost + the prior rows' Σ (FitOptions::prior_sigma), rad²: what LM minimised.
  double map_cost = 0.0;
  /// Profiled fits only: the linearised least-squares step of the profiled (held) parameters
  /// at x, δ = −(J_nᵀJ_n)⁻¹ J_nᵀ r(x), one entry per column of the nuisance Jacobian.
  Eigen::VectorXd nuisance_step;
  long residuals = 0;   ///< N.
  int simulations = 0;  ///< trial simulations spent.
  /// LM's stop: a tolerance met (identification::LmConverged: the relative cost decrease or the
  /// step fell below its tolerance), not the iteration limit or a failure to decrease.
  bool converged = false;
  Eigen::MatrixXd jacobian;  ///< ∂r/∂x of the free parameters at the last linearisation point.
  Eigen::VectorXd jacobian_x;  ///< that point (all parameters).
  /// The raw residual y − ŷ at x and the simulated trials it came from (empty when x was not
  /// simulated in this fit). With `jacobian` (at x when the fit ends on an accepted or the start
  /// point, the last LM linearisation) they let a following fit from x start without simulating.
  Eigen::VectorXd residual;
  std::vector<Trial> predictions;
};

/// What a fit from x0 would compute first, already known (e.g. from the fit that ended at x0):
/// the raw residual y − ŷ(x0) and, when non-empty, the Jacobian of the free parameters at x0
/// (N × (p − first_free), as ResidualJacobian computes it from that residual).
struct FitStart {
  Eigen::VectorXd residual;
  Eigen::MatrixXd jacobian;
  std::vector<Trial> predictions;  ///< ŷ(x0), optional.
};

/// Bounded LM of the parameters from x0 on the counted samples of `view`. Parameters with index
/// < first_free are held at their x0 values (not fitted; their ci95 is NaN); `max_iterations`
/// overrides options.max_iterations when > 0.
///
/// Profiled fit (variable projection with a fixed Jacobian, Golub & Pereyra 1973): when
/// `nuisance` (N × q, the residual Jacobian of the held parameters at x0) is given, the held
/// parameters are not frozen but re-optimised to first order at every evaluation: LM minimises
/// ‖(I − P) r(x)‖² with P = J_n (J_nᵀJ_n)⁺ J_nᵀ, and its Jacobian is (I − P) J. This is the fit
/// that matches the score test of diagnose.h (a mechanism judged by what the held parameters
/// cannot produce); freezing them instead loses every mechanism that they partly absorb (e.g.
/// crosstalk, whose gain on the reached muscles the baseline took into strength_scale).
/// FitResult::nuisance_step is then the held parameters' linearised adjustment at x.
/// `start` (optional): the residual (and Jacobian) at x0, not simulated again; the result is the
/// same as without it when they are what this fit would compute.
FitResult FitParameters(const sim::ModelParams& base, const std::vector<ModelParameter>& params,
                        const Eigen::VectorXd& x0, const DataView& view, const FitOptions& options,
                        int first_free = 0, int max_iterations = 0,
                        const Eigen::MatrixXd* nuisance = nullptr, const FitStart* start = nullptr);

/// FitParameters of all `params` from every start in `starts` (non-empty), side by side on
/// options.threads threads (each fit's simulations on options.threads threads again): the fit of
/// lowest posterior cost (map_cost; the data cost without priors; the first of equal ones). A
/// start whose simulation fails is skipped; `costs` (optional) receives every start's map_cost
/// (∞ for a failed one) and `kept` the index of the one returned. Its simulations count all the
/// fits'. Throws std::invalid_argument without a start and std::runtime_error when every start
/// fails. Several starts reach valleys a local fit from one start does not (the elbow rig, whose
/// forearm weight trades off against strength and stiffness).
FitResult FitOverStarts(const sim::ModelParams& base, const std::vector<ModelParameter>& params,
                        const std::vector<Eigen::VectorXd>& starts, const DataView& view,
                        const FitOptions& options, int max_iterations,
                        std::vector<double>* costs = nullptr, std::size_t* kept = nullptr);

/// The vertex of the parabola through (f0, c0), (f1, c1), (f2, c2), f0 < f1 < f2, c1 < c0 and
/// c1 < c2: the minimiser of the quadratic interpolant, inside (f0, f2) — one step of successive
/// parabolic interpolation (Press et al., Numerical Recipes, 3rd ed., eq. 10.3.1). Refines a
/// profile of Σr² sampled on a grid of a mechanism parameter (extension.cc, LowestProfileStart).
double ParabolaVertex(double f0, double c0, double f1, double c1, double f2, double c2);

/// Forward-difference Jacobian ∂r/∂x_k (N × (p − first_free)) for the columns k ≥ first_free
/// at x with residual r0; one simulation per column and trial, in parallel, except kOutputDrift
/// columns, which are −t on their output (exact: the drift enters ŷ linearly and leaves the
/// simulation unchanged). Adds the simulations to *simulations when given.
Eigen::MatrixXd ResidualJacobian(const sim::ModelParams& base,
                                 const std::vector<ModelParameter>& params,
                                 const Eigen::VectorXd& x, const Eigen::VectorXd& r0,
                                 const DataView& view, const FitOptions& options,
                                 int* simulations = nullptr, int first_free = 0);

}  // namespace fesim::diagnosis
