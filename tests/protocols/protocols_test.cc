// Tests of the protocol generators (protocols/protocols.h, protocols/filters.h) against the checks
// of issue 3: grid coverage of U, staircase width shares, PRMS level uniformity, FRN spectrum,
// multisine band, reaching boundary conditions, stimulation limits, seed reproducibility.
#include "protocols/protocols.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "protocols/filters.h"

namespace fesim::protocols {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kExactTol = 1e-9;             // µs or s: values that are computed exactly
constexpr double kShareTol = 0.01;             // staircase: |share − 1/3| over a long sequence
constexpr double kChiSquare999Df4 = 18.467;    // χ² 99.9 % quantile, 4 degrees of freedom
constexpr double kFrnMaxFractionAbove = 0.05;  // FRN variance above 1.5·f_c
constexpr double kFrnCutoffFactor = 1.5;
constexpr double kMultisineMinInBand = 0.99;  // multisine power inside 0.2–4 Hz
constexpr double kBoundaryTol = 1e-9;         // reaching v, a at and 1 ps inside segment ends
constexpr double kFiniteDiffTol = 1e-5;       // relative, central differences of the path

// ---------------------------------------------------------------------------------------------
// helpers

/// Which part of the spectrum PowerFraction adds up.
struct Band {
  double lo_hz;
  double hi_hz;
};

/// Fraction of the (mean-removed) signal power at frequencies in [band.lo, band.hi], by a direct
/// DFT (one-sided periodogram, DC excluded). A record that is not periodic (filtered noise) is
/// tapered by a Hann window first, so that the jump between its ends does not leak power to high
/// frequencies; a record of whole periods (multisine) is analysed as it is.
double PowerFraction(const std::vector<double>& x, double rate_hz, Band band, bool hann) {
  const std::size_t n = x.size();
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= n;
  std::vector<double> y(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double w = hann ? 0.5 - 0.5 * std::cos(2.0 * kPi * i / (n - 1)) : 1.0;
    y[i] = (x[i] - mean) * w;
  }
  double total = 0.0, selected = 0.0;
  for (std::size_t k = 1; k <= n / 2; ++k) {
    double re = 0.0, im = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double a = 2.0 * kPi * static_cast<double>(k) * static_cast<double>(i) / n;
      re += y[i] * std::cos(a);
      im -= y[i] * std::sin(a);
    }
    const double f = k * rate_hz / n;
    const double power = (re * re + im * im) * ((2 * k == n) ? 1.0 : 2.0);
    total += power;
    if (f >= band.lo_hz - 1e-9 && f <= band.hi_hz + 1e-9) selected += power;
  }
  return selected / total;
}

/// Checks the limits of issue 3 on every sample: 0 ≤ u_k ≤ 300 and Σu ≤ sum_max.
void ExpectWithinLimits(const StimulationProgram& p, double sum_max_us) {
  ASSERT_EQ(p.times_s.size(), p.values_us.size());
  for (std::size_t k = 0; k < p.values_us.size(); ++k) {
    ASSERT_EQ(p.values_us[k].size(), p.channels.size());
    double sum = 0.0;
    for (double v : p.values_us[k]) {
      EXPECT_GE(v, 0.0);
      EXPECT_LE(v, kMaxPulseWidthUs);
      sum += v;
    }
    EXPECT_LE(sum, sum_max_us + kExactTol) << "sample " << k;
  }
}

/// Times strictly increasing from 0, all before duration.
void ExpectWellFormed(const StimulationProgram& p) {
  ASSERT_FALSE(p.times_s.empty());
  EXPECT_EQ(p.times_s.front(), 0.0);
  for (std::size_t k = 1; k < p.times_s.size(); ++k) EXPECT_GT(p.times_s[k], p.times_s[k - 1]);
  EXPECT_LT(p.times_s.back(), p.duration_s);
}

/// Zero stimulation on [0, rest) and [duration − rest, duration].
void ExpectRests(const StimulationProgram& p, double rest_s) {
  for (double t = 0.0; t < rest_s; t += 0.01) {
    for (double v : ValueAt(p, t)) EXPECT_EQ(v, 0.0) << "t = " << t;
  }
  for (double t = p.duration_s - rest_s; t <= p.duration_s; t += 0.01) {
    for (double v : ValueAt(p, t)) EXPECT_EQ(v, 0.0) << "t = " << t;
  }
}

bool SamePrograms(const StimulationProgram& a, const StimulationProgram& b) {
  return a.channels == b.channels && a.times_s == b.times_s && a.values_us == b.values_us &&
         a.duration_s == b.duration_s && a.steady_state_times_s == b.steady_state_times_s;
}

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// ---------------------------------------------------------------------------------------------
// limits

