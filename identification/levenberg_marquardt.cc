#include "identification/levenberg_marquardt.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

namespace fesim::identification {
namespace {

void Clamp(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper, const ProjectionFn& project,
           Eigen::VectorXd* x) {
  *x = x->cwiseMax(lower).cwiseMin(upper);
  if (project) project(x);
}

Eigen::MatrixXd Jacobian(const ResidualFn& residual, const Eigen::VectorXd& x,
                         const Eigen::VectorXd& r0, const Eigen::VectorXd& upper, double rel,
                         int* evaluations) {
  Eigen::MatrixXd J(r0.size(), x.size());
  for (int k = 0; k < x.size(); ++k) {
    double h = rel * std::max(std::abs(x(k)), 1e-3);
    Eigen::VectorXd xp = x;
    if (xp(k) + h > upper(k)) h = -h;  // step inward at an upper bound
    xp(k) += h;
    J.col(k) = (residual(xp) - r0) / h;
    ++*evaluations;
  }
  return J;
}

/// Consecutive rejected trial steps on a secant Jacobian before it is re-evaluated.
constexpr int kSecantRejectionsBeforeRefresh = 3;

/// The damped Gauss–Newton step Δx = −(JᵀJ + λ diag(JᵀJ))⁻¹ g (diagonal entries at least
/// 1e-12). With `hold_active_bounds`, a variable on a bound whose descent direction −g_k points
/// outwards gets Δx_k = 0 and the others solve the reduced system.
Eigen::VectorXd DampedStep(const Eigen::MatrixXd& jtj, const Eigen::VectorXd& g, double lambda,
                           const Eigen::VectorXd& x, const Eigen::VectorXd& lower,
                           const Eigen::VectorXd& upper, bool hold_active_bounds) {
  const int p = static_cast<int>(x.size());
  Eigen::MatrixXd A = jtj;
  for (int k = 0; k < p; ++k) A(k, k) += lambda * std::max(jtj(k, k), 1e-12);
  Eigen::VectorXd rhs = -g;
  if (hold_active_bounds) {
    for (int k = 0; k < p; ++k) {
      const bool held = (x(k) <= lower(k) && g(k) > 0.0) ||  // −g_k points below lower
                        (x(k) >= upper(k) && g(k) < 0.0);    // −g_k points above upper
      if (!held) continue;
      A.row(k).setZero();  // decouple k: Δx_k = 0, the others solve the reduced system
      A.col(k).setZero();
      A(k, k) = 1.0;
      rhs(k) = 0.0;
    }
  }
  return A.ldlt().solve(rhs);
}

/// Keeps a secant J from degenerating (Madsen, Nielsen & Tingleff 2004, Alg. 3.34): when the
/// step dx hardly moves along coordinate j (the next of a cycle), re-evaluates column j of *J by
/// a forward difference at x (residual r there). Returns whether it did (one residual
/// evaluation).
bool RefreshSecantColumn(const ResidualFn& residual, const Eigen::VectorXd& x,
                         const Eigen::VectorXd& r, const Eigen::VectorXd& dx,
                         const Eigen::VectorXd& upper, double fd_relative_step, int j,
                         Eigen::MatrixXd* J) {
  if (!(std::abs(dx(j)) < 0.8 * dx.norm())) return false;
  double h = fd_relative_step * std::max(std::abs(x(j)), 1e-3);
  if (x(j) + h > upper(j)) h = -h;
  Eigen::VectorXd xj = x;
  xj(j) += h;
  J->col(j) = (residual(xj) - r) / h;
  return true;
}

/// λ's factor after an accepted step: Nielsen's max(1/3, 1 − (2ρ − 1)³) with the gain ratio
/// ρ = decrease / predicted when `gain_ratio_damping` (and the predicted decrease is positive),
/// else 1/3.
double AcceptedStepDampingFactor(const LmOptions& options, double decrease, double predicted) {
  return options.gain_ratio_damping && predicted > 0.0
             ? std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * decrease / predicted - 1.0, 3))
             : 1.0 / 3.0;
}

}  // namespace

const char* LmStopReasonName(LmStopReason reason) {
  switch (reason) {
    case LmStopReason::kRelativeDecrease:
      return "relative_cost_decrease_below_tolerance";
    case LmStopReason::kStepTolerance:
      return "step_below_tolerance";
    case LmStopReason::kZeroCost:
      return "zero_cost";
    case LmStopReason::kIterationLimit:
      return "iteration_limit";
    case LmStopReason::kNoDecrease:
      return "damping_overflow_no_decrease_possible";
  }
  return "unknown";
}

bool LmConverged(LmStopReason reason) {
  return reason == LmStopReason::kRelativeDecrease || reason == LmStopReason::kStepTolerance ||
         reason == LmStopReason::kZeroCost;
}

