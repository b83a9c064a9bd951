#include "identification/nnls.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace fesim::identification {
namespace {

/// Least squares restricted to the columns flagged in `passive` (others fixed at 0).
Eigen::VectorXd SolvePassive(const Eigen::MatrixXd& E, const Eigen::VectorXd& f,
                             const std::vector<bool>& passive) {
  std::vector<int> idx;
  for (int j = 0; j < static_cast<int>(passive.size()); ++j) {
    if (passive[j]) idx.push_back(j);
  }
  Eigen::VectorXd z = Eigen::VectorXd::Zero(E.cols());
  if (idx.empty()) return z;
  Eigen::MatrixXd Ep(E.rows(), static_cast<int>(idx.size()));
  for (int k = 0; k < static_cast<int>(idx.size()); ++k) Ep.col(k) = E.col(idx[k]);
  const Eigen::VectorXd zp = Ep.colPivHouseholderQr().solve(f);
  for (int k = 0; k < static_cast<int>(idx.size()); ++k) z(idx[k]) = zp(k);
  return z;
}

}  // namespace

ConstrainedLsResult Nnls(const Eigen::MatrixXd& E, const Eigen::VectorXd& f, int max_iterations) {
  if (E.rows() != f.size()) {
    throw std::invalid_argument("Nnls: E has " + std::to_string(E.rows()) + " rows, f has " +
                                std::to_string(f.size()));
  }
  const int n = static_cast<int>(E.cols());
  if (max_iterations <= 0) max_iterations = 3 * n + 30;
  ConstrainedLsResult r;
  r.x = Eigen::VectorXd::Zero(n);
  std::vector<bool> passive(n, false);
  const double tol = 10.0 * std::numeric_limits<double>::epsilon() * E.norm() *
                     std::max<double>(E.rows(), n) * std::max(1.0, f.norm());
  for (r.iterations = 0; r.iterations < max_iterations; ++r.iterations) {
    const Eigen::VectorXd w = E.transpose() * (f - E * r.x);
    int t = -1;
    double wmax = tol;
    for (int j = 0; j < n; ++j) {
      if (!passive[j] && w(j) > wmax) {
        wmax = w(j);
        t = j;
      }
    }
    if (t < 0) {
      r.converged = true;
      return r;
    }
    passive[t] = true;
    // Inner loop: keep the passive-set solution feasible.
    for (int inner = 0; inner <= n; ++inner) {
      const Eigen::VectorXd z = SolvePassive(E, f, passive);
      bool feasible = true;
      for (int j = 0; j < n; ++j) {
        if (passive[j] && z(j) <= 0.0) feasible = false;
      }
      if (feasible) {
        r.x = z;
        break;
      }
      double alpha = 1.0;
      for (int j = 0; j < n; ++j) {
        if (passive[j] && z(j) <= 0.0) alpha = std::min(alpha, r.x(j) / (r.x(j) - z(j)));
      }
      r.x += alpha * (z - r.x);
      for (int j = 0; j < n; ++j) {
        if (passive[j] && r.x(j) <= tol * 1e-3) {
          passive[j] = false;
          r.x(j) = 0.0;
        }
      }
    }
  }
  return r;
}

ConstrainedLsResult LeastDistance(const Eigen::MatrixXd& G, const Eigen::VectorXd& h) {
  if (G.rows() != h.size()) throw std::invalid_argument("LeastDistance: G and h sizes differ");
  const int m = static_cast<int>(G.rows());
  const int n = static_cast<int>(G.cols());
  ConstrainedLsResult r;
  if (m == 0) {
    r.x = Eigen::VectorXd::Zero(n);
    r.converged = true;
    return r;
  }
  // min ‖[Gᵀ; hᵀ] u − e_{n+1}‖ subject to u ≥ 0; the residual gives x (Lawson–Hanson 23.3).
  Eigen::MatrixXd E(n + 1, m);
  E.topRows(n) = G.transpose();
  E.row(n) = h.transpose();
  Eigen::VectorXd f = Eigen::VectorXd::Zero(n + 1);
  f(n) = 1.0;
  const ConstrainedLsResult u = Nnls(E, f);
  const Eigen::VectorXd res = E * u.x - f;
  if (res.norm() < 1e-12 || std::abs(res(n)) < 1e-12) {
    throw std::runtime_error("constrained least squares: inequality constraints are infeasible");
  }
  r.x = -res.head(n) / res(n);
  r.iterations = u.iterations;
  r.converged = u.converged;
  return r;
}

ConstrainedLsResult LeastSquaresInequality(const Eigen::MatrixXd& E, const Eigen::VectorXd& f,
                                           const Eigen::MatrixXd& G, const Eigen::VectorXd& h) {
  if (E.rows() != f.size() || G.rows() != h.size() || (G.rows() > 0 && G.cols() != E.cols())) {
    throw std::invalid_argument("LeastSquaresInequality: inconsistent sizes");
  }
  const int n = static_cast<int>(E.cols());
  if (E.rows() < n) {
    throw std::runtime_error("constrained least squares: fewer equations than unknowns");
  }
  // E = Q R (thin); x = R⁻¹ (z + Q₁ᵀ f) turns the problem into min ‖z‖ s.t. G R⁻¹ z ≥ h − G x_ls.
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(E);
  const Eigen::MatrixXd R = qr.matrixQR().topRows(n).triangularView<Eigen::Upper>();
  const double rmax = R.diagonal().cwiseAbs().maxCoeff();
  if (!(R.diagonal().cwiseAbs().minCoeff() > 1e-13 * rmax)) {
    throw std::runtime_error("constrained least squares: regressor matrix is rank deficient");
  }
  const Eigen::MatrixXd Qtf = (qr.householderQ().transpose() * f).head(n);
  const Eigen::VectorXd x_ls = R.triangularView<Eigen::Upper>().solve(Qtf);
  ConstrainedLsResult r;
  if (G.rows() == 0 || ((G * x_ls - h).array() >= 0.0).all()) {
    r.x = x_ls;
    r.converged = true;
    return r;
  }
  // G R⁻¹ = (R⁻ᵀ Gᵀ)ᵀ.
  const Eigen::MatrixXd GRinv =
      R.transpose().triangularView<Eigen::Lower>().solve(G.transpose()).transpose();
  const ConstrainedLsResult z = LeastDistance(GRinv, h - G * x_ls);
  r.x = x_ls + R.triangularView<Eigen::Upper>().solve(z.x);
  r.iterations = z.iterations;
  r.converged = z.converged;
  return r;
}

}  // namespace fesim::identification
