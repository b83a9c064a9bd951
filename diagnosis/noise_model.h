// The residual's discrepancy model of `fesim diagnose` (PRODUCT.md "Diagnosis" step 3): what a
// calibrated model still gets wrong on data it did not make is coloured — slow misfit from every
// detail of the person it cannot represent — and a test that takes the residual for white noise
// finds every candidate "significant". Here the residual is modelled per output as a stationary
// autoregressive process (Box & Jenkins 1970; Ljung 1999 "System Identification" §4.2, the noise
// model H(q) = 1/A(q) of an output-error model with coloured noise),
//     r_i = Σ_{k=1..p} a_k r_{i−k} + e_i,   e_i white, variance σ_e²,
// fitted by least squares on the contiguous runs of finite samples, order p ≤ max_order chosen by
// BIC. Its covariance Σ = σ_e² A⁻¹A⁻ᵀ (A the lower-triangular Toeplitz matrix of 1 − Σ a_k q^{−k}
// per run; outputs and runs independent) enters the tests as the variance of a projection:
//   robust score test  S = gᵀ (D̃ᵀ Σ D̃)⁻¹ g,  g = D̃ᵀ r  (a sandwich, Huber–White form: the
//                      least-squares score with the variance it has under coloured noise);
//   robust LR          ΔRSS / σ_d²,  σ_d² = dᵀΣd / dᵀd the noise variance along the change d
//                      of the fitted residual;
//   held-out gain      the Diebold–Mariano test (Diebold & Mariano 1995, J Bus Econ Stat 13:253)
//                      of the loss differential r₀² − r₁², its long-run variance from an AR
//                      model of the differential (den Haan & Levin 1997's VARHAC).
// A direction the misfit can mimic (slow, input-shaped) is judged against the misfit's power
// there; one it cannot (a spectral line, a trend over the record, a constant lag) against the
// measurement noise.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "diagnosis/extended_model.h"

namespace fesim::diagnosis {

/// Where each row of a stacked residual (StackResiduals' order) comes from: its output and the
/// contiguous run of consecutive samples it belongs to (a new run at every trial, output or gap).
struct RowLayout {
  std::vector<int> output;  ///< output index of each row.
  std::vector<int> run;     ///< run id of each row, non-decreasing.
  int outputs = 0;
  long rows() const { return static_cast<long>(output.size()); }
};
RowLayout LayoutOf(const DataView& view);

/// AR model of one output's residual.
struct ArModel {
  Eigen::VectorXd a;            ///< a_1 … a_p.
  double innovation_var = 0.0;  ///< σ_e², unit² of the residual.
  double variance = 0.0;        ///< sample variance of the residual, unit².
};

struct NoiseModel {
  std::vector<ArModel> outputs;  ///< per output.
};

/// Largest AR order considered (BIC chooses ≤ this).
inline constexpr int kMaxNoiseOrder = 12;

/// Per output, AR(p) fitted to `r` (rows of `layout`) by least squares over the runs, p ∈
/// [0, max_order] by BIC. Runs shorter than p + 2 rows do not enter. r.size() must equal
/// layout.rows() (std::invalid_argument).
NoiseModel FitNoiseModel(const RowLayout& layout, const Eigen::VectorXd& r,
                         int max_order = kMaxNoiseOrder);

/// Dᵀ Σ D for the model's covariance Σ (D: rows of `layout` × k).
Eigen::MatrixXd CovarianceForm(const NoiseModel& noise, const RowLayout& layout,
                               const Eigen::MatrixXd& d);

/// The robust score test of the directions D (N × k) against residual r with nuisance Jacobian J
/// (N × q, projected out): S = gᵀ (D̃ᵀ Σ D̃)⁻¹ g with D̃ = (I − P_J) D, g = D̃ᵀ r, and Σ from an AR
/// model of r with [J, D] projected out (the noise estimated without the effect the directions
/// carry). Directions flagged one-sided whose Gauss–Newton coefficient θ = −(D̃ᵀD̃)⁻¹ g comes out
/// negative are dropped (the most negative first) and the test repeated on the rest.
struct ScoreTest {
  double statistic = 0.0;
  int dof = 0;            ///< directions kept.
  Eigen::VectorXd theta;  ///< GN coefficients (0 for dropped directions).
  /// Noise variance along the kept directions relative to the white estimate rᵀr/N (1 for white
  /// residuals; ≫ 1 when the misfit has power where the directions do).
  double variance_inflation = 1.0;
};
ScoreTest RobustScoreTest(const RowLayout& layout, const Eigen::VectorXd& r,
                          const Eigen::MatrixXd& d, const Eigen::MatrixXd& j,
                          const std::vector<bool>& one_sided);

/// The robust likelihood-ratio statistic of a fit that moved the training residual from r0 to
/// r1: (‖r0‖² − ‖r1‖²) / σ_d², σ_d² = dᵀΣd / dᵀd with d = r0 − r1 and Σ from an AR model of r1;
/// 0 when the fit did not lower the residual. Compare with χ²_p (p fitted parameters).
double RobustLikelihoodRatio(const RowLayout& layout, const Eigen::VectorXd& r0,
                             const Eigen::VectorXd& r1);

/// The Diebold–Mariano statistic of the held-out loss differential l = r0² − r1² (rows of
/// `layout`): mean(l) / √(LRV / N), LRV = σ_e² / (1 − Σa)² of an AR model of l − mean(l) (BIC).
/// Positive: r1 predicts better. ~ N(0, 1) when both predict equally well.
double DieboldMariano(const RowLayout& layout, const Eigen::VectorXd& r0,
                      const Eigen::VectorXd& r1);

/// Upper-tail probability of the standard normal distribution, P(Z > z).
double NormalSurvival(double z);

}  // namespace fesim::diagnosis
