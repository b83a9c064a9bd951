#include "identification/gaussian_process.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace fesim::identification {
namespace {

constexpr double kGradientRelTol = 1e-5;  // analytic vs central differences
constexpr double kFdStep = 1e-5;          // in log hyper-parameter space
constexpr double kLooTol = 1e-8;          // closed form vs explicit refit
constexpr double kExactTol = 1e-10;
constexpr unsigned kSeed = 2016;

struct Data {
  Eigen::MatrixXd X;
  Eigen::VectorXd y;
};

/// y = sin(x0) + 0.5 x1² − 0.3 x2 + noise, x ~ U(−2, 2)³.
Data MakeData(int n, double noise, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  std::normal_distribution<double> e(0.0, noise);
  Data d;
  d.X.resize(n, 3);
  d.y.resize(n);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) d.X(i, k) = u(rng);
    d.y(i) = std::sin(d.X(i, 0)) + 0.5 * d.X(i, 1) * d.X(i, 1) - 0.3 * d.X(i, 2) + e(rng);
  }
  return d;
}

SeArdHyperParams Hyper() {
  SeArdHyperParams hp;
  hp.length_scales = Eigen::Vector3d(0.9, 1.4, 2.5);
  hp.signal_sd = 1.3;
  hp.noise_sd = 0.2;
  return hp;
}

void ExpectGradientMatchesFiniteDifferences(const Data& d, const Eigen::VectorXd& mean,
                                            const Eigen::MatrixXd& extra) {
  const SeArdHyperParams hp = Hyper();
  const auto lml = GpLogMarginalLikelihood(hp, d.X, d.y, mean, extra);
  const Eigen::VectorXd theta = ToLogVector(hp);
  for (Eigen::Index j = 0; j < theta.size(); ++j) {
    Eigen::VectorXd tp = theta, tm = theta;
    tp(j) += kFdStep;
    tm(j) -= kFdStep;
    const double fd = (GpLogMarginalLikelihood(FromLogVector(tp), d.X, d.y, mean, extra).value -
                       GpLogMarginalLikelihood(FromLogVector(tm), d.X, d.y, mean, extra).value) /
                      (2.0 * kFdStep);
    EXPECT_NEAR(lml.gradient(j), fd, kGradientRelTol * std::max(1.0, std::abs(fd)))
        << "hyper-parameter " << j;
  }
}

TEST(GaussianProcess, KernelMatrixMatchesKernel) {
  const Data d = MakeData(7, 0.1, kSeed);
  const SeArdHyperParams hp = Hyper();
  const Eigen::MatrixXd K = SeArdKernelMatrix(hp, d.X, d.X.topRows(4));
  for (int i = 0; i < 7; ++i) {
    for (int j = 0; j < 4; ++j) {
      const Eigen::VectorXd a = d.X.row(i).transpose(), b = d.X.row(j).transpose();
      const double r2 = ((a - b).array() / hp.length_scales.array()).square().sum();
      EXPECT_NEAR(K(i, j), hp.signal_sd * hp.signal_sd * std::exp(-0.5 * r2), kExactTol);
      EXPECT_NEAR(K(i, j), SeArdKernel(hp, a, b), kExactTol);
    }
  }
}

TEST(GaussianProcess, MarginalLikelihoodGradientMatchesFiniteDifferences) {
  const Data d = MakeData(40, 0.1, kSeed);
  ExpectGradientMatchesFiniteDifferences(d, Eigen::VectorXd(), Eigen::MatrixXd());
}

TEST(GaussianProcess, SemiparametricLikelihoodGradientMatchesFiniteDifferences) {
  const Data d = MakeData(30, 0.1, kSeed + 1);
  Eigen::MatrixXd Phi(30, 2);
  Phi.col(0).setOnes();
  Phi.col(1) = d.X.col(2);
  const Eigen::Vector2d b(0.5, -0.3);
  const Eigen::Matrix2d B = Eigen::Vector2d(0.04, 0.01).asDiagonal();
  ExpectGradientMatchesFiniteDifferences(d, Phi * b, Phi * B * Phi.transpose());
}

