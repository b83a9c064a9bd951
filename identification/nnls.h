// Small dense constrained least-squares solvers on Eigen, used by the monotone recruitment fit of
// [Copur 2016] (eq. 15, 17: least squares subject to A θ_n ≥ 0) and by bounded linear sub-problems.
//
// Algorithms from C. L. Lawson and R. J. Hanson, "Solving Least Squares Problems" (1974):
// NNLS (ch. 23, active set), LDP (ch. 23.3: least distance programming via NNLS) and LSI
// (ch. 23.5: least squares with linear inequalities reduced to LDP through a QR factorisation).
#pragma once

#include <Eigen/Dense>

namespace fesim::identification {

/// Result of an active-set solve.
struct ConstrainedLsResult {
  Eigen::VectorXd x;   ///< the minimiser.
  int iterations = 0;  ///< outer active-set iterations.
  bool converged = false;
};

/// Non-negative least squares: min ‖E x − f‖₂ subject to x ≥ 0 (Lawson–Hanson).
/// Throws std::invalid_argument on size mismatch.
ConstrainedLsResult Nnls(const Eigen::MatrixXd& E, const Eigen::VectorXd& f,
                         int max_iterations = 0);

/// Least-distance programming: min ‖x‖₂ subject to G x ≥ h. Throws std::runtime_error when the
/// constraints are infeasible.
ConstrainedLsResult LeastDistance(const Eigen::MatrixXd& G, const Eigen::VectorXd& h);

/// Least squares with linear inequalities: min ‖E x − f‖₂ subject to G x ≥ h. E must have full
/// column rank (checked: std::runtime_error otherwise, as for infeasible constraints).
ConstrainedLsResult LeastSquaresInequality(const Eigen::MatrixXd& E, const Eigen::VectorXd& f,
                                           const Eigen::MatrixXd& G, const Eigen::VectorXd& h);

}  // namespace fesim::identification