TEST(ClipToLimits, ClampsEachChannelAndScalesTheSumUniformly) {
  StimulationLimit limit;
  limit.sum_max_us = 300.0;
  const std::vector<double> a = ClipToLimits({-20.0, 100.0, 50.0}, limit);
  EXPECT_EQ(a, (std::vector<double>{0.0, 100.0, 50.0}));
  const std::vector<double> b = ClipToLimits({400.0, 150.0}, limit);  // → {300, 150} → ×2/3
  EXPECT_NEAR(b[0], 200.0, kExactTol);
  EXPECT_NEAR(b[1], 100.0, kExactTol);
  EXPECT_NEAR(b[0] + b[1], 300.0, kExactTol);
  EXPECT_EQ(ClipToLimits({350.0}, StimulationLimit{})[0], 300.0);
  EXPECT_THROW(ClipToLimits({std::nan("")}, limit), std::invalid_argument);
  limit.sum_max_us = 0.0;
  EXPECT_NE(ErrorOf([&] { ClipToLimits({1.0}, limit); }).find("sum_max_us"), std::string::npos);
}

TEST(ValueAt, HoldsEachValueFromItsTime) {
  StimulationProgram p;
  p.channels = {"a"};
  p.times_s = {0.0, 1.0, 2.5};
  p.values_us = {{0.0}, {10.0}, {20.0}};
  p.duration_s = 3.0;
  EXPECT_EQ(ValueAt(p, -1.0)[0], 0.0);
  EXPECT_EQ(ValueAt(p, 0.999)[0], 0.0);
  EXPECT_EQ(ValueAt(p, 1.0)[0], 10.0);
  EXPECT_EQ(ValueAt(p, 2.49)[0], 10.0);
  EXPECT_EQ(ValueAt(p, 2.5)[0], 20.0);
  EXPECT_EQ(ValueAt(p, 10.0)[0], 20.0);
}

// ---------------------------------------------------------------------------------------------
// [Hand Hammerstein]: step grid

/// All points of the 50 µs lattice inside U (000 eq. (46)), by brute force.
std::set<std::vector<double>> LatticeInU(std::size_t n, double u_max, double spacing) {
  std::set<std::vector<double>> out;
  const int m = static_cast<int>(std::floor(kMaxPulseWidthUs / spacing + 1e-9));
  std::vector<int> idx(n, 0);
  for (;;) {
    std::vector<double> u(n);
    double sum = 0.0;
    for (std::size_t i = 0; i < n; ++i) sum += (u[i] = idx[i] * spacing);
    if (sum <= u_max + 1e-9) out.insert(u);
    std::size_t i = 0;
    while (i < n && ++idx[i] > m) idx[i++] = 0;
    if (i == n) break;
  }
  return out;
}

TEST(StepGrid, VisitsEveryLatticePointOfUOnceInBothOrders) {
  struct Case {
    std::size_t n;
    double u_max;
  };
  for (const Case c : {Case{2, 150.0}, Case{2, 300.0}, Case{2, 450.0}, Case{2, 600.0},
                       Case{3, 400.0}, Case{4, 500.0}}) {
    for (GridOrder order : {GridOrder::kFirstChannelFastest, GridOrder::kLastChannelFastest}) {
      StepGridParams params;
      params.channels.clear();
      for (std::size_t i = 0; i < c.n; ++i) params.channels.push_back("ch" + std::to_string(i));
      params.u_max_us = c.u_max;
      params.order = order;
      const StimulationProgram p = StepGrid(params);
      SCOPED_TRACE("n = " + std::to_string(c.n) + ", u_max = " + std::to_string(c.u_max));
      ExpectWellFormed(p);
      ExpectWithinLimits(p, c.u_max);
      const std::set<std::vector<double>> lattice = LatticeInU(c.n, c.u_max, 50.0);
      const std::set<std::vector<double>> visited(p.values_us.begin(), p.values_us.end());
      EXPECT_EQ(visited, lattice);                    // all visited, all inside U
      EXPECT_EQ(p.values_us.size(), lattice.size());  // each once
      EXPECT_EQ(p.values_us.front(), std::vector<double>(c.n, 0.0));
      for (std::size_t k = 0; k < p.times_s.size(); ++k) {
        EXPECT_NEAR(p.times_s[k], 5.0 * k, kExactTol);
        ASSERT_LT(k, p.steady_state_times_s.size());
        // The steady-state sample is at the end of its own step.
        EXPECT_NEAR(p.steady_state_times_s[k], 5.0 * (k + 1) - params.steady_state_lead_s,
                    kExactTol);
        EXPECT_EQ(ValueAt(p, p.steady_state_times_s[k]), p.values_us[k]);
      }
      EXPECT_EQ(p.steady_state_times_s.size(), p.values_us.size());
      EXPECT_NEAR(p.duration_s, 5.0 * lattice.size(), kExactTol);
    }
  }
}