TEST(GaussianProcess, LikelihoodValueMatchesDirectFormula) {
  const Data d = MakeData(12, 0.1, kSeed + 2);
  const SeArdHyperParams hp = Hyper();
  Eigen::MatrixXd Ky = SeArdKernelMatrix(hp, d.X, d.X);
  Ky.diagonal().array() += hp.noise_sd * hp.noise_sd;
  const double direct = -0.5 * d.y.dot(Ky.inverse() * d.y) - 0.5 * std::log(Ky.determinant()) -
                        0.5 * 12 * std::log(2.0 * M_PI);
  EXPECT_NEAR(GpLogMarginalLikelihood(hp, d.X, d.y).value, direct, 1e-9);
}

TEST(GaussianProcess, ClosedFormLooEqualsExplicitRefits) {
  const Data d = MakeData(25, 0.1, kSeed + 3);
  const SeArdHyperParams hp = Hyper();
  const GaussianProcess gp(hp, d.X, d.y);
  const Eigen::VectorXd res = gp.LooResiduals(), var = gp.LooVariances();
  for (int i = 0; i < 25; ++i) {
    Eigen::MatrixXd Xi(24, 3);
    Eigen::VectorXd yi(24);
    for (int r = 0, k = 0; r < 25; ++r) {
      if (r == i) continue;
      Xi.row(k) = d.X.row(r);
      yi(k++) = d.y(r);
    }
    const GaussianProcess refit(hp, Xi, yi);
    const auto p = refit.Predict(d.X.row(i).transpose());
    EXPECT_NEAR(res(i), d.y(i) - p.mean, kLooTol) << "i = " << i;
    EXPECT_NEAR(var(i), p.variance + hp.noise_sd * hp.noise_sd, kLooTol) << "i = " << i;
  }
}

TEST(GaussianProcess, HyperParameterFitReachesStationaryMaximum) {
  const Data d = MakeData(60, 0.1, kSeed + 4);
  SeArdHyperParams start = Hyper();
  start.noise_sd = 0.5;
  GpHyperFitOptions opt;
  opt.max_iterations = 200;
  int iterations = 0;
  const auto hp =
      FitHyperParameters(start, d.X, d.y, opt, Eigen::VectorXd(), Eigen::MatrixXd(), &iterations);
  const auto at_opt = GpLogMarginalLikelihood(hp, d.X, d.y);
  EXPECT_GT(at_opt.value, GpLogMarginalLikelihood(start, d.X, d.y).value);
  EXPECT_LT(at_opt.gradient.lpNorm<Eigen::Infinity>(), 1e-3);
  EXPECT_GT(iterations, 0);
  // The noise level planted (0.1) is found within a factor of two.
  EXPECT_GT(hp.noise_sd, 0.05);
  EXPECT_LT(hp.noise_sd, 0.2);
}

TEST(GaussianProcess, PredictionEqualsEquationSix) {
  const Data d = MakeData(15, 0.1, kSeed + 5);
  const SeArdHyperParams hp = Hyper();
  const GaussianProcess gp(hp, d.X, d.y);
  Eigen::MatrixXd Ky = SeArdKernelMatrix(hp, d.X, d.X);
  Ky.diagonal().array() += hp.noise_sd * hp.noise_sd;
  const Eigen::Vector3d x(0.3, -0.7, 1.1);
  const Eigen::VectorXd ks = SeArdKernelMatrix(hp, d.X, x.transpose());
  const auto p = gp.Predict(x);
  EXPECT_NEAR(p.mean, ks.dot(Ky.inverse() * d.y), 1e-9);
  EXPECT_NEAR(p.variance, hp.signal_sd * hp.signal_sd - ks.dot(Ky.inverse() * ks), 1e-9);
  // Batched means equal the pointwise ones.
  const Data probe = MakeData(9, 0.0, kSeed + 9);
  const Eigen::VectorXd batch = gp.PredictMean(probe.X);
  for (int i = 0; i < 9; ++i) {
    EXPECT_NEAR(batch(i), gp.Predict(probe.X.row(i).transpose()).mean, kExactTol);
  }
}

