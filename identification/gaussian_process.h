// Gaussian-process regression with a squared-exponential ARD kernel, marginal-likelihood
// hyper-parameters, closed-form leave-one-out residuals, and the semiparametric GP with an
// explicit basis-function prior ([Schearer 2014], "Identifying Inverse Human Arm
// Dynamics Using a Robotic Testbed", eq. 5–8).
//
// Kernel ([Schearer 2014] eq. 5, with one length scale per input — automatic relevance
// determination):
//   k(x, x') = σ_f² exp(−½ Σ_d (x_d − x'_d)² / ℓ_d²),   K_y = K + σ_n² I.
// Nonparametric prediction (eq. 6): μ(x*) = k*ᵀ K_y⁻¹ y, v(x*) = k(x*, x*) − k*ᵀ K_y⁻¹ k*.
// Log marginal likelihood (Rasmussen & Williams eq. 5.8, 5.9):
//   L = −½ (y − m)ᵀ Σ⁻¹ (y − m) − ½ log|Σ| − n/2 log 2π,  Σ = K_y (+ Φ B Φᵀ, semiparametric),
//   ∂L/∂θ_j = ½ tr((α αᵀ − Σ⁻¹) ∂Σ/∂θ_j),  α = Σ⁻¹ (y − m),  θ = (log ℓ_1..D, log σ_f, log σ_n).
// Semiparametric GP (eq. 7–8): mean h(x)ᵀβ with β ~ N(b, B); with Φ the n×k matrix whose rows
// are h(x_i)ᵀ (the paper's H is Φᵀ):
//   β̄ = (B⁻¹ + Φᵀ K_y⁻¹ Φ)⁻¹ (Φᵀ K_y⁻¹ y + B⁻¹ b)
//   μ(x*) = h*ᵀ β̄ + k*ᵀ K_y⁻¹ (y − Φ β̄)
//   v(x*) = k** − k*ᵀ K_y⁻¹ k* + rᵀ (B⁻¹ + Φᵀ K_y⁻¹ Φ)⁻¹ r,  r = h* − Φᵀ K_y⁻¹ k*.
// Closed-form LOO (Rasmussen & Williams eq. 5.12): y_i − μ_{−i} = [K_y⁻¹ y]_i / [K_y⁻¹]_ii,
// σ²_{−i} = 1 / [K_y⁻¹]_ii (for fixed hyper-parameters).
// Variances returned are of the latent function; add σ_n² for a new observation.
#pragma once

#include <Eigen/Dense>

#include "identification/method_support.h"

