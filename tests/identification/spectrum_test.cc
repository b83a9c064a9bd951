// The transforms of identification/spectrum.h against the direct sums they replace (issue 28:
// the tremor frequency search was a direct DFT, quadratic in the trial length).
#include "identification/spectrum.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace fesim::identification {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Agreement with the direct sums, relative to the largest magnitude of the result.
constexpr double kRelativeTolerance = 1e-9;

Eigen::VectorXd RandomSignal(Eigen::Index n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::VectorXd x(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    x(k) = 0.3 * std::sin(0.37 * static_cast<double>(k)) + g(rng);
  }
  return x;
}

/// The periodogram as tremor_arx.cc computed it before: a direct DFT per grid frequency.
Periodogram DirectPeriodogram(const std::vector<Eigen::VectorXd>& res, double T, double f_lo,
                              double f_hi) {
  Eigen::Index n_max = 0;
  for (const auto& e : res) n_max = std::max(n_max, e.size());
  const double df = 1.0 / (4.0 * static_cast<double>(n_max) * T);
  Periodogram p;
  for (double f = f_lo; f <= f_hi; f += df) {
    const double w = 2.0 * kPi * f * T;
    double power = 0.0;
    for (const auto& e : res) {
      std::complex<double> acc = 0.0;
      for (Eigen::Index k = 0; k < e.size(); ++k) acc += e(k) * std::polar(1.0, -w * k);
      power += std::norm(acc);
    }
    p.f_hz.push_back(f);
    p.power.push_back(power);
  }
  return p;
}

TEST(Spectrum, FftMatchesTheDirectSumAndInverts) {
  const Eigen::VectorXd x = RandomSignal(64, 1);
  std::vector<std::complex<double>> a(64);
  for (int k = 0; k < 64; ++k) a[k] = {x(k), 0.5 * x(63 - k)};
  const auto original = a;
  Fft(&a, false);
  for (int i = 0; i < 64; ++i) {
    std::complex<double> direct = 0.0;
    for (int k = 0; k < 64; ++k) direct += original[k] * std::polar(1.0, -2.0 * kPi * i * k / 64);
    EXPECT_NEAR(std::abs(a[i] - direct), 0.0, 1e-12) << i;
  }
  Fft(&a, true);
  for (int k = 0; k < 64; ++k) EXPECT_NEAR(std::abs(a[k] / 64.0 - original[k]), 0.0, 1e-14);
  std::vector<std::complex<double>> odd(12);
  EXPECT_THROW(Fft(&odd, false), std::invalid_argument);
}

TEST(Spectrum, ZoomDftMatchesTheDirectSumOffGridAndForAnyLengths) {
  for (const auto& [n, k_count, M, f0] :
       std::vector<std::tuple<int, int, int, double>>{{1000, 300, 4000, 0.03},
                                                      {3001, 1, 12004, 0.1234567},
                                                      {7, 50, 28, 0.9},
                                                      {257, 1024, 9, 0}}) {
    const Eigen::VectorXd x = RandomSignal(n, static_cast<unsigned>(n));
    const auto X = ZoomDft(x, f0, static_cast<std::uint64_t>(M), static_cast<std::size_t>(k_count));
    ASSERT_EQ(X.size(), static_cast<std::size_t>(k_count));
    double largest = 0.0, worst = 0.0;
    for (int i = 0; i < k_count; ++i) {
      std::complex<double> direct = 0.0;
      const double f = f0 + static_cast<double>(i) / M;
      for (int k = 0; k < n; ++k) direct += x(k) * std::polar(1.0, -2.0 * kPi * f * k);
      largest = std::max(largest, std::abs(direct));
      worst = std::max(worst, std::abs(X[i] - direct));
    }
    EXPECT_LT(worst, kRelativeTolerance * largest) << "N " << n << " K " << k_count;
  }
}

// The tremor search's periodogram: the same grid (bit for bit) and the same powers within 1e-9 of
// the largest, for trials of unequal lengths summed, at 100 Hz over the 3-12 Hz band.
TEST(Spectrum, SummedPeriodogramIsTheDirectOneOnTheSameGrid) {
  const std::vector<Eigen::VectorXd> res = {RandomSignal(2000, 3), RandomSignal(1500, 4)};
  const Periodogram fast = SummedPeriodogram(res, 0.01, 3.0, 12.0);
  const Periodogram direct = DirectPeriodogram(res, 0.01, 3.0, 12.0);
  ASSERT_EQ(fast.f_hz, direct.f_hz);
  ASSERT_EQ(fast.power.size(), direct.power.size());
  ASSERT_GT(fast.power.size(), 700u);
  const double largest = *std::max_element(direct.power.begin(), direct.power.end());
  for (std::size_t i = 0; i < fast.power.size(); ++i) {
    EXPECT_NEAR(fast.power[i], direct.power[i], kRelativeTolerance * largest) << fast.f_hz[i];
  }
  // A 60 Hz trial and a band edge off the grid.
  const std::vector<Eigen::VectorXd> one = {RandomSignal(999, 5)};
  const Periodogram f2 = SummedPeriodogram(one, 1.0 / 60.0, 2.9, 12.3);
  const Periodogram d2 = DirectPeriodogram(one, 1.0 / 60.0, 2.9, 12.3);
  ASSERT_EQ(f2.f_hz, d2.f_hz);
  const double l2 = *std::max_element(d2.power.begin(), d2.power.end());
  for (std::size_t i = 0; i < f2.power.size(); ++i) {
    EXPECT_NEAR(f2.power[i], d2.power[i], kRelativeTolerance * l2);
  }
  EXPECT_TRUE(SummedPeriodogram({}, 0.01, 3.0, 12.0).f_hz.empty());
}

}  // namespace
}  // namespace fesim::identification