class Semiparametric : public ::testing::Test {
 protected:
  void SetUp() override {
    // y = 2 + 1.5 x0 (parametric part) + sin(3 x1) (local structure), 1-D basis h = [1, x0].
    d_ = MakeData(80, 0.01, kSeed + 6);
    for (int i = 0; i < 80; ++i) d_.y(i) = 2.0 + 1.5 * d_.X(i, 0) + std::sin(3.0 * d_.X(i, 1));
    phi_.resize(80, 2);
    phi_.col(0).setOnes();
    phi_.col(1) = d_.X.col(0);
    b_ = Eigen::Vector2d(2.0, 1.5);
    B_ = Eigen::Vector2d(0.01, 0.01).asDiagonal();
    hp_.length_scales = Eigen::Vector3d(0.5, 0.5, 0.5);
    hp_.signal_sd = 1.0;
    hp_.noise_sd = 0.01;
  }
  Data d_;
  Eigen::MatrixXd phi_;
  Eigen::Vector2d b_;
  Eigen::Matrix2d B_;
  SeArdHyperParams hp_;
};

TEST_F(Semiparametric, FarFromDataFallsBackToParametricModel) {
  const SemiparametricGp sp(hp_, d_.X, d_.y, phi_, b_, B_);
  const Eigen::Vector3d far(40.0, -35.0, 50.0);  // ≫ length scales away from all data
  const Eigen::Vector2d h(1.0, far(0));
  const auto p = sp.Predict(far, h);
  EXPECT_NEAR(p.mean, h.dot(sp.beta_bar()), kExactTol);        // k* = 0: eq. 8 first term only
  EXPECT_NEAR(p.mean, h.dot(b_), 0.05 * std::abs(h.dot(b_)));  // ≈ the prior parametric model
  // Variance: σ_f² + hᵀ (B⁻¹ + Φᵀ K_y⁻¹ Φ)⁻¹ h.
  Eigen::MatrixXd Ky = SeArdKernelMatrix(hp_, d_.X, d_.X);
  Ky.diagonal().array() += hp_.noise_sd * hp_.noise_sd;
  const Eigen::Matrix2d A = B_.inverse() + phi_.transpose() * Ky.inverse() * phi_;
  EXPECT_NEAR(p.variance, hp_.signal_sd * hp_.signal_sd + h.dot(A.inverse() * h), 1e-9);
}

TEST_F(Semiparametric, NearDataMatchesNonparametricGp) {
  const SemiparametricGp sp(hp_, d_.X, d_.y, phi_, b_, B_);
  SeArdHyperParams hp_gp = hp_;
  hp_gp.signal_sd = 5.0;  // zero-mean GP needs the offset in its prior variance
  const GaussianProcess gp(hp_gp, d_.X, d_.y);
  constexpr double kNearTol = 0.02;  // output unit; y spans about ±5
  for (int i = 0; i < 80; i += 7) {
    const Eigen::VectorXd x = d_.X.row(i).transpose() + Eigen::Vector3d(1e-3, -1e-3, 1e-3);
    const auto ps = sp.Predict(x, Eigen::Vector2d(1.0, x(0)));
    EXPECT_NEAR(ps.mean, gp.Predict(x).mean, kNearTol) << "i = " << i;
    EXPECT_NEAR(ps.mean, d_.y(i), kNearTol) << "i = " << i;
  }
}

TEST_F(Semiparametric, PosteriorBetaEqualsFormula) {
  const SemiparametricGp sp(hp_, d_.X, d_.y, phi_, b_, B_);
  Eigen::MatrixXd Ky = SeArdKernelMatrix(hp_, d_.X, d_.X);
  Ky.diagonal().array() += hp_.noise_sd * hp_.noise_sd;
  const Eigen::MatrixXd Kinv = Ky.inverse();
  const Eigen::Vector2d beta = (B_.inverse() + phi_.transpose() * Kinv * phi_).inverse() *
                               (phi_.transpose() * Kinv * d_.y + B_.inverse() * b_);
  EXPECT_LT((sp.beta_bar() - beta).norm(), 1e-7);
  const Data probe = MakeData(9, 0.0, kSeed + 9);
  Eigen::MatrixXd H(9, 2);
  H.col(0).setOnes();
  H.col(1) = probe.X.col(0);
  const Eigen::VectorXd batch = sp.PredictMean(probe.X, H);
  for (int i = 0; i < 9; ++i) {
    EXPECT_NEAR(batch(i), sp.Predict(probe.X.row(i).transpose(), H.row(i).transpose()).mean,
                kExactTol);
  }
}

}  // namespace
}  // namespace fesim::identification
