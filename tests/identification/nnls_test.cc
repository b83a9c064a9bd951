#include "identification/nnls.h"

#include <gtest/gtest.h>

#include <limits>
#include <random>

namespace fesim::identification {
namespace {

constexpr double kKktTol = 1e-9;
constexpr double kObjTol = 1e-9;
constexpr int kProblems = 200;
constexpr unsigned kSeed = 11;

Eigen::MatrixXd RandomMatrix(int r, int c, std::mt19937* rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::MatrixXd M(r, c);
  for (int i = 0; i < r; ++i)
    for (int j = 0; j < c; ++j) M(i, j) = n(*rng);
  return M;
}

TEST(Nnls, SatisfiesKktConditions) {
  std::mt19937 rng(kSeed);
  for (int t = 0; t < kProblems; ++t) {
    const Eigen::MatrixXd E = RandomMatrix(12, 6, &rng);
    const Eigen::VectorXd f = RandomMatrix(12, 1, &rng);
    const auto r = Nnls(E, f);
    ASSERT_TRUE(r.converged);
    const Eigen::VectorXd w = E.transpose() * (f - E * r.x);  // −gradient / 2
    for (int j = 0; j < 6; ++j) {
      EXPECT_GE(r.x(j), 0.0);
      if (r.x(j) > 0.0) {
        EXPECT_NEAR(w(j), 0.0, kKktTol);
      } else {
        EXPECT_LE(w(j), kKktTol);
      }
    }
  }
}

// Brute force over active sets: every subset of constraints held as equalities.
double BruteForceLsi(const Eigen::MatrixXd& E, const Eigen::VectorXd& f, const Eigen::MatrixXd& G,
                     const Eigen::VectorXd& h) {
  const int m = static_cast<int>(G.rows()), n = static_cast<int>(E.cols());
  double best = std::numeric_limits<double>::infinity();
  for (int mask = 0; mask < (1 << m); ++mask) {
    std::vector<int> act;
    for (int i = 0; i < m; ++i)
      if (mask & (1 << i)) act.push_back(i);
    if (static_cast<int>(act.size()) > n) continue;
    const int a = static_cast<int>(act.size());
    Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n + a, n + a);
    Eigen::VectorXd rhs(n + a);
    K.topLeftCorner(n, n) = E.transpose() * E;
    rhs.head(n) = E.transpose() * f;
    for (int k = 0; k < a; ++k) {
      K.block(n + k, 0, 1, n) = G.row(act[k]);
      K.block(0, n + k, n, 1) = G.row(act[k]).transpose();
      rhs(n + k) = h(act[k]);
    }
    const Eigen::VectorXd sol = K.fullPivLu().solve(rhs);
    const Eigen::VectorXd x = sol.head(n);
    if (((G * x - h).array() >= -1e-10).all()) best = std::min(best, (E * x - f).squaredNorm());
  }
  return best;
}

TEST(LeastSquaresInequality, MatchesBruteForceActiveSetEnumeration) {
  std::mt19937 rng(kSeed + 1);
  for (int t = 0; t < kProblems; ++t) {
    const Eigen::MatrixXd E = RandomMatrix(8, 3, &rng);
    const Eigen::VectorXd f = RandomMatrix(8, 1, &rng);
    const Eigen::MatrixXd G = RandomMatrix(5, 3, &rng);
    const Eigen::VectorXd h = RandomMatrix(5, 1, &rng) * 0.5 - Eigen::VectorXd::Ones(5);
    const double best = BruteForceLsi(E, f, G, h);
    if (!std::isfinite(best)) continue;
    const auto r = LeastSquaresInequality(E, f, G, h);
    EXPECT_TRUE(((G * r.x - h).array() >= -1e-9).all());
    EXPECT_NEAR((E * r.x - f).squaredNorm(), best, kObjTol * (1.0 + best));
  }
}

TEST(LeastSquaresInequality, InactiveConstraintsGiveOrdinaryLeastSquares) {
  std::mt19937 rng(kSeed + 2);
  const Eigen::MatrixXd E = RandomMatrix(10, 4, &rng);
  const Eigen::VectorXd f = RandomMatrix(10, 1, &rng);
  const Eigen::VectorXd x_ls = E.colPivHouseholderQr().solve(f);
  const Eigen::MatrixXd G = Eigen::MatrixXd::Identity(4, 4);
  const Eigen::VectorXd h = x_ls.array() - 1.0;
  EXPECT_LT((LeastSquaresInequality(E, f, G, h).x - x_ls).norm(), 1e-12);
}

TEST(LeastSquaresInequality, InfeasibleAndRankDeficientAreReported) {
  Eigen::MatrixXd E = Eigen::MatrixXd::Identity(3, 2);
  const Eigen::VectorXd f = Eigen::VectorXd::Ones(3);
  Eigen::MatrixXd G(2, 2);
  G << 1, 0, -1, 0;  // x0 ≥ 1 and −x0 ≥ 0: empty
  EXPECT_THROW(LeastSquaresInequality(E, f, G, Eigen::Vector2d(1.0, 0.0)), std::runtime_error);
  E.col(1) = E.col(0);
  EXPECT_THROW(LeastSquaresInequality(E, f, G, Eigen::Vector2d(0.0, -1.0)), std::runtime_error);
}

}  // namespace
}  // namespace fesim::identification
