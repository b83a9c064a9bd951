#include "diagnosis/signatures.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "diagnosis/extended_model.h"

namespace fesim::diagnosis {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDt = 0.01;  // 100 Hz
constexpr int kN = 6000;      // 60 s

std::vector<double> WhiteNoise(double sd, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n(0.0, sd);
  std::vector<double> v(kN);
  for (double& x : v) x = n(rng);
  return v;
}

std::vector<double> Times() {
  std::vector<double> t(kN);
  for (int i = 0; i < kN; ++i) t[i] = i * kDt;
  return t;
}

// A line over [0, T] has variance b²T²/12; a step at mid-recording removes 3/4 of it, so a trend
// adds N·b²T²/48 to the best step, and a step adds nothing beyond the noise to the trend.
TEST(Signatures, TrendOrStepCreditsALineToTheTrendByAQuarterOfItsVariance) {
  const std::vector<double> t = Times();
  std::vector<double> r = WhiteNoise(0.01, 7);
  const double b = 0.0005;  // rad/s
  for (int i = 0; i < kN; ++i) r[i] += b * t[i];
  r[200] = NAN;
  const TrendShape s = TrendOrStep(t, r);
  const double span = t.back();
  EXPECT_NEAR(s.trend_beyond_step, kN * b * b * span * span / 48.0,
              0.1 * kN * b * b * span * span / 48.0);
  // A step search over white noise removes a few σ² (≈ 2 ln ln N of a max over ~N tests).
  EXPECT_LT(s.step_beyond_trend, 20 * 0.01 * 0.01);
}

// A step of height h at fraction q of the samples: a line explains ρ² = 3p(1−p) of its variance
// p(1−p)·h² (p = 1 − q the share after the step), so a step adds N·h²·p(1−p)·(1 − 3p(1−p)).
TEST(Signatures, TrendOrStepFindsAStepItsTimeAndHeight) {
  const std::vector<double> t = Times();
  std::vector<double> r = WhiteNoise(0.01, 8);
  const double h = -0.03, tau = 18.0;
  for (int i = 0; i < kN; ++i) r[i] += t[i] >= tau ? h : 0.0;
  const TrendShape s = TrendOrStep(t, r);
  EXPECT_NEAR(s.step_time_s, tau, 0.05);
  EXPECT_NEAR(s.step_rad, h, 0.002);
  const double p = 0.7;
  const double expected = kN * h * h * p * (1 - p) * (1 - 3 * p * (1 - p));
  EXPECT_NEAR(s.step_beyond_trend, expected, 0.1 * expected);
  EXPECT_LT(s.trend_beyond_step, 20 * 0.01 * 0.01);
}

// Several outputs of one recording share one step time: a slip of every reading at 25 s is found
// there, its largest height named, and what the step adds is the sum of the outputs' — while
// steps of each output at its own time (a model's misfit) add less with one time than searched
// per output (a constrained minimum: never more; here 0.89 against 1.38 rad²).
TEST(Signatures, TrendOrStepOfSeveralOutputsSearchesOneStepTimeForAll) {
  const std::vector<double> t = Times();
  const std::vector<double> heights = {0.03, -0.02, 0.04}, own_times = {14.0, 29.0, 44.0};
  std::vector<std::vector<double>> slip, misfit, times(3, t);
  double alone = 0.0;
  for (int o = 0; o < 3; ++o) {
    slip.push_back(WhiteNoise(0.01, 20 + o));
    misfit.push_back(WhiteNoise(0.01, 30 + o));
    for (int i = 0; i < kN; ++i) {
      slip[o][i] += t[i] >= 25.0 ? heights[o] : 0.0;
      misfit[o][i] += t[i] >= own_times[o] ? heights[o] : 0.0;
    }
    alone += TrendOrStep(t, misfit[o]).step_beyond_trend;
  }
  const TrendShape s = TrendOrStep(times, slip);
  EXPECT_NEAR(s.step_time_s, 25.0, 0.05);
  EXPECT_EQ(s.step_series, 2);
  EXPECT_NEAR(s.step_rad, 0.04, 0.002);
  const double share = 25.0 / 60.0, p = 1.0 - share, ssq = 0.03 * 0.03 + 0.02 * 0.02 + 0.04 * 0.04;
  const double expected = kN * ssq * p * (1 - p) * (1 - 3 * p * (1 - p));
  EXPECT_NEAR(s.step_beyond_trend, expected, 0.1 * expected);
  const TrendShape m = TrendOrStep(times, misfit);
  EXPECT_LT(m.step_beyond_trend, 0.75 * alone) << alone;
  // One series: the single-series search.
  const TrendShape one = TrendOrStep({t}, {slip[0]});
  const TrendShape single = TrendOrStep(t, slip[0]);
  EXPECT_EQ(one.step_beyond_trend, single.step_beyond_trend);
  EXPECT_EQ(one.step_time_s, single.step_time_s);
  EXPECT_THROW(TrendOrStep(times, {slip[0]}), std::invalid_argument);
}

TEST(Signatures, TrendOrStepNeedsSamplesOnBothSidesAndMatchingSizes) {
  EXPECT_TRUE(std::isnan(TrendOrStep({0, 1, 2}, {0, 1, 0}).step_time_s));
  EXPECT_THROW(TrendOrStep({0, 1}, {0}), std::invalid_argument);
  EXPECT_THROW(TrendOrStep(Times(), WhiteNoise(1, 1), 0.5), std::invalid_argument);
}

TEST(Signatures, SpectrumPeakFindsAPlantedTremorFrequencyBelowTheNoise) {
  std::vector<double> r = WhiteNoise(1.0, 1);
  for (int i = 0; i < kN; ++i) r[i] += 0.3 * std::sin(2 * kPi * 6.37 * i * kDt + 0.4);
  r[100] = NAN;  // dropouts are skipped
  const SpectrumPeak p = ResidualSpectrumPeak(r, kDt, 3.0, 12.0, 0.01);
  EXPECT_NEAR(p.frequency_hz, 6.37, 0.011);
  EXPECT_GT(p.power_ratio, 20.0);
  const SpectrumPeak white = ResidualSpectrumPeak(WhiteNoise(1.0, 2), kDt, 3.0, 12.0, 0.01);
  EXPECT_LT(white.power_ratio, 15.0);  // max of ~900 exponential(1) draws / median ≈ ln 900/ln 2
  EXPECT_THROW(ResidualSpectrumPeak(r, kDt, 3.0, 60.0, 0.01), std::invalid_argument);
}

TEST(Signatures, SpectrumPeakUsesTheMeanStepOfARoundedClock) {
  // A 60 Hz record with time stamps rounded to 4 decimals (steps 0.0166 / 0.0167 s) and an
  // 8.5163 Hz line in its residual: the peak is found within 2 mHz, not 0.2 % low (8.4993 Hz,
  // what the first step 0.0167 s alone gives).
  constexpr int kSamples = 3601;  // 60 s
  constexpr double kF = 8.5163;
  Trial t;
  std::vector<double> y(kSamples), zero(kSamples, 0.0);
  for (int i = 0; i < kSamples; ++i) {
    t.time.push_back(std::round(i / 60.0 * 1e4) / 1e4);
    y[static_cast<std::size_t>(i)] = 0.01 * std::sin(2 * kPi * kF * i / 60.0);
  }
  t.AddColumn("u.ext", zero);
  t.AddColumn("q.wrist_flexion", y);
  Trial prediction = t;
  prediction.MutableColumn("q.wrist_flexion") = zero;
  DataView v;
  v.trials = {t};
  v.use = {std::vector<char>(kSamples, 1)};
  v.outputs = {"q.wrist_flexion"};
  const std::vector<OutputSignature> s = ResidualSignatures(v, {prediction});
  ASSERT_EQ(s.size(), 1u);
  EXPECT_NEAR(s[0].spectrum_peak_hz, kF, 0.002);
}

TEST(Signatures, StructuredShareIsZeroForWhiteNoiseAndNearOneForASlowResidual) {
  EXPECT_LT(StructuredVarianceFraction(WhiteNoise(1.0, 3)), 0.05);
  std::vector<double> slow(kN);
  for (int i = 0; i < kN; ++i) slow[i] = std::sin(2 * kPi * 0.2 * i * kDt);
  EXPECT_GT(StructuredVarianceFraction(slow), 0.99);
  // Equal variance of noise and slow structure: about one half.
  std::vector<double> mix = WhiteNoise(1.0 / std::sqrt(2.0), 4);
  for (int i = 0; i < kN; ++i) mix[i] += slow[i];
  EXPECT_NEAR(StructuredVarianceFraction(mix), 0.5, 0.05);
}

TEST(Signatures, CrossCorrelationPeakFindsThePositiveLagOfADelayedResponse) {
  const std::vector<double> x = WhiteNoise(1.0, 5);
  std::vector<double> r(kN, 0.0);
  for (int i = 7; i < kN; ++i) r[i] = x[i - 7];  // r follows x by 70 ms
  const LagPeak p = CrossCorrelationPeak(x, r, kDt, 0.2);
  EXPECT_NEAR(p.lag_s, 0.07, 1e-9);
  EXPECT_GT(p.correlation, 0.99);
}

TEST(Signatures, CorrelationCumulativeStimulationAndDerivative) {
  const std::vector<double> t = {0, 1, 2, 3, 4};
  EXPECT_NEAR(Correlation(t, {1, 3, 5, 7, 9}), 1.0, 1e-12);
  EXPECT_NEAR(Correlation(t, {9, 7, NAN, 3, 1}), -1.0, 1e-12);
  EXPECT_EQ(Correlation(t, {2, 2, 2, 2, 2}), 0.0);
  EXPECT_THROW(Correlation(t, {1, 2}), std::invalid_argument);
  const std::vector<double> c =
      CumulativeStimulation(t, {{100, 100, 100, 100, 100}, {0, 0, 50, 50, 50}});
  EXPECT_NEAR(c[4], 400.0 + 125.0, 1e-9);  // µs·s: 100·4 + trapezoid of the second
  const std::vector<double> d = Derivative(t, {0, 2, 4, 6, 8});
  for (double v : d) EXPECT_NEAR(v, 2.0, 1e-12);
}

TEST(Signatures, ChiSquareSurvivalMatchesTables) {
  EXPECT_NEAR(ChiSquareSurvival(3.841458820694124, 1), 0.05, 1e-9);
  EXPECT_NEAR(ChiSquareSurvival(5.991464547107979, 2), 0.05, 1e-9);
  EXPECT_NEAR(ChiSquareSurvival(7.814727903251178, 3), 0.05, 1e-9);
  EXPECT_NEAR(ChiSquareSurvival(2.0, 2), std::exp(-1.0), 1e-12);  // χ²₂ is exponential
  EXPECT_NEAR(ChiSquareSurvival(100.0, 10), 5.4497019829205295e-17, 1e-25);
  EXPECT_EQ(ChiSquareSurvival(-1.0, 3), 1.0);
}

}  // namespace
}  // namespace fesim::diagnosis