TEST(StepGrid, BoustrophedonTraversalAsFig6AndItsMirror) {
  // Full square (u_max = 600 µs, two channels): every move is one 50 µs step of one channel; the
  // fast channel sweeps 0 → 300 → 0 while the slow one climbs (000 Fig. 6 b, c).
  StepGridParams params;
  params.u_max_us = 600.0;
  const StimulationProgram a = StepGrid(params);
  params.order = GridOrder::kLastChannelFastest;
  const StimulationProgram b = StepGrid(params);
  for (const StimulationProgram* p : {&a, &b}) {
    for (std::size_t k = 1; k < p->values_us.size(); ++k) {
      const double d0 = std::abs(p->values_us[k][0] - p->values_us[k - 1][0]);
      const double d1 = std::abs(p->values_us[k][1] - p->values_us[k - 1][1]);
      EXPECT_NEAR(d0 + d1, 50.0, kExactTol) << "step " << k;
      EXPECT_TRUE(d0 == 0.0 || d1 == 0.0) << "step " << k;
    }
  }
  // First sweep: order A moves channel 0 first, order B channel 1; B mirrors A (u1 ↔ u2).
  EXPECT_EQ(a.values_us[1], (std::vector<double>{50.0, 0.0}));
  EXPECT_EQ(b.values_us[1], (std::vector<double>{0.0, 50.0}));
  ASSERT_EQ(a.values_us.size(), b.values_us.size());
  for (std::size_t k = 0; k < a.values_us.size(); ++k) {
    EXPECT_EQ(a.values_us[k][0], b.values_us[k][1]);
    EXPECT_EQ(a.values_us[k][1], b.values_us[k][0]);
  }
}

TEST(StepGrid, FourDataSetsShareTheGridAndAlternateOrders) {
  StepGridParams params;
  params.u_max_us = 450.0;
  const std::vector<StimulationProgram> sets = StepGridDataSets(params);
  ASSERT_EQ(sets.size(), 4u);
  const std::set<std::vector<double>> grid(sets[0].values_us.begin(), sets[0].values_us.end());
  for (const StimulationProgram& s : sets) {
    EXPECT_EQ(std::set<std::vector<double>>(s.values_us.begin(), s.values_us.end()), grid);
  }
  EXPECT_TRUE(SamePrograms(sets[0], sets[2]));
  EXPECT_TRUE(SamePrograms(sets[1], sets[3]));
  EXPECT_FALSE(SamePrograms(sets[0], sets[1]));
}

