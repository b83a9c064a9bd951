// The residual noise model of the diagnosis (diagnosis/noise_model.h): AR fits recover planted
// coefficients, the covariance form equals its definition, and the robust tests keep their false-
// alarm rate on coloured noise while still finding a spectral line.
#include "diagnosis/noise_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "diagnosis/signatures.h"

namespace fesim::diagnosis {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// One output, one run of n rows.
RowLayout OneRun(long n) {
  RowLayout l;
  l.outputs = 1;
  l.output.assign(n, 0);
  l.run.assign(n, 0);
  return l;
}

/// r_i = φ1 r_{i−1} + φ2 r_{i−2} + e_i, e ~ N(0, σ²).
Eigen::VectorXd Ar2(long n, double phi1, double phi2, double sigma, std::mt19937_64* rng) {
  std::normal_distribution<double> e(0.0, sigma);
  Eigen::VectorXd r(n);
  double a = 0.0, b = 0.0;
  for (long i = -200; i < n; ++i) {  // burn-in
    const double x = phi1 * a + phi2 * b + e(*rng);
    b = a;
    a = x;
    if (i >= 0) r(i) = x;
  }
  return r;
}

TEST(NoiseModel, YuleWalkerRecoversAPlantedAr2AndItsInnovationVariance) {
  std::mt19937_64 rng(3);
  const Eigen::VectorXd r = Ar2(40000, 1.5, -0.7, 0.2, &rng);
  const NoiseModel m = FitNoiseModel(OneRun(r.size()), r);
  ASSERT_GE(m.outputs[0].a.size(), 2);
  EXPECT_NEAR(m.outputs[0].a(0), 1.5, 0.03);
  EXPECT_NEAR(m.outputs[0].a(1), -0.7, 0.03);
  EXPECT_NEAR(m.outputs[0].innovation_var, 0.04, 0.04 * 0.03);
  // White noise: BIC keeps order 0 (or a negligible coefficient).
  std::normal_distribution<double> w(0.0, 1.0);
  Eigen::VectorXd white(20000);
  for (auto& v : white) v = w(rng);
  const NoiseModel mw = FitNoiseModel(OneRun(white.size()), white);
  for (Eigen::Index k = 0; k < mw.outputs[0].a.size(); ++k)
    EXPECT_LT(std::abs(mw.outputs[0].a(k)), 0.03);
}

TEST(NoiseModel, CovarianceFormIsDTransposeSigmaDOfTheArCovariance) {
  // Two runs of one output and one run of another: Σ is block diagonal, each block
  // σ² A⁻¹A⁻ᵀ with A the run's lower-triangular AR matrix.
  RowLayout l;
  l.outputs = 2;
  const std::vector<std::pair<int, long>> runs = {{0, 30}, {0, 20}, {1, 25}};
  int id = 0;
  for (const auto& [o, n] : runs) {
    for (long i = 0; i < n; ++i) {
      l.output.push_back(o);
      l.run.push_back(id);
    }
    ++id;
  }
  NoiseModel m;
  m.outputs.resize(2);
  m.outputs[0].a = Eigen::Vector2d(0.9, -0.2);
  m.outputs[0].innovation_var = 0.5;
  m.outputs[1].a = Eigen::VectorXd::Constant(1, 0.6);
  m.outputs[1].innovation_var = 2.0;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::MatrixXd d(l.rows(), 3);
  for (Eigen::Index i = 0; i < d.size(); ++i) d.data()[i] = g(rng);
  Eigen::MatrixXd sigma = Eigen::MatrixXd::Zero(l.rows(), l.rows());
  long begin = 0;
  for (const auto& [o, n] : runs) {
    Eigen::MatrixXd a = Eigen::MatrixXd::Identity(n, n);
    for (long i = 0; i < n; ++i) {
      for (Eigen::Index k = 1; k <= m.outputs[o].a.size() && i - k >= 0; ++k) {
        a(i, i - k) = -m.outputs[o].a(k - 1);
      }
    }
    const Eigen::MatrixXd ainv = a.inverse();
    sigma.block(begin, begin, n, n) = m.outputs[o].innovation_var * ainv * ainv.transpose();
    begin += n;
  }
  const Eigen::MatrixXd expected = d.transpose() * sigma * d;
  EXPECT_LT((CovarianceForm(m, l, d) - expected).norm(), 1e-10 * expected.norm());
}

/// A smooth "misfit" direction: the response of a first-order lag (τ = 0.5 s at 60 Hz) to random
/// steps held 1–3 s.
Eigen::VectorXd SlowDirection(long n, std::mt19937_64* rng) {
  std::uniform_real_distribution<double> level(-1.0, 1.0), hold(60.0, 180.0);
  Eigen::VectorXd d(n);
  double u = level(*rng), y = 0.0, next = hold(*rng);
  const double a = std::exp(-1.0 / 30.0);
  for (long i = 0; i < n; ++i) {
    if (i >= next) {
      u = level(*rng);
      next += hold(*rng);
    }
    y = a * y + (1.0 - a) * u;
    d(i) = y;
  }
  return d;
}

TEST(NoiseModel, RobustScoreTestKeepsItsFalseAlarmRateOnColouredNoiseWhereTheWhiteOneDoesNot) {
  // Residual = slow AR(2) misfit (correlation time ≈ 1 s at 60 Hz) + white noise, no effect. A
  // slow test direction: the white-noise score test rejects at 1 % far more often than 1 %; the
  // robust one keeps the mean of S near its dof (1).
  std::mt19937_64 rng(11);
  std::normal_distribution<double> w(0.0, 0.01);
  const long n = 3600;
  const RowLayout l = OneRun(n);
  double mean_robust = 0.0;
  int white_rejects = 0, robust_rejects = 0;
  constexpr int kReps = 60;
  for (int rep = 0; rep < kReps; ++rep) {
    Eigen::VectorXd r = Ar2(n, 1.95, -0.952, 0.0005, &rng);
    for (auto& v : r) v += w(rng);
    const Eigen::MatrixXd d = SlowDirection(n, &rng);
    const ScoreTest t = RobustScoreTest(l, r, d, Eigen::MatrixXd(n, 0), {false});
    mean_robust += t.statistic / kReps;
    const double g = d.col(0).dot(r), s2 = r.squaredNorm() / n;
    const double white = g * g / (d.col(0).squaredNorm() * s2);
    white_rejects += ChiSquareSurvival(white, 1) < 0.01 ? 1 : 0;
    robust_rejects += ChiSquareSurvival(t.statistic, 1) < 0.01 ? 1 : 0;
    EXPECT_GT(t.variance_inflation, 3.0);
  }
  EXPECT_GT(white_rejects, kReps / 2);
  EXPECT_LE(robust_rejects, 4);
  EXPECT_GT(mean_robust, 0.4);
  EXPECT_LT(mean_robust, 2.0);
}

TEST(NoiseModel, ASpectralLineIsFoundOnTheSameColouredResidual) {
  // A 5.3 Hz line of amplitude equal to the white noise's σ on top of the slow misfit: the robust
  // test of the two quadrature directions finds it (the misfit has no power there).
  std::mt19937_64 rng(13);
  std::normal_distribution<double> w(0.0, 0.01);
  const long n = 3600;
  const RowLayout l = OneRun(n);
  Eigen::VectorXd r = Ar2(n, 1.95, -0.952, 0.0005, &rng);
  Eigen::MatrixXd d(n, 2);
  for (long i = 0; i < n; ++i) {
    const double t = i / 60.0;
    d(i, 0) = std::sin(2 * kPi * 5.3 * t);
    d(i, 1) = std::cos(2 * kPi * 5.3 * t);
    r(i) += w(rng) + 0.01 * std::sin(2 * kPi * 5.3 * t + 0.4);
  }
  const ScoreTest t = RobustScoreTest(l, r, d, Eigen::MatrixXd(n, 0), {false, false});
  EXPECT_EQ(t.dof, 2);
  EXPECT_GT(t.statistic, 500.0);
  EXPECT_LT(t.variance_inflation, 2.0);
}

TEST(NoiseModel, ALineWhosePhaseChangesBetweenTrialsNeedsDirectionsPerTrial) {
  // Two 60 s runs with a 5.3 Hz line at opposite phases (a tremor restarts at a random phase in
  // every trial): one (sin, cos) pair for both runs cancels and the AR model takes the line for
  // colour; a pair per run (screening.h PerTrialDirections) finds it.
  std::mt19937_64 rng(17);
  std::normal_distribution<double> w(0.0, 0.01);
  const long n = 3600;
  RowLayout l;
  l.outputs = 1;
  l.output.assign(2 * n, 0);
  for (long i = 0; i < 2 * n; ++i) l.run.push_back(i < n ? 0 : 1);
  Eigen::VectorXd r(2 * n);
  Eigen::MatrixXd common(2 * n, 2), split = Eigen::MatrixXd::Zero(2 * n, 4);
  for (long i = 0; i < 2 * n; ++i) {
    const long run = i < n ? 0 : 1;
    const double t = static_cast<double>(i - run * n) / 60.0;
    common(i, 0) = split(i, 2 * run) = std::sin(2 * kPi * 5.3 * t);
    common(i, 1) = split(i, 2 * run + 1) = std::cos(2 * kPi * 5.3 * t);
    r(i) = w(rng) + 0.01 * std::sin(2 * kPi * 5.3 * t + 0.4 + kPi * static_cast<double>(run));
  }
  const Eigen::MatrixXd none(2 * n, 0);
  const ScoreTest one = RobustScoreTest(l, r, common, none, {false, false});
  const ScoreTest per_run = RobustScoreTest(l, r, split, none, {false, false, false, false});
  EXPECT_LT(one.statistic, 20.0);  // χ²₂ at p = 0.01 is 9.2
  EXPECT_GT(per_run.statistic, 1000.0);
  EXPECT_EQ(per_run.dof, 4);
}

TEST(NoiseModel, OneSidedDirectionsWithANegativeCoefficientAreDropped) {
  std::mt19937_64 rng(17);
  std::normal_distribution<double> w(0.0, 0.01);
  const long n = 2000;
  Eigen::MatrixXd d(n, 1);
  Eigen::VectorXd r(n);
  for (long i = 0; i < n; ++i) {
    d(i, 0) = std::sin(0.3 * i);
    r(i) = w(rng) + 0.02 * d(i, 0);  // r = +0.02 d: θ = −(dᵀd)⁻¹dᵀr < 0
  }
  const ScoreTest t = RobustScoreTest(OneRun(n), r, d, Eigen::MatrixXd(n, 0), {true});
  EXPECT_EQ(t.dof, 0);
  EXPECT_EQ(t.statistic, 0.0);
  const ScoreTest both = RobustScoreTest(OneRun(n), r, d, Eigen::MatrixXd(n, 0), {false});
  EXPECT_EQ(both.dof, 1);
  EXPECT_LT(both.theta(0), 0.0);
}

TEST(NoiseModel, RobustLikelihoodRatioIsTheClassicalOneOnWhiteNoise) {
  std::mt19937_64 rng(19);
  std::normal_distribution<double> w(0.0, 0.01);
  const long n = 5000;
  Eigen::VectorXd r1(n), d(n);
  for (long i = 0; i < n; ++i) {
    r1(i) = w(rng);
    d(i) = 0.003 * std::sin(0.05 * i);
  }
  const Eigen::VectorXd r0 = r1 + d;
  const double lr = RobustLikelihoodRatio(OneRun(n), r0, r1);
  const double classical = (r0.squaredNorm() - r1.squaredNorm()) / (r1.squaredNorm() / n);
  EXPECT_NEAR(lr, classical, 0.1 * classical);
  EXPECT_EQ(RobustLikelihoodRatio(OneRun(n), r1, r0), 0.0);  // worse: no evidence
}

TEST(NoiseModel, DieboldMarianoIsNearZeroForEqualForecastsAndLargeForABetterOne) {
  std::mt19937_64 rng(23);
  std::normal_distribution<double> w(0.0, 0.01);
  const long n = 3600;
  double mean_abs = 0.0;
  for (int rep = 0; rep < 20; ++rep) {
    Eigen::VectorXd a(n), b(n);
    for (long i = 0; i < n; ++i) {
      a(i) = w(rng);
      b(i) = w(rng);
    }
    mean_abs += std::abs(DieboldMariano(OneRun(n), a, b)) / 20.0;
  }
  EXPECT_LT(mean_abs, 1.5);
  Eigen::VectorXd r0(n), r1(n);
  for (long i = 0; i < n; ++i) {
    r1(i) = w(rng);
    r0(i) = r1(i) + 0.01 * std::sin(0.02 * i);  // a slow effect of the noise's size, removed
  }
  EXPECT_GT(DieboldMariano(OneRun(n), r0, r1), 5.0);
  EXPECT_NEAR(NormalSurvival(1.6448536), 0.05, 1e-6);
}

}  // namespace
}  // namespace fesim::diagnosis