namespace fesim::identification {

/// Squared-exponential ARD hyper-parameters.
struct SeArdHyperParams {
  Eigen::VectorXd length_scales;  ///< ℓ_d, in the unit of input d, > 0.
  double signal_sd = 1.0;         ///< σ_f, unit of the output, > 0.
  double noise_sd = 0.1;          ///< σ_n, unit of the output, > 0.
};

/// θ = (log ℓ_1..D, log σ_f, log σ_n) and back.
Eigen::VectorXd ToLogVector(const SeArdHyperParams& hp);
SeArdHyperParams FromLogVector(const Eigen::VectorXd& theta);

/// k(a, b) (without the noise term).
double SeArdKernel(const SeArdHyperParams& hp, const Eigen::VectorXd& a, const Eigen::VectorXd& b);
/// K[i, j] = k(A.row(i), B.row(j)); A is n1×D, B is n2×D.
Eigen::MatrixXd SeArdKernelMatrix(const SeArdHyperParams& hp, const Eigen::MatrixXd& A,
                                  const Eigen::MatrixXd& B);

/// Log marginal likelihood and its gradient with respect to θ = ToLogVector(hp).
struct LogMarginalLikelihood {
  double value = 0.0;
  Eigen::VectorXd gradient;
};
/// y ~ N(mean, K_y + extra_cov). `mean` and `extra_cov` may be empty (zero).
LogMarginalLikelihood GpLogMarginalLikelihood(const SeArdHyperParams& hp, const Eigen::MatrixXd& X,
                                              const Eigen::VectorXd& y,
                                              const Eigen::VectorXd& mean = Eigen::VectorXd(),
                                              const Eigen::MatrixXd& extra_cov = Eigen::MatrixXd());

/// Which hyper-parameters are optimised, and bounds on the noise.
struct GpHyperFitOptions {
  bool fit_length_scales = true;
  bool fit_signal = true;
  bool fit_noise = true;
  double min_noise_sd = 1e-6;  ///< lower bound on σ_n, output unit.
  int max_iterations = 100;    ///< BFGS iterations.
};

/// Maximises the log marginal likelihood from `initial` by BFGS on θ with backtracking line
/// search; the analytic gradient is used. Returns the optimum (and the iteration count, and how
/// it stopped: converged on "gradient_below_tolerance" or "relative_objective_change_below_
/// tolerance"; not converged on "line_search_failed" or "iteration_limit").
SeArdHyperParams FitHyperParameters(const SeArdHyperParams& initial, const Eigen::MatrixXd& X,
                                    const Eigen::VectorXd& y, const GpHyperFitOptions& options,
                                    const Eigen::VectorXd& mean = Eigen::VectorXd(),
                                    const Eigen::MatrixXd& extra_cov = Eigen::MatrixXd(),
                                    int* iterations = nullptr, Convergence* convergence = nullptr);

/// Prediction of the latent function: mean (output unit) and variance (output unit²).
struct GpPrediction {
  double mean = 0.0;
  double variance = 0.0;
};

/// Zero-mean GP conditioned on (X, y) for fixed hyper-parameters ([Schearer 2014] eq. 5–6).
class GaussianProcess {
 public:
  GaussianProcess(const SeArdHyperParams& hp, const Eigen::MatrixXd& X, const Eigen::VectorXd& y);
  GpPrediction Predict(const Eigen::VectorXd& x) const;
  /// Means only at the rows of Xs (m × D), batched: K(Xs, X) K_y⁻¹ y.
  Eigen::VectorXd PredictMean(const Eigen::MatrixXd& Xs) const;
  /// y_i − μ_{−i}(x_i), closed form.
  Eigen::VectorXd LooResiduals() const;
  /// Predictive variance of y_i when left out, 1/[K_y⁻¹]_ii.
  Eigen::VectorXd LooVariances() const;
  const SeArdHyperParams& hyper() const { return hp_; }

 private:
  SeArdHyperParams hp_;
  Eigen::MatrixXd X_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
  Eigen::VectorXd alpha_;  // K_y⁻¹ y
};

/// Semiparametric GP ([Schearer 2014] eq. 7–8).
class SemiparametricGp {
 public:
  /// Phi is n×k (rows h(x_i)ᵀ); b (k) and B (k×k, SPD) the prior of β.
  SemiparametricGp(const SeArdHyperParams& hp, const Eigen::MatrixXd& X, const Eigen::VectorXd& y,
                   const Eigen::MatrixXd& Phi, const Eigen::VectorXd& b, const Eigen::MatrixXd& B);
  /// x: GP input; h: basis h(x) at the same point.
  GpPrediction Predict(const Eigen::VectorXd& x, const Eigen::VectorXd& h) const;
  /// Means only at the rows of Xs (m × D) with basis rows Hs (m × k), batched (eq. 8).
  Eigen::VectorXd PredictMean(const Eigen::MatrixXd& Xs, const Eigen::MatrixXd& Hs) const;
  /// β̄, the posterior mean of the basis coefficients.
  const Eigen::VectorXd& beta_bar() const { return beta_bar_; }

 private:
  SeArdHyperParams hp_;
  Eigen::MatrixXd X_, Phi_;
  Eigen::LLT<Eigen::MatrixXd> llt_;      // K_y
  Eigen::LDLT<Eigen::MatrixXd> a_ldlt_;  // B⁻¹ + Φᵀ K_y⁻¹ Φ
  Eigen::VectorXd beta_bar_, alpha_;     // alpha = K_y⁻¹ (y − Φ β̄)
};

}  // namespace fesim::identification