Convergence ToConvergence(const LmResult& result) {
  return {result.converged, LmStopReasonName(result.stop_reason), result.iterations};
}

namespace {

/// The iteration of LevenbergMarquardt and LevenbergMarquardtOnCost: exactly one of `residual`
/// and `cost` is set; with `cost`, r is never formed (res.residual stays empty) and
/// `normal_equations` is set, broyden off.
LmResult Minimise(const ResidualFn& residual, const CostFn& cost, Eigen::VectorXd x0,
                  const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                  const LmOptions& options, const ProjectionFn& project, const JacobianFn& jacobian,
                  const NormalEquationsFn& normal_equations) {
  if (lower.size() != x0.size() || upper.size() != x0.size()) {
    throw std::invalid_argument("LevenbergMarquardt: bounds and x0 sizes differ");
  }
  if (normal_equations && options.broyden) {
    throw std::invalid_argument("LevenbergMarquardt: normal equations need broyden = false");
  }
  // ‖r(x)‖², and r(x) into *r unless only the cost is given.
  const auto evaluate = [&](const Eigen::VectorXd& x, Eigen::VectorXd* r) {
    if (cost) return cost(x);
    *r = residual(x);
    return r->squaredNorm();
  };
  LmResult res;
  Clamp(lower, upper, project, &x0);
  res.x = x0;
  res.cost = evaluate(res.x, &res.residual);
  res.evaluations = 1;
  const int p = static_cast<int>(x0.size());
  const auto jac = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& r) {
    ++res.jacobian_evaluations;
    return jacobian ? jacobian(x, r, &res.evaluations)
                    : Jacobian(residual, x, r, upper, options.fd_relative_step, &res.evaluations);
  };
  Eigen::MatrixXd J;  // unused with normal_equations
  Eigen::MatrixXd jtj;
  Eigen::VectorXd g;
  bool fresh = true;  // J was evaluated at res.x (not a secant update)
  const auto refresh = [&] {
    if (normal_equations) {
      ++res.jacobian_evaluations;
      normal_equations(res.x, res.residual, &jtj, &g, &res.evaluations);
    } else {
      J = jac(res.x, res.residual);
      jtj = JacobianGram(J);
      g = J.transpose() * res.residual;
    }
    fresh = true;
  };
  refresh();
  res.cost_history.push_back(res.cost);
  res.evaluations_history.push_back(res.evaluations);
  double lambda = options.scale_free_damping
                      ? options.initial_damping
                      : options.initial_damping * std::max(jtj.diagonal().maxCoeff(), 1e-300);
  double nu = 2.0;
  int rejected = 0;  // trial steps rejected since the last accepted one
  int cycle = 0;     // next coordinate of the secant column refresh
  res.stop_reason = LmStopReason::kIterationLimit;
  if (res.cost == 0.0) res.stop_reason = LmStopReason::kZeroCost;
  while (res.cost != 0.0 && res.iterations < options.max_iterations) {
    Eigen::VectorXd x_new =
        res.x + DampedStep(jtj, g, lambda, res.x, lower, upper, options.hold_active_bounds);
    Clamp(lower, upper, project, &x_new);
    const Eigen::VectorXd dx = x_new - res.x;
    if (dx.norm() <= options.step_tolerance * (res.x.norm() + options.step_tolerance)) {
      if (!fresh) {  // only a secant J says so: check with a real one
        refresh();
        continue;
      }
      // A step that vanished only because the damping grew over rejected trials, before any
      // step was accepted, leaves the start point: that is no convergence.
      res.stop_reason = res.iterations == 0 && rejected > 0 ? LmStopReason::kNoDecrease
                                                            : LmStopReason::kStepTolerance;
      break;
    }
    if (options.broyden) {
      const int j = cycle;
      cycle = (cycle + 1) % p;
      if (RefreshSecantColumn(residual, res.x, res.residual, dx, upper, options.fd_relative_step, j,
                              &J)) {
        ++res.evaluations;
        fresh = false;
      }
    }
    Eigen::VectorXd r_new;
    const double cost_new = evaluate(x_new, &r_new);
    ++res.evaluations;
    if (options.broyden && r_new.allFinite()) {
      // Broyden's rank-one secant update after every trial step, accepted or not:
      // J_new Δx = r(x + Δx) − r(x) exactly, J unchanged on the directions orthogonal to Δx.
      J += ((r_new - res.residual) - J * dx) * (dx.transpose() / dx.squaredNorm());
      fresh = false;
    }
    if (std::isfinite(cost_new) && cost_new < res.cost) {
      const double decrease = res.cost - cost_new;
      res.x = x_new;
      res.residual = std::move(r_new);
      const double old_cost = res.cost;
      res.cost = cost_new;
      ++res.iterations;
      res.cost_history.push_back(res.cost);
      res.evaluations_history.push_back(res.evaluations);
      const double predicted = -(2.0 * g.dot(dx) + dx.dot(jtj * dx));
      lambda = std::max(lambda * AcceptedStepDampingFactor(options, decrease, predicted), 1e-300);
      nu = 2.0;
      rejected = 0;
      if (options.broyden) {
        jtj = JacobianGram(J);
        g = J.transpose() * res.residual;
      } else {
        refresh();
      }
      if (res.cost == 0.0) {
        res.stop_reason = LmStopReason::kZeroCost;
        break;
      }
      if (decrease <= options.relative_tolerance * old_cost &&
          (!options.stop_needs_predicted_decrease ||
           predicted <= options.relative_tolerance * old_cost)) {
        if (!fresh) {  // a small decrease along a secant step: go on with a real Jacobian
          refresh();
          continue;
        }
        res.stop_reason = LmStopReason::kRelativeDecrease;
        break;
      }
    } else {
      ++rejected;
      if (!fresh && rejected >= kSecantRejectionsBeforeRefresh) {
        refresh();  // the secant Jacobian keeps failing: re-evaluate it, same damping
        continue;
      }
      if (!fresh) {  // J now holds the rejected step's secant information
        jtj = JacobianGram(J);
        g = J.transpose() * res.residual;
      }
      lambda *= nu;
      nu *= 2.0;
      if (!std::isfinite(lambda) || lambda > 1e300) {
        res.stop_reason = LmStopReason::kNoDecrease;
        break;
      }
    }
  }
  if (options.broyden && !fresh) refresh();  // iteration limit on a secant J: real JᵀJ for CIs
  res.jtj = jtj;
  res.converged = LmConverged(res.stop_reason);
  return res;
}

}  // namespace

