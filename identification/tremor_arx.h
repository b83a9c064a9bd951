// Tremor wrist model: co-activation of two antagonists, monotone polynomial recruitment, ARX plant
// with a periodic tremor term, its iterative identification and the order sweep.
//
// Paper: [Copur 2016] (docs/papers.md), §3–4.
//   co-activation: u_fcr = u + c_fcr (u ≥ 0) else c_fcr; u_ecr = c_ecr (u ≥ 0) else c_ecr − u  eq.
//   (5) P(q) = B_P/A_P = (b_0 q^{-m_P} + … + b_{n_P} q^{-(m_P+n_P)}) / (1 + a_1 q^{-1} + … +
//   a_{l_P} q^{-l_P})
//                                                                                     eq. (8)
//   h_IRC(u) = β_0 + β_1 u + … + β_m u^m, monotone: dh/du ≥ 0 on [u_min, u_max]       eq. (9), (13)
//   d(k) = λ_1 cos(2πk/N_p) + λ_2 sin(2πk/N_p)                                         eq. (10)
//   A_P y = B_P h_IRC(u) + d + e  (ARX), one-step error eq. (12), cost eq. (14)
//   Algorithm 1: θ_n by constrained least squares (eq. 15–17, here Lawson–Hanson LSI/NNLS),
//   then θ_l = [θ_a; θ_b; λ_1; λ_2] by least squares (eq. 18–21), until |ΔV_N| < ε.
//   Evaluation: Best Fit (eq. 23) of the simulated output; validation = model of trial i on trial
//   i, cross-validation = model of trial i on trial i+1 (cyclic), averaged (§4.2).
//
// Trial conventions: inputs = exactly two u.* columns, the first the agonist of positive output
// (e.g. u.fcr, flexion), the second its antagonist (u.ecr); the combined input u (µs, signed) is
// recovered by inverting eq. (5) with co-activation levels c = per-channel minimum over the
// training trials (or given). Output = the single q.<joint> column (rad), increasing with u at
// steady state (flexion positive). Trials uniformly sampled.
//
// Departures, stated:
// * The polynomial is evaluated in s = u/u_scale, u_scale = max |u| of the training data, for
//   conditioning; β are per unit s^k, rad.
// * The gain of B_P h is not identifiable: the model is normalised to P(1) = B_P(1)/A_P(1) = 1
// after
//   every iteration (h_IRC is then the steady-state angle curve); the monotonicity constraint uses
//   that normalisation, so B_P(1)/A_P(1) > 0 is assumed.
// * Monotonicity is imposed on a grid of `constraint_points` values of s over the data range
//   (the paper uses the data samples), then verified exactly at the real roots of h'' and the
//   interval ends; any violating point is added and the problem re-solved, so h' ≥ 0 holds on the
//   whole interval, not only at samples.
// * λ_1, λ_2 are real (the paper's "integers" would not fit a continuous amplitude). The tremor
//   period N_p need not be an integer: when not given, the frequency is found by scanning the
//   periodogram of the one-step residual of a tremor-free fit of order ≤ 2 over
//   [tremor_min_hz, tremor_max_hz]; its 3 largest peaks compete on V_N of the full fit, and the
//   winner is refined by golden-section search on V_N.
// * Simulated output: ŷ = (B_P/A_P) h_IRC(u) + d/A_P from the first l_P measured samples.
// * ε is relative: stop when |V_N^j − V_N^{j−1}| < ε Σ y².
// * Computation, not model: eq. (12)'s residual is linear in the lifted regressor z(k) = [y(k),
//   y lags, 1, s^p lags, cos ω k, sin ω k]; its columns other than cos/sin are factorised once
//   (Householder QR over the N rows), each tremor frequency adds its two columns, and both steps
//   of Algorithm 1 and V_N (eq. 14) are solved on the small R factor, so an iteration costs
//   nothing in N and a frequency O(N).
#pragma once

#include <Eigen/Dense>
#include <complex>
#include <vector>

#include "identification/method.h"
#include "identification/method_support.h"

