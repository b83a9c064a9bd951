// Hammerstein model with cubic-spline recruitment for electrically stimulated muscle, and its
// two iterative identification algorithms.
//
// Paper: [Le 2010] (docs/papers.md), §3–4.
//   G(q) = B(q)/A(q) = (b_0 q^{-d} + … + b_n q^{-(n+d)}) / (1 + a_1 q^{-1} + … + a_l q^{-l})  eq.
//   (1) f(u) = Σ_{i=1}^{m-2} β_i |u − u_{i+1}|³ + β_{m-1} + β_m u + β_{m+1} u² + β_{m+2} u³     eq.
//   (2) ARX cost ‖A y − B f(u)‖² (eq. 5, 7, 9, 14); OE cost ‖y − (B/A) f(u)‖² (eq. 6, 10–13,
//   15–16). Algorithm 1 (ARX): alternating ordinary least squares for θ_n (eq. 9) and θ_l (eq. 14).
//   Algorithm 2 (OE): θ_n by least squares through T_ext⁻¹ (eq. 13, zero initial conditions),
//   θ_a by Levenberg–Marquardt with θ_b = g(θ_a) eliminated by least squares (eq. 16).
//   Second-order stability bounds 0 < a_2 ≤ 1, −2 ≤ a_1 ≤ 0 (§4.2) imposed when l = 2.
//
// Trial conventions: input = the single u.<channel> column (pulse width, µs); output = the single
// tau.<joint> column (isometric elbow torque, N·m) when the trial has one, otherwise the single
// q.<joint> column (rad). Trials must be uniformly sampled. The baseline (mean output over the
// leading samples with u = 0, [Le 2010] §6.1) is removed before fitting and added back to the
// predictions; all samples, rest included, enter the fit, with zero initial conditions.
//
// Departures, stated:
// * The spline basis of eq. (2) is evaluated in the normalised input s = (u − u_1)/(u_m − u_1)
//   (knots likewise) for conditioning; this spans the same function space, so β are reported
//   per unit of s^k, in output units.
// * The gain of B f is not identifiable (B·c, f/c give the same output): after every iteration the
//   model is normalised to unit static gain G(1) = B(1)/A(1) = 1, so f(u) is the steady-state
//   recruitment curve in output units.
// * ε is relative: iteration stops when |V_N^j − V_N^{j−1}| < ε Σ y² (V_N = the method's cost).
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "identification/method.h"
#include "identification/method_support.h"

namespace fesim::identification {

/// Orders (n, l, d) of eq. (1) and the number of spline knots m of eq. (2).
struct SplineOrders {
  int zeros_n = 1;  ///< n ≥ 0: numerator b_0 … b_n.
  int poles_l = 2;  ///< l ≥ 1: denominator a_1 … a_l.
  int delay_d = 1;  ///< d ≥ 0: input delay, samples.
  int knots_m = 6;  ///< m ≥ 2: knots u_1 < … < u_m.
};

/// Linear block θ_l = [θ_a; θ_b] (eq. 3).
struct LinearBlock {
  Eigen::VectorXd a;  ///< a_1 … a_l, dimensionless.
  Eigen::VectorXd b;  ///< b_0 … b_n, dimensionless (G(1) = 1 after normalisation).
};

/// An identified model.
struct SplineHammersteinModel {
  SplineOrders orders;
  Eigen::VectorXd knots_us;  ///< u_1 … u_m, µs, strictly increasing.
  Eigen::VectorXd beta;      ///< β_1 … β_{m+2} (eq. 2, normalised input), output units.
  LinearBlock linear;
  double baseline = 0.0;  ///< output offset added to predictions, output units.
};

struct SplineOptions {
  SplineOrders orders;
  double tolerance_eps = 1e-12;          ///< ε, relative to Σ y², > 0.
  int max_iterations = 500;              ///< outer iterations j at most.
  double initial_time_constant_s = 0.1;  ///< generic start: l poles at e^{−T/τ₀}, unit gain.
};

/// SISO data of one or more trials (baseline already removed from y).
struct SisoData {
  std::vector<Eigen::VectorXd> u_us;  ///< input per trial, µs.
  std::vector<Eigen::VectorXd> y;     ///< output per trial, output units.
  double sample_period_s = 0.0;       ///< T, s.
};

struct SplineFitReport {
  SplineHammersteinModel model;
  int iterations = 0;                ///< outer iterations j.
  int lm_iterations = 0;             ///< accepted Levenberg–Marquardt steps (Algorithm 2).
  std::vector<double> cost_history;  ///< V_N after each iteration.
  std::vector<double> step_wall_s;   ///< wall time of each local (LM) optimisation, s.
  /// The outer alternation (Alg. 1 or 2): converged when |V_j − V_{j−1}| < ε Σ y²
  /// ("cost_change_below_eps"), else "iteration_limit" after max_iterations.
  Convergence convergence;
  /// Algorithm 2: how each θ_a Levenberg–Marquardt run stopped (the last one is kept).
  std::vector<Convergence> step_convergence;
  double wall_s = 0.0;                        ///< total wall time, s.
  Eigen::VectorXd beta_ci95, a_ci95, b_ci95;  ///< 95 % half-widths (conditional), NaN if none.
};

/// m knots equally spaced on [u_min, u_max] (µs).
Eigen::VectorXd UniformKnots(double u_min_us, double u_max_us, int m);

/// Row of the m+2 basis functions of eq. (2) at u (µs) in the normalised input.
Eigen::RowVectorXd SplineBasis(const Eigen::VectorXd& knots_us, double u_us);

/// f(u) of eq. (2), output units.
double SplineValue(const Eigen::VectorXd& knots_us, const Eigen::VectorXd& beta, double u_us);

/// Simulated output (B/A) f(u) with zero initial conditions, without baseline (eq. 10).
Eigen::VectorXd SimulateSplineHammerstein(const SplineHammersteinModel& model,
                                          const Eigen::VectorXd& u_us);

/// The generic start: all l poles at e^{−T/τ₀}, b equal, unit static gain.
LinearBlock GenericLinearStart(const SplineOrders& orders, double sample_period_s,
                               double time_constant_s);

/// Algorithm 1 (ARX, alternating least squares) from `start`.
SplineFitReport FitSplineArx(const SisoData& data, const Eigen::VectorXd& knots_us,
                             const SplineOptions& options, const LinearBlock& start);

/// Algorithm 2 (OE, separable least squares + Levenberg–Marquardt on θ_a) from `start`
/// (normally Algorithm 1's linear block).
SplineFitReport FitSplineOe(const SisoData& data, const Eigen::VectorXd& knots_us,
                            const SplineOptions& options, const LinearBlock& start);

/// ARX cost V_N of eq. (7) summed over trials, and OE cost ‖y − ŷ‖² of eq. (4, 6).
double SplineArxCost(const SisoData& data, const SplineHammersteinModel& model);
double SplineOeCost(const SisoData& data, const SplineHammersteinModel& model);

/// CLI entries "spline-arx" (Algorithm 1) and "spline-oe" (Algorithm 1, then Algorithm 2).
/// Options from metadata of the first training trial: spline.zeros_n, spline.poles_l,
/// spline.delay_d, spline.knots_m, spline.eps, spline.max_iterations, spline.tau0_s.
MethodEntry SplineArxMethod();
MethodEntry SplineOeMethod();

}  // namespace fesim::identification
