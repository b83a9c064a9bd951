// Bounded Levenberg–Marquardt for small nonlinear least-squares problems on Eigen, used for the
// local steps of [Hand Hammerstein] §4 (static Ψ and dynamic Θ fits, eq. 42 and 44) and for θ_a in
// Algorithm 2 of [Le 2010] (§4.2, OE model). Marquardt (1963) damping on JᵀJ with a
// forward-difference Jacobian; bounds by projection (clamping) of every trial step, and an
// optional user projection for simple non-box constraints (e.g. u_sat > u_db in eq. 40).
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <vector>

#include "identification/method_support.h"

namespace fesim::identification {

struct LmResult;
/// The run's converged flag, stop-reason name and accepted steps as a Convergence record.
Convergence ToConvergence(const LmResult& result);

struct LmOptions {
  int max_iterations = 200;           ///< accepted steps at most.
  double relative_tolerance = 1e-12;  ///< stop when the cost decreases by less than this fraction.
  /// The relative-decrease stop also needs the linear model's predicted decrease below
  /// relative_tolerance · cost (MINPACK's ftol test): a step that gained little of a large
  /// predicted decrease (ρ ≈ 0, e.g. along an inexact Jacobian) is not taken for a minimum.
  bool stop_needs_predicted_decrease = false;
  double step_tolerance = 1e-12;  ///< stop when ‖Δx‖ ≤ this · (‖x‖ + step_tolerance).
  double initial_damping = 1e-3;  ///< λ₀ relative to max diag(JᵀJ) (see scale_free_damping).
  /// λ₀ = initial_damping itself. The damping term is λ·diag(JᵀJ) (Marquardt's scaling), so λ is
  /// already dimensionless; the default λ₀ = initial_damping · max diag(JᵀJ) makes the first
  /// steps short gradient steps whenever max diag(JᵀJ) ≫ 1 (the full-model fit: ≈ 6 accepted
  /// steps at λ/3 each before the cost starts to fall).
  bool scale_free_damping = false;
  double fd_relative_step = 1e-7;  ///< forward-difference step, relative to max(|x_k|, 1e-3).
  /// Secant Jacobian (Madsen, Nielsen & Tingleff 2004, "Methods for non-linear least squares
  /// problems", §3.4): after every trial step Δx, accepted or rejected, Broyden's rank-one update
  ///   J ← J + (r(x + Δx) − r(x) − J Δx) Δxᵀ / ‖Δx‖²
  /// replaces the Jacobian evaluation (forward differences or `jacobian`), and one column per
  /// iteration (cyclically, when the step hardly moves along it) is re-evaluated by a forward
  /// difference. J is evaluated in full only at the start, after 3 consecutive rejected steps on
  /// a secant J, when a secant step meets the relative or step tolerance (a stop is only declared
  /// on an evaluated J), and at an iteration-limit stop (so `jtj` is always from an evaluated J).
  /// For residuals whose Jacobian costs many expensive evaluations (the full-model fit: one
  /// simulation per column and data set).
  bool broyden = false;
  /// Hold active bounds: a variable at a bound whose steepest-descent direction −(Jᵀr)_k points
  /// out of the box gets Δx_k = 0, and the damped Gauss–Newton step is solved for the others
  /// (the reduced system of a projected Gauss–Newton method, e.g. Kelley 1999, "Iterative
  /// methods for optimization", §5.5). Without it the full step is computed as if unbounded and
  /// then clamped, which along a valley ending on a bound moves little per iteration (seen as a
  /// 200-iteration crawl of the Hammerstein static step on full-model data).
  bool hold_active_bounds = false;
  /// After an accepted step, scale λ by max(1/3, 1 − (2ρ − 1)³), ρ = actual / predicted cost
  /// decrease (Nielsen 1999, "Damping parameter in Marquardt's method", IMM-REP-1999-05; Madsen,
  /// Nielsen & Tingleff 2004, eq. 2.21), instead of always dividing it by 3: λ stays where a step
  /// gains half of what the linear model predicts (ρ ≈ 0.5) and falls only as ρ → 1. On
  /// residuals whose linear model holds in a region of roughly fixed size (the full-model fit's
  /// slow phase) the fixed 1/3 overshoots it and costs one rejected trial per iteration.
  bool gain_ratio_damping = false;
};

/// Why a Levenberg–Marquardt run stopped. The first three are convergence; the others are not.
enum class LmStopReason {
  kRelativeDecrease,  ///< an accepted step lowered the cost by ≤ relative_tolerance · cost (and
                      ///< predicted no more, with stop_needs_predicted_decrease).
  kStepTolerance,  ///< the (clamped) step ‖Δx‖ fell to ≤ step_tolerance · (‖x‖ + step_tol.)
                   ///< (after ≥ 1 accepted step, or at once: a stationary start).
  kZeroCost,        ///< the cost reached exactly 0.
  kIterationLimit,  ///< max_iterations accepted steps without meeting a tolerance.
  kNoDecrease,      ///< no trial step lowered the cost: the damping grew past 1e300 (or
                    ///< became non-finite), or, before any step was accepted, until the
                    ///< step vanished below step_tolerance; x is the start point then.
};

/// Short snake_case name for metrics and YAML, e.g. "relative_cost_decrease_below_tolerance".
const char* LmStopReasonName(LmStopReason reason);

/// True for the tolerance-based stops (kRelativeDecrease, kStepTolerance, kZeroCost).
bool LmConverged(LmStopReason reason);

struct LmResult {
  Eigen::VectorXd x;             ///< the minimiser (within bounds).
  Eigen::VectorXd residual;      ///< r(x).
  double cost = 0.0;             ///< ‖r(x)‖².
  int iterations = 0;            ///< accepted steps.
  int evaluations = 0;           ///< residual evaluations (including the Jacobian's).
  int jacobian_evaluations = 0;  ///< evaluated (not secant-updated) Jacobians.
  Eigen::MatrixXd jtj;           ///< Jᵀ J at x (for confidence intervals).
  /// Cost at the start and after every accepted step, with the residual evaluations used so far
  /// (evaluations_history[k] when cost_history[k] was reached): the convergence trace.
  std::vector<double> cost_history;
  std::vector<int> evaluations_history;
  bool converged = false;  ///< LmConverged(stop_reason).
  LmStopReason stop_reason = LmStopReason::kIterationLimit;
};

/// r(x) → residual vector (fixed length).
using ResidualFn = std::function<Eigen::VectorXd(const Eigen::VectorXd&)>;
/// (x, r(x)) → J(x), optional analytic or structured Jacobian (forward differences otherwise);
/// it should add the residual evaluations it makes to *evaluations.
using JacobianFn = std::function<Eigen::MatrixXd(const Eigen::VectorXd&, const Eigen::VectorXd&,
                                                 int* evaluations)>;
/// Maps a point onto the feasible set after clamping to the bounds (identity if empty).
using ProjectionFn = std::function<void(Eigen::VectorXd*)>;
/// (x, r(x)) → JᵀJ (p×p) and Jᵀr (p) at x without forming J, for residuals whose Jacobian has a
/// structure the caller exploits (e.g. block-sparse columns); it should add the residual
/// evaluations it makes to *evaluations. Replaces `jacobian`; not with LmOptions::broyden.
using NormalEquationsFn =
    std::function<void(const Eigen::VectorXd& x, const Eigen::VectorXd& r, Eigen::MatrixXd* jtj,
                       Eigen::VectorXd* jtr, int* evaluations)>;

/// x → ‖r(x)‖², for residuals that supply their normal equations and need not be stored.
using CostFn = std::function<double(const Eigen::VectorXd&)>;

/// JᵀJ as column dot products (cheaper than a packed GEMM for tall, thin J): the Gram the
/// iteration forms from a Jacobian, for callers that supply normal equations and fall back to one.
Eigen::MatrixXd JacobianGram(const Eigen::MatrixXd& J);

/// Minimises ‖r(x)‖² subject to lower ≤ x ≤ upper (entries may be ±inf).
LmResult LevenbergMarquardt(const ResidualFn& residual, Eigen::VectorXd x0,
                            const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                            const LmOptions& options = {}, const ProjectionFn& project = {},
                            const JacobianFn& jacobian = {},
                            const NormalEquationsFn& normal_equations = {});

/// LevenbergMarquardt with `normal_equations` on a residual that is never formed: `cost` gives
/// ‖r(x)‖² and `normal_equations` JᵀJ and Jᵀr (its r argument is empty). The same iteration
/// (broyden must be off); LmResult::residual stays empty. For long residuals whose normal
/// equations are accumulated in the pass that computes the cost (the Hammerstein dynamic step),
/// where storing r and summing its squares again would be a second pass over memory.
LmResult LevenbergMarquardtOnCost(const CostFn& cost, Eigen::VectorXd x0,
                                  const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                                  const NormalEquationsFn& normal_equations,
                                  const LmOptions& options = {}, const ProjectionFn& project = {});

/// 95 % half-widths 1.96 √diag(σ² (JᵀJ)⁺), σ² = cost / (N − p); NaN for parameters in a
/// singular direction of JᵀJ (eigenvalue < 1e-12 of the largest; not estimable, e.g. held at a
/// bound where the cost is flat): those whose weight in its unit eigenvector exceeds
/// `participation`. The eigenvector of a singular direction carries rounding of order
/// ε‖JᵀJ‖/gap on the other parameters; callers whose JᵀJ has an exactly singular pair next to a
/// well-determined rest raise it (the full-model fit: 1e-3).
Eigen::VectorXd ConfidenceHalfWidths95(const Eigen::MatrixXd& jtj, double cost, long n_residuals,
                                       double participation = 1e-6);

}  // namespace fesim::identification