namespace fesim::identification {

/// Orders of eq. (8)–(9).
struct TremorOrders {
  int poles_l = 12;     ///< l_P ≥ 1 (paper's recommended 12).
  int zeros_n = 7;      ///< n_P ≥ 0 (paper's recommended 7).
  int delay_m = 1;      ///< m_P ≥ 0, samples (paper's recommended 1).
  int poly_degree = 3;  ///< m ≥ 1 of eq. (9).
};

struct TremorOptions {
  TremorOrders orders;
  double tolerance_eps = 1e-12;  ///< ε relative to Σ y².
  int max_iterations = 500;
  double tremor_hz = 0.0;      ///< tremor frequency, Hz; 0 = estimate.
  double tremor_min_hz = 3.0;  ///< search band, Hz.
  double tremor_max_hz = 12.0;
  int constraint_points = 101;  ///< monotonicity grid over the data range of s.
};

/// Co-activation levels of eq. (5), µs.
struct Coactivation {
  double c_agonist_us = 0.0;     ///< c_fcr.
  double c_antagonist_us = 0.0;  ///< c_ecr.
};

/// Eq. (5): combined u (µs, signed) → (u_agonist, u_antagonist) pulse widths, µs.
Eigen::Vector2d CoactivationSplit(const Coactivation& c, double u_us);
/// Inverse of eq. (5): u = (u_ag − c_ag) − (u_ant − c_ant).
double CoactivationCombine(const Coactivation& c, double u_agonist_us, double u_antagonist_us);

struct TremorModel {
  TremorOrders orders;
  double u_scale_us = 300.0;            ///< s = u/u_scale.
  Eigen::VectorXd beta;                 ///< β_0 … β_m (per unit s^k), rad.
  Eigen::VectorXd a;                    ///< a_1 … a_{l_P}.
  Eigen::VectorXd b;                    ///< b_0 … b_{n_P}.
  double lambda1 = 0.0, lambda2 = 0.0;  ///< tremor amplitudes in the ARX equation, rad.
  double tremor_hz = 0.0;               ///< f = 1/(N_p T), Hz.
  double sample_period_s = 0.0;
  double s_min = -1.0, s_max = 1.0;  ///< data range of s where monotonicity is guaranteed.
};

struct TremorData {
  std::vector<Eigen::VectorXd> u_us;  ///< combined input per trial, µs.
  std::vector<Eigen::VectorXd> y;     ///< output per trial, rad.
  double sample_period_s = 0.0;
};

struct TremorFit {
  TremorModel model;
  int iterations = 0;
  /// The iterative algorithm (§3.3.4): converged when |V_j − V_{j−1}| < ε Σ y²
  /// ("cost_change_below_eps"), else "iteration_limit".
  Convergence convergence;
  std::vector<double> cost_history;
  double wall_s = 0.0;
  Eigen::VectorXd beta_ci95, theta_l_ci95;  ///< conditional 95 % half-widths.
};

/// h_IRC(u) and dh/du (per µs) of eq. (9), (13).
double TremorRecruitment(const TremorModel& m, double u_us);
double TremorRecruitmentSlope(const TremorModel& m, double u_us);

/// min over [s_min, s_max] of dh/ds (exact: ends and real roots of h'').
double MinimumRecruitmentSlope(const Eigen::VectorXd& beta, double s_min, double s_max);

/// Simulated output (see header) with the first l_P samples taken from `y_init`.
Eigen::VectorXd SimulateTremorArx(const TremorModel& m, const Eigen::VectorXd& u_us,
                                  const Eigen::VectorXd& y_init);

/// Algorithm 1 with the given orders; `u_scale_us` fixes s = u/u_scale.
TremorFit FitTremorArx(const TremorData& data, const TremorOptions& options, double u_scale_us);

/// Order sweep (§4.2–4.3): for every (l_P, n_P, m_P) of the grid and every trial i, fit on trial
/// i; validation Best Fit on trial i, cross-validation on trial i+1 (cyclic), averaged.
/// `progress` (optional) is told the fraction of the grid done.
struct TremorSweepEntry {
  TremorOrders orders;
  double validation_best_fit = 0.0;        ///< %.
  double cross_validation_best_fit = 0.0;  ///< %.
  /// The ARX polynomials a_1 … a_{l_P}, b_0 … b_{n_P} of the model fitted on data set 1 (the
  /// models whose frequency responses paper 001 Figs 9–10 compare across orders).
  Eigen::VectorXd first_a, first_b;
};
std::vector<TremorSweepEntry> SweepTremorOrders(const TremorData& data, const TremorOptions& base,
                                                const std::vector<int>& poles,
                                                const std::vector<int>& zeros,
                                                const std::vector<int>& delays, double u_scale_us,
                                                const ProgressFn& progress = nullptr);

/// Frequency response of eq. (8)'s linear block from h to y at f_hz: with z = exp(j 2π f T),
/// H = z^{−m} Σ_j b_j z^{−j} / (1 + Σ_i a_i z^{−i}) (the recursion of SimulateTremorArx), a =
/// a_1 … a_l, b = b_0 … b_n, m = delay_m samples, T the sample period (s). Dimensionless (h and
/// y in rad). Throws std::invalid_argument when T ≤ 0 or b is empty.
std::complex<double> TremorArxResponse(const Eigen::VectorXd& a, const Eigen::VectorXd& b,
                                       int delay_m, double sample_period_s, double f_hz);

/// CLI entry "tremor-arx". With ≥ 2 training trials, the orders are chosen by a sweep over
/// l_P ∈ {2, 4, 8, 12}, n_P ∈ {1, 3, 7, 12}, m_P ∈ {1} (best cross-validation), unless given in
/// metadata: tremor.poles_l, tremor.zeros_n, tremor.delay_m, tremor.poly_degree, tremor.hz,
/// tremor.c_agonist_us, tremor.c_antagonist_us, tremor.eps, tremor.sweep (0/1).
MethodEntry TremorArxMethod();

}  // namespace fesim::identification
