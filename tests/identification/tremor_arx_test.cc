#include "identification/tremor_arx.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "identification/metrics.h"

namespace fesim::identification {
namespace {

constexpr double kRecoveryTol = 1e-3;    // relative, noiseless
constexpr double kFrequencyTol = 1e-6;   // relative, estimated tremor frequency, noiseless
constexpr double kNoiseStd_rad = 0.002;  // ARX equation noise e(k) (output range ≈ ±0.5 rad)
constexpr double kNoisyTol = 0.05;       // relative error of h on its range and of a, b
constexpr double kSlopeRelTol = 1e-9;    // h' ≥ −tol·max|h'| on the whole range (rounding)
constexpr double kNormalEqTol = 1e-10;   // |φᵀe|/(‖φ‖‖e‖), φ a column of eq. (21)
constexpr double kSamplePeriod = 0.01;   // s (100 Hz)
constexpr double kTwoPi = 6.283185307179586;
constexpr unsigned kSeed = 99;

TremorModel Planted() {
  TremorModel m;
  m.orders = {2, 1, 1, 3};
  m.u_scale_us = 200.0;
  m.beta = Eigen::Vector4d(0.1, 0.5, 0.1, 0.3);  // h' = 0.5 + 0.2 s + 0.9 s² > 0
  m.a = Eigen::Vector2d(-1.6, 0.64);             // double pole at 0.8
  m.b = Eigen::Vector2d(0.6, 0.4) * 0.04;        // P(1) = 1
  m.lambda1 = 0.02;
  m.lambda2 = -0.01;
  m.tremor_hz = 5.0;
  m.sample_period_s = kSamplePeriod;
  return m;
}

// Multisine 0.2–4 Hz in combined µs ([Copur 2016] §4.1), random phases.
Eigen::VectorXd Multisine(int n, std::mt19937* rng) {
  std::uniform_real_distribution<double> ph(0.0, kTwoPi);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(n);
  const double freqs[] = {0.2, 0.5, 0.9, 1.4, 2.1, 3.0, 4.0};
  for (double f : freqs) {
    const double p = ph(*rng);
    for (int k = 0; k < n; ++k) u(k) += 200.0 / 7.0 * std::sin(kTwoPi * f * k * kSamplePeriod + p);
  }
  return u;
}

// ARX form of eq. (11)–(12): A y = B h(u) + d + e, from rest.
Eigen::VectorXd Generate(const TremorModel& m, const Eigen::VectorXd& u, double noise,
                         std::mt19937* rng) {
  std::normal_distribution<double> e(0.0, 1.0);
  const int n = static_cast<int>(u.size());
  Eigen::VectorXd y = Eigen::VectorXd::Zero(n);
  const double w = kTwoPi * m.tremor_hz * kSamplePeriod;
  for (int k = 2; k < n; ++k) {
    double v = m.lambda1 * std::cos(w * k) + m.lambda2 * std::sin(w * k) + noise * e(*rng);
    v -= m.a(0) * y(k - 1) + m.a(1) * y(k - 2);
    v += m.b(0) * TremorRecruitment(m, u(k - 1)) + m.b(1) * TremorRecruitment(m, u(k - 2));
    y(k) = v;
  }
  return y;
}

TremorData Data(const TremorModel& m, int trials, double noise, unsigned seed) {
  std::mt19937 rng(seed);
  TremorData d;
  d.sample_period_s = kSamplePeriod;
  for (int t = 0; t < trials; ++t) {
    d.u_us.push_back(Multisine(3000, &rng));
    d.y.push_back(Generate(m, d.u_us.back(), noise, &rng));
  }
  return d;
}

TremorOptions Options(const TremorModel& m, double hz) {
  TremorOptions o;
  o.orders = m.orders;
  o.tremor_hz = hz;
  o.tolerance_eps = 1e-16;
  return o;
}

double Rel(const Eigen::VectorXd& a, const Eigen::VectorXd& b) { return (a - b).norm() / b.norm(); }

double Scale(const TremorData& d) {
  double s = 0;
  for (const auto& u : d.u_us) s = std::max(s, u.cwiseAbs().maxCoeff());
  return s;
}

void ExpectRecovered(const TremorModel& got, const TremorModel& want) {
  // β are per unit of s = u/u_scale: compare h itself on the range and the linear block.
  Eigen::VectorXd hg(41), hw(41);
  for (int k = 0; k <= 40; ++k) {
    hg(k) = TremorRecruitment(got, -200.0 + 10.0 * k);
    hw(k) = TremorRecruitment(want, -200.0 + 10.0 * k);
  }
  EXPECT_LT(Rel(hg, hw), kRecoveryTol);
  EXPECT_LT(Rel(got.a, want.a), kRecoveryTol);
  EXPECT_LT(Rel(got.b, want.b), kRecoveryTol);
  EXPECT_LT(
      Rel(Eigen::Vector2d(got.lambda1, got.lambda2), Eigen::Vector2d(want.lambda1, want.lambda2)),
      kRecoveryTol);
}

TEST(TremorArx, CoactivationMappingOfEq5) {
  const Coactivation c{40.0, 55.0};
  EXPECT_EQ(CoactivationSplit(c, 100.0), Eigen::Vector2d(140.0, 55.0));
  EXPECT_EQ(CoactivationSplit(c, -80.0), Eigen::Vector2d(40.0, 135.0));
  EXPECT_EQ(CoactivationSplit(c, 0.0), Eigen::Vector2d(40.0, 55.0));
  for (double u : {-150.0, -1.0, 0.0, 3.0, 200.0}) {
    const Eigen::Vector2d s = CoactivationSplit(c, u);
    EXPECT_DOUBLE_EQ(CoactivationCombine(c, s(0), s(1)), u);
  }
}

TEST(TremorArx, RecoversPlantedParametersNoiselessKnownFrequency) {
  const TremorModel truth = Planted();
  const TremorData d = Data(truth, 1, 0.0, kSeed);
  const TremorFit fit = FitTremorArx(d, Options(truth, truth.tremor_hz), Scale(d));
  ExpectRecovered(fit.model, truth);
}

TEST(TremorArx, EstimatesTremorFrequencyAndRecoversParametersNoiseless) {
  const TremorModel truth = Planted();
  const TremorData d = Data(truth, 1, 0.0, kSeed + 1);
  const TremorFit fit = FitTremorArx(d, Options(truth, 0.0), Scale(d));
  EXPECT_NEAR(fit.model.tremor_hz / truth.tremor_hz, 1.0, kFrequencyTol);
  ExpectRecovered(fit.model, truth);
}

TEST(TremorArx, StaysCloseUnderEquationNoise) {
  const TremorModel truth = Planted();
  const TremorData d = Data(truth, 1, kNoiseStd_rad, kSeed + 2);
  const TremorFit fit = FitTremorArx(d, Options(truth, 0.0), Scale(d));
  Eigen::VectorXd hg(41), hw(41);
  for (int k = 0; k <= 40; ++k) {
    hg(k) = TremorRecruitment(fit.model, -200.0 + 10.0 * k);
    hw(k) = TremorRecruitment(truth, -200.0 + 10.0 * k);
  }
  EXPECT_LT(Rel(hg, hw), kNoisyTol);
  EXPECT_LT(Rel(fit.model.a, truth.a), kNoisyTol);
  // With a 0.2–4 Hz input at 100 Hz, u(k−1) and u(k−2) are nearly collinear: b_0 and b_1 are
  // individually poorly determined under noise, their sum B(1) is not.
  EXPECT_LT(std::abs(fit.model.b.sum() / truth.b.sum() - 1.0), kNoisyTol);
  EXPECT_NEAR(fit.model.tremor_hz, truth.tremor_hz, 0.01);
  // The simulated (noise-free) response of the fitted model matches the true one.
  std::mt19937 rng(kSeed + 5);
  const Eigen::VectorXd u = Multisine(3000, &rng);
  const Eigen::VectorXd y0 = Generate(truth, u, 0.0, &rng);
  const Eigen::VectorXd yh = SimulateTremorArx(fit.model, u, y0);
  EXPECT_LT((yh - y0).norm() / (y0.array() - y0.mean()).matrix().norm(), kNoisyTol);
}

TEST(TremorArx, MonotonicityHoldsOnTheWholeInputRangeAfterFitting) {
  // A recruitment with a flat stretch (h' = 0 at s = 0) and noise tempts the unconstrained degree-5
  // fit into a negative slope; the constrained fit must keep h' ≥ 0 everywhere on the range.
  TremorModel truth = Planted();
  truth.orders.poly_degree = 5;
  truth.beta = Eigen::VectorXd::Zero(6);
  truth.beta(3) = 0.6;  // h = 0.6 s³
  const TremorData d = Data(truth, 1, 5 * kNoiseStd_rad, kSeed + 3);
  const TremorFit fit = FitTremorArx(d, Options(truth, truth.tremor_hz), Scale(d));
  const double umin = fit.model.s_min * fit.model.u_scale_us;
  const double umax = fit.model.s_max * fit.model.u_scale_us;
  double max_slope = 0.0;
  for (int k = 0; k <= 10000; ++k) {
    const double u = umin + (umax - umin) * k / 10000.0;
    max_slope = std::max(max_slope, std::abs(TremorRecruitmentSlope(fit.model, u)));
  }
  const double tol = kSlopeRelTol * max_slope;
  EXPECT_GE(MinimumRecruitmentSlope(fit.model.beta, fit.model.s_min, fit.model.s_max) /
                fit.model.u_scale_us,
            -tol);
  for (int k = 0; k <= 10000; ++k) {
    const double u = umin + (umax - umin) * k / 10000.0;
    ASSERT_GE(TremorRecruitmentSlope(fit.model, u), -tol) << "u = " << u;
  }
  // The constraint is active: the fit touches h' = 0 somewhere (the truth's flat point).
  EXPECT_LT(MinimumRecruitmentSlope(fit.model.beta, fit.model.s_min, fit.model.s_max) /
                fit.model.u_scale_us,
            1e-6 * max_slope);
}

TEST(TremorArx, OrderSweepPrefersTheTrueOrderInCrossValidation) {
  const TremorModel truth = Planted();
  const TremorData d = Data(truth, 2, 0.0, kSeed + 4);
  const auto sweep =
      SweepTremorOrders(d, Options(truth, truth.tremor_hz), {1, 2}, {1}, {1}, Scale(d));
  ASSERT_EQ(sweep.size(), 2u);
  EXPECT_EQ(sweep[1].orders.poles_l, 2);
  EXPECT_GT(sweep[1].validation_best_fit, 99.0);
  // The tremor phase differs between trials, so cross-validation keeps a residual tremor error.
  EXPECT_GT(sweep[1].cross_validation_best_fit, sweep[0].cross_validation_best_fit);
}

TEST(TremorArx, FrequencyResponseIsTheSteadySineGainOfTheRecursion) {
  // y(k) = 0.5 y(k−1) + 0.5 h(k−1) with h = u (β = [0, 1], u_scale 1): H(z) = 0.5 z⁻¹/(1 −
  // 0.5 z⁻¹), gain 1 at DC and 1/3 at Nyquist; a sine through SimulateTremorArx settles to
  // |H| times its amplitude with phase arg H.
  TremorModel m;
  m.orders = {1, 0, 1, 1};
  m.u_scale_us = 1.0;
  m.beta = Eigen::Vector2d(0.0, 1.0);
  m.a = Eigen::VectorXd::Constant(1, -0.5);
  m.b = Eigen::VectorXd::Constant(1, 0.5);
  m.sample_period_s = 0.01;
  EXPECT_NEAR(std::abs(TremorArxResponse(m.a, m.b, 1, 0.01, 0.0) - 1.0), 0.0, 1e-14);
  EXPECT_NEAR(std::abs(TremorArxResponse(m.a, m.b, 1, 0.01, 50.0) + 1.0 / 3.0), 0.0, 1e-14);
  const double f = 7.0, w = 2.0 * M_PI * f * m.sample_period_s;
  const Eigen::Index n = 4000;
  Eigen::VectorXd u(n);
  for (Eigen::Index k = 0; k < n; ++k) u(k) = std::sin(w * k);
  const Eigen::VectorXd y = SimulateTremorArx(m, u, Eigen::VectorXd::Zero(1));
  const std::complex<double> h = TremorArxResponse(m.a, m.b, 1, m.sample_period_s, f);
  for (Eigen::Index k = n - 50; k < n; ++k) {
    EXPECT_NEAR(y(k), std::abs(h) * std::sin(w * k + std::arg(h)), 1e-12) << k;
  }
  EXPECT_THROW(TremorArxResponse(m.a, Eigen::VectorXd(), 1, 0.01, 1.0), std::invalid_argument);
}

TEST(TremorArx, OrderSweepKeepsDataSetOnesPolynomials) {
  const TremorModel truth = Planted();
  const TremorData d = Data(truth, 2, 0.0, kSeed + 4);
  const auto sweep =
      SweepTremorOrders(d, Options(truth, truth.tremor_hz), {1, 2}, {1}, {1}, Scale(d));
  ASSERT_EQ(sweep.size(), 2u);
  for (const auto& e : sweep) {
    EXPECT_EQ(e.first_a.size(), e.orders.poles_l);
    EXPECT_EQ(e.first_b.size(), e.orders.zeros_n + 1);
  }
  // The true order's model of data set 1 (noiseless) has the planted response.
  for (double f : {0.5, 2.0, 5.0}) {
    const auto planted =
        TremorArxResponse(truth.a, truth.b, truth.orders.delay_m, truth.sample_period_s, f);
    const auto fitted =
        TremorArxResponse(sweep[1].first_a, sweep[1].first_b, 1, truth.sample_period_s, f);
    EXPECT_LT(std::abs(fitted - planted), 1e-3 * std::abs(planted)) << f;
  }
}

TEST(TremorArx, MethodEntryMapsCoactivationAndFitsTwoTrials) {
  const TremorModel truth = Planted();
  const TremorData d = Data(truth, 2, 0.0, kSeed + 6);
  const Coactivation c{30.0, 45.0};
  std::vector<Trial> trials;
  for (int t = 0; t < 2; ++t) {
    Trial tr;
    std::vector<double> fcr, ecr;
    for (Eigen::Index k = 0; k < d.u_us[t].size(); ++k) {
      tr.time.push_back(kSamplePeriod * k);
      const Eigen::Vector2d s = CoactivationSplit(c, d.u_us[t](k));
      fcr.push_back(s(0));
      ecr.push_back(s(1));
    }
    tr.AddColumn("u.fcr", fcr);
    tr.AddColumn("u.ecr", ecr);
    tr.AddColumn("q.wrist", std::vector<double>(d.y[t].data(), d.y[t].data() + d.y[t].size()));
    tr.metadata["tremor.poles_l"] = "2";
    tr.metadata["tremor.zeros_n"] = "1";
    tr.metadata["tremor.delay_m"] = "1";
    tr.metadata["tremor.hz"] = "5";
    trials.push_back(tr);
  }
  const MethodResult r = TremorArxMethod().run(trials, {}, nullptr);
  ASSERT_EQ(r.predictions.size(), 2u);
  EXPECT_GT(BestFitPercent(trials[0].Column("q.wrist"), r.predictions[0].Column("q.wrist")), 99.0);
  EXPECT_NE(r.model_yaml.find("c_agonist: {value: 30"), std::string::npos) << r.model_yaml;
  Trial one_input = trials[0];
  one_input.names.erase(one_input.names.begin() + 1);
  one_input.columns.erase(one_input.columns.begin() + 1);
  EXPECT_THROW(TremorArxMethod().run({one_input}, {}, nullptr), std::runtime_error);
}

// Issue 28: tracker dropouts (NaN bursts, 5 % of the output samples, one in the first samples)
// are accepted: the ARX rows touching them are dropped, the metrics count them, and the fit is
// as good as on the complete record.
TEST(TremorArx, MissingOutputSamplesAreLeftOutOfTheFit) {
  const TremorModel truth = Planted();
  const TremorData d = Data(truth, 1, kNoiseStd_rad, kSeed + 7);
  const Coactivation c{30.0, 45.0};
  Trial full;
  std::vector<double> fcr, ecr;
  for (Eigen::Index k = 0; k < d.u_us[0].size(); ++k) {
    full.time.push_back(kSamplePeriod * k);
    const Eigen::Vector2d s = CoactivationSplit(c, d.u_us[0](k));
    fcr.push_back(s(0));
    ecr.push_back(s(1));
  }
  full.AddColumn("u.fcr", fcr);
  full.AddColumn("u.ecr", ecr);
  full.AddColumn("q.wrist", std::vector<double>(d.y[0].data(), d.y[0].data() + d.y[0].size()));
  full.metadata["tremor.poles_l"] = "2";
  full.metadata["tremor.zeros_n"] = "1";
  full.metadata["tremor.delay_m"] = "1";
  Trial gaps = full;
  std::vector<double>& y = gaps.MutableColumn("q.wrist");
  std::size_t missing = 1;
  y[0] = NAN;  // an initial sample of the simulation
  std::mt19937 rng(kSeed + 8);
  std::uniform_int_distribution<int> start(10, 2980);
  while (missing < 150) {  // bursts of 6 samples
    const int k0 = start(rng);
    for (int k = k0; k < k0 + 6; ++k) {
      if (!std::isnan(y[k])) ++missing;
      y[k] = NAN;
    }
  }
  const MethodResult with_gaps = TremorArxMethod().run({gaps}, {}, nullptr);
  const MethodResult complete = TremorArxMethod().run({full}, {}, nullptr);
  const std::string metrics = with_gaps.metrics.Dump(0);
  EXPECT_NE(metrics.find("\"missing_samples\":" + std::to_string(missing)), std::string::npos)
      << metrics;
  EXPECT_NE(metrics.find("\"train_missing_samples\":" + std::to_string(missing)),
            std::string::npos);
  const auto& predicted = with_gaps.predictions[0].Column("q.wrist");
  ASSERT_EQ(predicted.size(), full.size());
  const double gaps_fit = BestFitPercent(full.Column("q.wrist"), predicted);
  const double complete_fit =
      BestFitPercent(full.Column("q.wrist"), complete.predictions[0].Column("q.wrist"));
  EXPECT_GT(gaps_fit, complete_fit - 1.0);
  EXPECT_GT(gaps_fit, 90.0);
  // The tremor frequency is found as on the complete record.
  const auto hz = [](const std::string& yaml) {
    const std::size_t at = yaml.find("tremor_frequency: {value: ");
    return std::stod(yaml.substr(at + 26));
  };
  EXPECT_NEAR(hz(with_gaps.model_yaml), hz(complete.model_yaml), 1e-3);
}

// The least squares of Algorithm 1 are solved on the R factor of the lifted regressor, not on
// the N rows: the fitted a, b, λ must still satisfy the normal equations of eq. (21) built
// directly on every complete row (orders with several lags of y and of h, missing samples).
TEST(TremorArx, LinearStepSatisfiesTheNormalEquationsOnTheFullRows) {
  TremorModel truth = Planted();
  const TremorData clean = Data(truth, 1, kNoiseStd_rad, kSeed + 9);
  TremorData d = clean;
  for (int k : {0, 500, 501, 1700, 2999}) d.y[0](k) = NAN;
  TremorOptions opt = Options(truth, truth.tremor_hz);
  opt.orders = {4, 3, 1, 3};
  const TremorModel m = FitTremorArx(d, opt, Scale(d)).model;
  const Eigen::VectorXd& y = d.y[0];
  const Eigen::VectorXd& u = d.u_us[0];
  const int l = m.orders.poles_l, n = m.orders.zeros_n, delay = m.orders.delay_m;
  const double w = kTwoPi * m.tremor_hz * kSamplePeriod;
  std::vector<Eigen::VectorXd> rows;  // [φ(k); e(k)] of every complete row
  for (int k = std::max(l, delay + n); k < y.size(); ++k) {
    Eigen::VectorXd r(l + n + 4);
    double e = y(k) - m.lambda1 * std::cos(w * k) - m.lambda2 * std::sin(w * k);
    for (int i = 1; i <= l; ++i) {
      r(i - 1) = -y(k - i);
      e += m.a(i - 1) * y(k - i);
    }
    for (int j = 0; j <= n; ++j) {
      r(l + j) = TremorRecruitment(m, u(k - delay - j));
      e -= m.b(j) * r(l + j);
    }
    r(l + n + 1) = std::cos(w * k);
    r(l + n + 2) = std::sin(w * k);
    r(l + n + 3) = e;
    if (r.allFinite()) rows.push_back(r);
  }
  // Rows k ≥ 4 without those touching a gap: 4 (y(0)), 500–505, 1700–1704, 2999.
  ASSERT_EQ(static_cast<Eigen::Index>(rows.size()), y.size() - 4 - 13);
  Eigen::MatrixXd Phi(static_cast<Eigen::Index>(rows.size()), l + n + 4);
  for (std::size_t i = 0; i < rows.size(); ++i) Phi.row(static_cast<Eigen::Index>(i)) = rows[i];
  const Eigen::VectorXd e = Phi.rightCols(1);
  for (Eigen::Index c = 0; c + 1 < Phi.cols(); ++c) {
    EXPECT_LT(std::abs(Phi.col(c).dot(e)), kNormalEqTol * Phi.col(c).norm() * e.norm())
        << "column " << c;
  }
}

}  // namespace
}  // namespace fesim::identification