TEST(StepGrid, RejectsBadParams) {
  StepGridParams params;
  params.u_max_us = 700.0;
  EXPECT_NE(ErrorOf([&] { StepGrid(params); }).find("StepGridParams.u_max_us"), std::string::npos);
  params = StepGridParams{};
  params.steady_state_lead_s = 5.0;
  EXPECT_NE(ErrorOf([&] { StepGrid(params); }).find("steady_state_lead_s"), std::string::npos);
  params = StepGridParams{};
  params.channels = {"a", "a"};
  EXPECT_NE(ErrorOf([&] { StepGrid(params); }).find("twice"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// [Le 2010]: triangular ramp, staircase, FRN, PRMS (30 s tests, 5 s rest at both ends)

TEST(TriangularRamp, RisesToThePeakAndReturnsAtThePulseRate) {
  const TriangularRampParams params;
  const StimulationProgram p = TriangularRamp(params);
  ExpectWellFormed(p);
  ExpectWithinLimits(p, kMaxPulseWidthUs);
  ExpectRests(p, 5.0);
  EXPECT_EQ(p.duration_s, 30.0);
  // 800 pulses at 40 Hz in the 20 s window + two rest entries.
  ASSERT_EQ(p.times_s.size(), 802u);
  EXPECT_NEAR(ValueAt(p, 5.0)[0], 0.0, kExactTol);
  EXPECT_NEAR(ValueAt(p, 15.0)[0], 300.0, kExactTol);
  EXPECT_NEAR(ValueAt(p, 10.0)[0], 150.0, kExactTol);
  EXPECT_NEAR(ValueAt(p, 20.0)[0], 150.0, kExactTol);
  for (std::size_t k = 2; k < p.times_s.size() - 1; ++k) {
    EXPECT_NEAR(p.times_s[k] - p.times_s[k - 1], 0.025, kExactTol);
    EXPECT_NEAR(std::abs(p.values_us[k][0] - p.values_us[k - 1][0]), 300.0 / 400.0, kExactTol);
  }
}

TEST(Staircase, WidthsTauTwoTauThreeTauShareTheTestInThirdsInRandomOrder) {
  StaircaseParams params;
  params.timing.duration_s = 3010.0;  // a long sequence: 3000 s active
  params.settling_time_s = 1.0;       // τ = 0.25 s
  params.seed = 11;
  const StimulationProgram p = Staircase(params);
  ExpectWellFormed(p);
  ExpectWithinLimits(p, kMaxPulseWidthUs);
  ExpectRests(p, 5.0);
  const double tau = 0.25;
  std::map<int, double> time_by_width;
  std::vector<int> classes;
  // Entries 1 … size−2 are the steps; the last step ends where the closing rest begins.
  for (std::size_t k = 1; k + 1 < p.times_s.size(); ++k) {
    const double w = p.times_s[k + 1] - p.times_s[k];
    const int c = static_cast<int>(std::lround(w / tau));
    ASSERT_GE(c, 1);
    ASSERT_LE(c, 3);
    // Common scale factor ≈ 1; boundaries snapped to the 40 Hz pulse grid.
    EXPECT_NEAR(w, c * tau, 0.025 + 0.01 * tau);
    const double pulses = p.times_s[k] * 40.0;
    EXPECT_NEAR(pulses, std::round(pulses), 1e-6);
    time_by_width[c] += w;
    classes.push_back(c);
    EXPECT_GE(p.values_us[k][0], params.u_min_us);
    EXPECT_LE(p.values_us[k][0], params.u_max_us);
  }
  for (int c = 1; c <= 3; ++c) {
    EXPECT_NEAR(time_by_width[c] / 3000.0, 1.0 / 3.0, kShareTol) << "width " << c << "τ";
  }
  // Randomised order: the width class changes often (a sorted list changes twice). For independent
  // draws with these proportions P(change) ≈ 0.6; require at least 0.4.
  std::size_t changes = 0;
  for (std::size_t k = 1; k < classes.size(); ++k) changes += classes[k] != classes[k - 1];
  EXPECT_GT(static_cast<double>(changes), 0.4 * classes.size());
}

TEST(Staircase, DefaultThirtySecondTest) {
  const StimulationProgram p = Staircase(StaircaseParams{});
  ExpectWellFormed(p);
  ExpectRests(p, 5.0);
  EXPECT_EQ(p.duration_s, 30.0);
  EXPECT_NEAR(p.times_s.back(), 25.0, kExactTol);
}

TEST(IsometricTests, RejectBadParamsNamingTheParameter) {
  StaircaseParams st;
  st.settling_time_s = 0.1;  // τ below two pulse periods
  EXPECT_NE(ErrorOf([&] { Staircase(st); }).find("StaircaseParams.settling_time_s"),
            std::string::npos);
  FilteredRandomNoiseParams frn;
  frn.cutoff_hz = 20.0;  // Nyquist of 40 Hz
  EXPECT_NE(ErrorOf([&] { FilteredRandomNoise(frn); }).find("FilteredRandomNoiseParams.cutoff_hz"),
            std::string::npos);
  TriangularRampParams tr;
  tr.timing.duration_s = 10.0;  // not longer than the two 5 s rests
  EXPECT_NE(ErrorOf([&] { TriangularRamp(tr); }).find("TriangularRampParams.timing.duration_s"),
            std::string::npos);
  tr = TriangularRampParams{};
  tr.u_peak_us = 350.0;
  EXPECT_NE(ErrorOf([&] { TriangularRamp(tr); }).find("u_peak_us = 350 is outside (0, 300]"),
            std::string::npos);
}

TEST(ButterworthLowPass, UnitDcGainHalfPowerAtCutoffAndMonotone) {
  for (int order : {1, 2, 3, 4, 7}) {
    const auto s = DesignButterworthLowPass(order, 1.0, 40.0);
    EXPECT_NEAR(CascadeGain(s, 0.0, 40.0), 1.0, 1e-12);
    EXPECT_NEAR(CascadeGain(s, 1.0, 40.0), 1.0 / std::sqrt(2.0), 1e-12);
    double last = 1.0 + 1e-12;
    for (double f = 0.0; f < 20.0; f += 0.1) {
      const double g = CascadeGain(s, f, 40.0);
      EXPECT_LE(g, last);
      last = g;
    }
    // Step response settles to 1 (unit DC gain of the time-domain filter).
    const std::vector<double> y = FilterCascade(s, std::vector<double>(2000, 1.0));
    EXPECT_NEAR(y.back(), 1.0, 1e-9);
  }
  EXPECT_THROW(DesignButterworthLowPass(4, 25.0, 40.0), std::invalid_argument);
  EXPECT_THROW(DesignButterworthLowPass(0, 1.0, 40.0), std::invalid_argument);
}

// Forward–backward filtering: a constant passes unchanged (no start-up transient), a sinusoid is
// scaled by |H|² and not shifted (zero phase), and the result has x's length.
TEST(ButterworthLowPass, ZeroPhaseFilterKeepsConstantsAndPhaseAndSquaresTheGain) {
  constexpr double kFs = 25.0, kFc = 2.0, kF = 1.0;
  const auto s = DesignButterworthLowPass(2, kFc, kFs);
  const std::vector<double> c = FilterZeroPhase(s, std::vector<double>(50, 3.5), 40);
  ASSERT_EQ(c.size(), 50u);
  for (double v : c) EXPECT_NEAR(v, 3.5, 1e-12);
  const double kPi = std::acos(-1.0);
  std::vector<double> x(500);
  for (std::size_t k = 0; k < x.size(); ++k) x[k] = std::sin(2.0 * kPi * kF * k / kFs);
  const std::vector<double> y = FilterZeroPhase(s, x, 75);
  ASSERT_EQ(y.size(), x.size());
  const double g2 = std::pow(CascadeGain(s, kF, kFs), 2);
  // Away from the ends (where the reflection stands in for the unseen signal): y = |H|² x.
  for (std::size_t k = 100; k + 100 < x.size(); ++k) EXPECT_NEAR(y[k], g2 * x[k], 1e-6) << k;
  EXPECT_EQ(FilterZeroPhase(s, {1.0}, 10), std::vector<double>{1.0});
}

TEST(FilteredRandomNoise, SpectrumBelowCutoffAndRangeSpanned) {
  for (std::uint64_t seed : {1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u}) {
    FilteredRandomNoiseParams params;
    params.seed = seed;
    const StimulationProgram p = FilteredRandomNoise(params);
    ExpectWellFormed(p);
    ExpectWithinLimits(p, kMaxPulseWidthUs);
    ExpectRests(p, 5.0);
    std::vector<double> active;
    for (std::size_t k = 1; k + 1 < p.values_us.size(); ++k) active.push_back(p.values_us[k][0]);
    ASSERT_EQ(active.size(), 800u);
    EXPECT_NEAR(*std::min_element(active.begin(), active.end()), params.u_min_us, kExactTol);
    EXPECT_NEAR(*std::max_element(active.begin(), active.end()), params.u_max_us, kExactTol);
    const double above = PowerFraction(active, 40.0, {kFrnCutoffFactor * params.cutoff_hz, 20.0},
                                       /*hann=*/true);
    EXPECT_LE(above, kFrnMaxFractionAbove) << "seed " << seed;
  }
}

TEST(Prms, LevelsUniformByChiSquareAndSequencePeriodic) {
  PrmsParams params;  // q = 5, n = 2: period 24 symbols
  params.symbol_duration_s = 0.25;
  params.timing.duration_s = 10.0 + 0.25 * 24 * 50;  // 50 whole periods
  for (std::uint64_t seed : {1u, 7u, 42u}) {
    params.seed = seed;
    const StimulationProgram p = Prms(params);
    ExpectWellFormed(p);
    ExpectWithinLimits(p, kMaxPulseWidthUs);
    ExpectRests(p, 5.0);
    std::map<double, int> counts;
    for (std::size_t k = 1; k + 1 < p.values_us.size(); ++k) ++counts[p.values_us[k][0]];
    ASSERT_EQ(counts.size(), 5u);  // exactly the q levels 0, 75, …, 300 µs
    EXPECT_EQ(counts.begin()->first, 0.0);
    EXPECT_EQ(counts.rbegin()->first, 300.0);
    double n = 0.0;
    for (const auto& c : counts) n += c.second;
    double chi2 = 0.0;
    for (const auto& c : counts) chi2 += std::pow(c.second - n / 5.0, 2) / (n / 5.0);
    EXPECT_LT(chi2, kChiSquare999Df4) << "seed " << seed;
    const std::vector<int> s = PrmsSymbols(params, 200);
    for (std::size_t k = 0; k + 24 < s.size(); ++k) EXPECT_EQ(s[k], s[k + 24]);
    // Maximal length: the period is not shorter than 24 (every window of 2 nonzero states occurs).
    std::set<std::pair<int, int>> windows;
    for (std::size_t k = 0; k + 1 < 24; ++k) windows.insert({s[k], s[k + 1]});
    windows.insert({s[23], s[24]});
    EXPECT_EQ(windows.size(), 24u);
  }
}

TEST(Prms, RejectsNonPrimeLevels) {
  PrmsParams params;
  params.num_levels = 6;
  EXPECT_NE(ErrorOf([&] { Prms(params); }).find("PrmsParams.num_levels"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// [Copur 2016]: multisine through the co-activation mapping

TEST(CoactivationMap, Equations5And6) {
  const CoactivatedPair pos = CoactivationMap(80.0, 40.0, 30.0);
  EXPECT_EQ(pos.agonist_us, 120.0);
  EXPECT_EQ(pos.antagonist_us, 30.0);
  const CoactivatedPair neg = CoactivationMap(-80.0, 40.0, 30.0);
  EXPECT_EQ(neg.agonist_us, 40.0);
  EXPECT_EQ(neg.antagonist_us, 110.0);
  const CoactivatedPair zero = CoactivationMap(0.0, 40.0, 30.0);
  EXPECT_EQ(zero.agonist_us, 40.0);
  EXPECT_EQ(zero.antagonist_us, 30.0);
}

TEST(Multisine, PowerInsideTheBandAndMappedByCoactivation) {
  MultisineParams params;
  params.duration_s = 30.0;  // six 5 s periods keeps the DFT small
  const std::vector<double> u = MultisineVirtualInput(params);
  ASSERT_EQ(u.size(), 1200u);
  double peak = 0.0;
  for (double v : u) peak = std::max(peak, std::abs(v));
  EXPECT_NEAR(peak, params.amplitude_us, kExactTol);
  EXPECT_GE(PowerFraction(u, 40.0, {0.2, 4.0}, /*hann=*/false), kMultisineMinInBand);

  const StimulationProgram p = Multisine(params);
  ExpectWellFormed(p);
  ExpectWithinLimits(p, kMaxPulseWidthUs * 2);
  ASSERT_EQ(p.values_us.size(), u.size());
  for (std::size_t k = 0; k < u.size(); ++k) {
    const double ag = p.values_us[k][0] - params.coact_agonist_us;
    const double an = p.values_us[k][1] - params.coact_antagonist_us;
    EXPECT_GE(ag, -kExactTol);
    EXPECT_GE(an, -kExactTol);
    EXPECT_TRUE(ag <= kExactTol || an <= kExactTol);  // only one side above co-activation
    EXPECT_NEAR(ag - an, u[k], kExactTol);            // inverse of eq. (5)–(6)
  }
}

// ---------------------------------------------------------------------------------------------
// [Spagnol 2013]: antagonist pseudo-random steps

TEST(ShoulderPseudoRandomSteps, NeverBothChannelsAtOnce) {
  ShoulderStepsParams params;
  params.duration_s = 600.0;
  params.gap_min_s = 0.0;  // allow direct switches between channels
  const StimulationProgram p = ShoulderPseudoRandomSteps(params);
  ExpectWellFormed(p);
  ExpectWithinLimits(p, kMaxPulseWidthUs);
  ExpectRests(p, params.rest_s);
  int on[2] = {0, 0};
  for (std::size_t k = 0; k < p.values_us.size(); ++k) {
    const auto& v = p.values_us[k];
    EXPECT_FALSE(v[0] > 0.0 && v[1] > 0.0) << "sample " << k;
    for (int c = 0; c < 2; ++c) {
      if (v[c] > 0.0) {
        ++on[c];
        EXPECT_GE(v[c], params.level_min_us);
        EXPECT_LE(v[c], params.level_max_us);
      }
    }
    // Switching instants on the pulse grid.
    const double n = p.times_s[k] * params.pulse_rate_hz;
    EXPECT_NEAR(n, std::round(n), 1e-6);
  }
  EXPECT_GT(on[0], 20);
  EXPECT_GT(on[1], 20);
}

// ---------------------------------------------------------------------------------------------
// limits on every generator, seeds

TEST(Limits, NeverExceededByAnyGenerator) {
  StimulationLimit tight;
  tight.sum_max_us = 120.0;
  {
    TriangularRampParams q;
    q.limit = tight;
    ExpectWithinLimits(TriangularRamp(q), tight.sum_max_us);
  }
  {
    StaircaseParams q;
    q.limit = tight;
    ExpectWithinLimits(Staircase(q), tight.sum_max_us);
  }
  {
    FilteredRandomNoiseParams q;
    q.limit = tight;
    ExpectWithinLimits(FilteredRandomNoise(q), tight.sum_max_us);
  }
  {
    PrmsParams q;
    q.limit = tight;
    ExpectWithinLimits(Prms(q), tight.sum_max_us);
  }
  {
    MultisineParams q;  // co-activation + amplitude would exceed 300 µs: clipped
    q.duration_s = 20.0;
    q.coact_agonist_us = 250.0;
    q.coact_antagonist_us = 250.0;
    q.amplitude_us = 200.0;
    q.limit.sum_max_us = 550.0;  // (300, 250) fits; anything larger would be scaled
    const StimulationProgram p = Multisine(q);
    ExpectWithinLimits(p, q.limit.sum_max_us);
    double top = 0.0;
    for (const auto& v : p.values_us) top = std::max(top, v[0]);
    EXPECT_EQ(top, kMaxPulseWidthUs);
  }
  {
    ShoulderStepsParams q;
    q.limit = tight;
    ExpectWithinLimits(ShoulderPseudoRandomSteps(q), tight.sum_max_us);
  }
  {
    StepGridParams q;
    q.u_max_us = 250.0;
    ExpectWithinLimits(StepGrid(q), 250.0);
  }
}

template <typename Params, typename Gen>
void ExpectSeedReproducible(Params params, Gen gen, const char* name) {
  SCOPED_TRACE(name);
  params.seed = 5;
  const StimulationProgram a = gen(params);
  const StimulationProgram b = gen(params);
  EXPECT_TRUE(SamePrograms(a, b));
  params.seed = 6;
  const StimulationProgram c = gen(params);
  EXPECT_FALSE(SamePrograms(a, c));
}

TEST(Seeds, SameSeedSameProgramDifferentSeedDifferentProgram) {
  ExpectSeedReproducible(StaircaseParams{}, Staircase, "staircase");
  ExpectSeedReproducible(FilteredRandomNoiseParams{}, FilteredRandomNoise, "frn");
  ExpectSeedReproducible(PrmsParams{}, Prms, "prms");
  ExpectSeedReproducible(MultisineParams{}, Multisine, "multisine");
  ExpectSeedReproducible(ShoulderStepsParams{}, ShoulderPseudoRandomSteps, "shoulder");
}

// ---------------------------------------------------------------------------------------------
// [Schearer 2014]: reaching

TEST(MinimumJerk, QuinticBoundaryConditionsAndShape) {
  const QuinticTiming a = MinimumJerk(0.0), b = MinimumJerk(1.0);
  EXPECT_EQ(a.s, 0.0);
  EXPECT_EQ(b.s, 1.0);
  EXPECT_EQ(a.ds, 0.0);
  EXPECT_EQ(b.ds, 0.0);
  EXPECT_EQ(a.dds, 0.0);
  EXPECT_EQ(b.dds, 0.0);
  // Limits from inside the interval vanish too (continuity with the clamped outside).
  const QuinticTiming a1 = MinimumJerk(1e-9), b1 = MinimumJerk(1.0 - 1e-9);
  EXPECT_LT(std::abs(a1.ds) + std::abs(a1.dds), 1e-6);
  EXPECT_LT(std::abs(b1.ds) + std::abs(b1.dds), 1e-6);
  EXPECT_NEAR(MinimumJerk(0.5).s, 0.5, 1e-15);
  EXPECT_NEAR(MinimumJerk(0.5).ds, 1.875, 1e-15);  // peak speed 15/8 · distance / T
  double last = 0.0;
  for (double t = 0.01; t < 1.0; t += 0.01) {
    const QuinticTiming q = MinimumJerk(t);
    EXPECT_NEAR(q.s, 10 * std::pow(t, 3) - 15 * std::pow(t, 4) + 6 * std::pow(t, 5), 1e-14);
    EXPECT_NEAR(q.s + MinimumJerk(1.0 - t).s, 1.0, 1e-12);  // symmetric
    EXPECT_GT(q.s, last);                                   // monotone
    last = q.s;
    const double h = 1e-5;
    EXPECT_NEAR(q.ds, (MinimumJerk(t + h).s - MinimumJerk(t - h).s) / (2 * h), 1e-8);
    EXPECT_NEAR(q.dds, (MinimumJerk(t + h).ds - MinimumJerk(t - h).ds) / (2 * h), 1e-7);
  }
}

double Norm(const Vec3& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

TEST(ReachingProgram, TwoHomesNineTargetsThreeTimesWithHoldAndReturn) {
  const ReachingParams params;
  const HandPath path = ReachingProgram(params);
  int reaches = 0;
  std::set<std::pair<int, int>> pairs;
  Vec3 here = params.homes_m[0];
  double t = 0.0;
  for (std::size_t i = 0; i < path.segments.size(); ++i) {
    const HandSegment& s = path.segments[i];
    EXPECT_NEAR(s.start_s, t, kExactTol);  // contiguous
    EXPECT_EQ(s.from_m, here);             // continuous
    t += s.duration_s;
    here = s.to_m;
    if (s.kind == SegmentKind::kReach) {
      ++reaches;
      pairs.insert({s.home_index, s.target_index});
      EXPECT_EQ(s.from_m, params.homes_m[s.home_index]);
      EXPECT_EQ(s.to_m, params.targets_m[s.target_index]);
      EXPECT_EQ(s.duration_s, 2.0);
      ASSERT_LT(i + 2, path.segments.size());
      EXPECT_EQ(path.segments[i + 1].kind, SegmentKind::kHold);
      EXPECT_EQ(path.segments[i + 1].duration_s, 1.0);
      EXPECT_EQ(path.segments[i + 2].kind, SegmentKind::kReturn);
      EXPECT_EQ(path.segments[i + 2].to_m, params.homes_m[s.home_index]);
    }
  }
  EXPECT_EQ(reaches, 2 * 9 * 3);  // 004 §II.A: 54 reaching trajectories
  EXPECT_EQ(pairs.size(), 18u);
  EXPECT_NEAR(path.duration_s, t, kExactTol);
}

TEST(ReachingProgram, VelocityAndAccelerationZeroAtSegmentEndsAndStraightLines) {
  const HandPath path = ReachingProgram(ReachingParams{});
  for (const HandSegment& s : path.segments) {
    for (double t : {s.start_s, s.start_s + 1e-12, s.start_s + s.duration_s - 1e-12}) {
      const HandState h = EvaluateHandPath(path, t);
      EXPECT_LT(Norm(h.velocity_m_s), kBoundaryTol) << "t = " << t;
      EXPECT_LT(Norm(h.acceleration_m_s2), kBoundaryTol) << "t = " << t;
    }
    EXPECT_EQ(Norm(EvaluateHandPath(path, s.start_s).velocity_m_s), 0.0);
    EXPECT_EQ(Norm(EvaluateHandPath(path, s.start_s).acceleration_m_s2), 0.0);
    // Midpoint on the straight line, halfway; peak speed 1.875 · distance / T.
    const HandState mid = EvaluateHandPath(path, s.start_s + 0.5 * s.duration_s);
    Vec3 d;
    for (int i = 0; i < 3; ++i) {
      d[i] = s.to_m[i] - s.from_m[i];
      EXPECT_NEAR(mid.position_m[i], s.from_m[i] + 0.5 * d[i], 1e-12);
    }
    EXPECT_NEAR(Norm(mid.velocity_m_s), 1.875 * Norm(d) / s.duration_s, 1e-12);
  }
  const HandState end = EvaluateHandPath(path, path.duration_s + 10.0);
  EXPECT_EQ(end.position_m, path.segments.back().to_m);
  EXPECT_EQ(Norm(end.velocity_m_s), 0.0);
}

TEST(ReachingProgram, SamplesMatchEvaluationAndDerivativesAreConsistent) {
  ReachingParams params;
  params.sample_rate_hz = 200.0;
  const HandPath path = ReachingProgram(params);
  ASSERT_EQ(path.times_s.size(), path.position_m.size());
  ASSERT_EQ(path.times_s.size(), path.velocity_m_s.size());
  ASSERT_EQ(path.times_s.size(), path.acceleration_m_s2.size());
  EXPECT_NEAR(path.times_s.back(), path.duration_s, 1.0 / params.sample_rate_hz);
  for (std::size_t k = 0; k < path.times_s.size(); k += 37) {
    EXPECT_NEAR(path.times_s[k], k / params.sample_rate_hz, kExactTol);
    const HandState h = EvaluateHandPath(path, path.times_s[k]);
    EXPECT_EQ(h.position_m, path.position_m[k]);
    EXPECT_EQ(h.velocity_m_s, path.velocity_m_s[k]);
    const double t = path.times_s[k], dt = 1e-5;
    const HandState a = EvaluateHandPath(path, t - dt), b = EvaluateHandPath(path, t + dt);
    for (int i = 0; i < 3; ++i) {
      const double v_fd = (b.position_m[i] - a.position_m[i]) / (2 * dt);
      EXPECT_NEAR(v_fd, h.velocity_m_s[i], kFiniteDiffTol * (1.0 + std::abs(v_fd)));
    }
  }
}

TEST(TargetGrid3x3, CornersAndCentre) {
  const Vec3 hl{0.4, 1.5, 0.0}, hr{0.4, 1.5, 0.3}, ll{0.4, 1.2, 0.0}, lr{0.4, 1.2, 0.3};
  const std::vector<Vec3> g = TargetGrid3x3(hl, hr, ll, lr);
  ASSERT_EQ(g.size(), 9u);
  EXPECT_EQ(g[0], hl);
  EXPECT_EQ(g[2], hr);
  EXPECT_EQ(g[6], ll);
  EXPECT_EQ(g[8], lr);
  EXPECT_NEAR(g[4][1], 1.35, 1e-12);
  EXPECT_NEAR(g[4][2], 0.15, 1e-12);
}

TEST(JointTorquesFromEndEffectorForce, LeverArmsOfAHingeAndPowerBalance) {
  // One hinge about Z at the origin, wrist at (L, 0, 0): column [ω × p; ω] = [(0, L, 0); (0, 0,
  // 1)]. A force F_y at the ball joint d further along X has the moment F_y (L + d) about the
  // hinge.
  const double L = 0.3, d = 0.05, F = 12.0;
  const std::vector<double> tau = JointTorquesFromEndEffectorForce({0.0, F, 0.0}, {d, 0.0, 0.0},
                                                                   {{0.0, L, 0.0, 0.0, 0.0, 1.0}});
  ASSERT_EQ(tau.size(), 1u);
  EXPECT_NEAR(tau[0], F * (L + d), 1e-12);
  // Two arbitrary columns: Σ τ_j q̇_j equals the wrench's power on the wrist twist J q̇.
  const std::vector<std::array<double, 6>> J = {{0.1, -0.2, 0.3, 0.0, 1.0, 0.0},
                                                {-0.25, 0.05, 0.15, 0.6, 0.0, 0.8}};
  const Vec3 f{3.0, -4.0, 5.0}, r{0.02, -0.03, 0.04};
  const double qd[2] = {0.7, -1.3};
  const std::vector<double> t2 = JointTorquesFromEndEffectorForce(f, r, J);
  const Vec3 m{r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]};
  double power = 0.0;
  for (int i = 0; i < 3; ++i) {
    power += f[i] * (J[0][i] * qd[0] + J[1][i] * qd[1]);
    power += m[i] * (J[0][i + 3] * qd[0] + J[1][i + 3] * qd[1]);
  }
  EXPECT_NEAR(t2[0] * qd[0] + t2[1] * qd[1], power, 1e-12);
}

// [Schearer 2014] §II.A, the subject with SCI: only the listed home–target pairs, in order, each
// repetitions times, with a transfer whenever the home changes.
TEST(ReachingProgram, ExplicitPathsRunOnlyThoseInOrder) {
  ReachingParams params;
  params.paths = {{0, 0}, {0, 2}, {0, 8}, {1, 8}};
  const HandPath path = ReachingProgram(params);
  std::vector<std::array<int, 2>> reached;
  int transfers = 0;
  for (const HandSegment& s : path.segments) {
    if (s.kind == SegmentKind::kReach) reached.push_back({s.home_index, s.target_index});
    transfers += s.kind == SegmentKind::kTransfer;
  }
  ASSERT_EQ(reached.size(), 12u);
  for (std::size_t k = 0; k < reached.size(); ++k) EXPECT_EQ(reached[k], params.paths[k / 3]);
  EXPECT_EQ(transfers, 1);  // home 0 → home 1 before the last path
  params.paths = {{0, 9}};
  EXPECT_NE(
      ErrorOf([&] { ReachingProgram(params); }).find("ReachingParams.paths[0] target index 9"),
      std::string::npos);
}

TEST(ReachingProgram, RejectsBadParams) {
  ReachingParams params;
  params.reach_duration_s = 0.0;
  EXPECT_NE(ErrorOf([&] { ReachingProgram(params); }).find("ReachingParams.reach_duration_s"),
            std::string::npos);
  params = ReachingParams{};
  params.targets_m.clear();
  EXPECT_NE(ErrorOf([&] { ReachingProgram(params); }).find("targets_m"), std::string::npos);
}

}  // namespace
}  // namespace fesim::protocols