Eigen::MatrixXd JacobianGram(const Eigen::MatrixXd& J) {
  const Eigen::Index p = J.cols();
  Eigen::MatrixXd G(p, p);
  for (Eigen::Index i = 0; i < p; ++i) {
    for (Eigen::Index j = 0; j <= i; ++j) G(i, j) = G(j, i) = J.col(i).dot(J.col(j));
  }
  return G;
}

LmResult LevenbergMarquardt(const ResidualFn& residual, Eigen::VectorXd x0,
                            const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                            const LmOptions& options, const ProjectionFn& project,
                            const JacobianFn& jacobian, const NormalEquationsFn& normal_equations) {
  return Minimise(residual, {}, std::move(x0), lower, upper, options, project, jacobian,
                  normal_equations);
}

LmResult LevenbergMarquardtOnCost(const CostFn& cost, Eigen::VectorXd x0,
                                  const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                                  const NormalEquationsFn& normal_equations,
                                  const LmOptions& options, const ProjectionFn& project) {
  if (!cost || !normal_equations) {
    throw std::invalid_argument("LevenbergMarquardtOnCost: needs the cost and normal equations");
  }
  return Minimise({}, cost, std::move(x0), lower, upper, options, project, {}, normal_equations);
}

Eigen::VectorXd ConfidenceHalfWidths95(const Eigen::MatrixXd& jtj, double cost, long n_residuals,
                                       double participation) {
  const long p = jtj.rows();
  Eigen::VectorXd half = Eigen::VectorXd::Constant(p, std::numeric_limits<double>::quiet_NaN());
  if (n_residuals <= p || p == 0) return half;
  // Pseudo-inverse; parameters that take part in an unidentifiable direction (e.g. one held at a
  // bound where the cost is flat) get NaN, the others their interval.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(jtj);
  const Eigen::VectorXd& s = eig.eigenvalues();
  const Eigen::MatrixXd& V = eig.eigenvectors();
  const double smax = s.cwiseAbs().maxCoeff();
  if (!(smax > 0.0)) return half;
  std::vector<bool> free(static_cast<std::size_t>(p), true);
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(p);
  for (long i = 0; i < p; ++i) {
    if (s(i) > 1e-12 * smax) {
      inv(i) = 1.0 / s(i);
    } else {
      for (long k = 0; k < p; ++k) {
        if (std::abs(V(k, i)) > participation) free[static_cast<std::size_t>(k)] = false;
      }
    }
  }
  const Eigen::MatrixXd cov =
      V * inv.asDiagonal() * V.transpose() * (cost / static_cast<double>(n_residuals - p));
  for (long k = 0; k < p; ++k) {
    if (free[static_cast<std::size_t>(k)]) half(k) = 1.96 * std::sqrt(std::max(cov(k, k), 0.0));
  }
  return half;
}

}  // namespace fesim::identification
