// The shared helpers and the report steps of `fesim benchmark` (paper_benchmark/run.cc,
// declared in sections.h) on known inputs; the whole run is in benchmark_test.cc.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <string>

#include "paper_benchmark/sections.h"

namespace fesim::paper_benchmark {
namespace {

constexpr double kTol = 1e-12;

TEST(BenchmarkRun, MeanAndSampleStdIgnoreNonFiniteValues) {
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_NEAR(MeanFinite({1.0, NAN, 2.0, inf, 6.0}), 3.0, kTol);
  EXPECT_TRUE(std::isnan(MeanFinite({NAN, -inf})));
  EXPECT_TRUE(std::isnan(MeanFinite({})));
  // Sample (n − 1) standard deviation of 1, 2, 6: sqrt(((−2)² + (−1)² + 3²) / 2) = sqrt(7).
  EXPECT_NEAR(StdFinite({1.0, NAN, 2.0, 6.0}), std::sqrt(7.0), kTol);
  EXPECT_EQ(StdFinite({4.0}), 0.0);
}

TEST(BenchmarkRun, FixedPrintsDecimalsAndADashForNonFinite) {
  EXPECT_EQ(Fixed(3.14159, 2), "3.14");
  EXPECT_EQ(Fixed(-0.5, 0), "-0");
  EXPECT_EQ(Fixed(1019.0, 0), "1019");
  EXPECT_EQ(Fixed(NAN, 3), "–");
  EXPECT_EQ(Fixed(std::numeric_limits<double>::infinity(), 1), "–");
}

TEST(BenchmarkRun, ModelYamlValuesAndListsReadIdentifiedModels) {
  const std::string yaml =
      "Omega: {value: 12.5, ci95: 0.3}\n"
      "order: 3\n"
      "a: {a1: {value: -1.6}, a2: {value: 0.64}, a3: 0.1}\n";
  EXPECT_EQ(ModelYamlValue(yaml, "Omega"), 12.5);
  EXPECT_EQ(ModelYamlValue(yaml, "order"), 3.0);
  EXPECT_TRUE(std::isnan(ModelYamlValue(yaml, "lambda1")));
  EXPECT_TRUE(std::isnan(ModelYamlValue("{not: [yaml", "Omega")));
  EXPECT_EQ(ModelYamlList(yaml, "a"), (std::vector<double>{-1.6, 0.64, 0.1}));
  EXPECT_TRUE(ModelYamlList(yaml, "order").empty());  // not a mapping
  EXPECT_TRUE(ModelYamlList(yaml, "b").empty());
}

TEST(BenchmarkRun, ModelYamlAtReadsNestedKeys) {
  const std::string yaml =
      "joints:\n"
      "  elbow_flexion:\n"
      "    parametric:\n"
      "      theta0: {value: -0.25, unit: rad}\n"
      "      k_s: 1.5\n"
      "  shoulder_elevation:\n"
      "    parametric:\n"
      "      theta0: {value: 0.5, unit: rad}\n";
  EXPECT_EQ(ModelYamlAt(yaml, {"joints", "elbow_flexion", "parametric", "theta0"}), -0.25);
  EXPECT_EQ(ModelYamlAt(yaml, {"joints", "elbow_flexion", "parametric", "k_s"}), 1.5);
  EXPECT_EQ(ModelYamlAt(yaml, {"joints", "shoulder_elevation", "parametric", "theta0"}), 0.5);
  EXPECT_TRUE(std::isnan(ModelYamlAt(yaml, {"joints", "wrist", "parametric", "theta0"})));
  EXPECT_TRUE(std::isnan(ModelYamlAt(yaml, {"joints", "elbow_flexion", "parametric", "k_s", "x"})));
  EXPECT_TRUE(std::isnan(ModelYamlAt("{not: [yaml", {"joints"})));
}

TEST(BenchmarkRun, FindingsAreOneMarkdownLineAndOneTableRowEach) {
  const Json f = Finding("Algorithm 2 identifies better", true, "+3.1 points");
  EXPECT_EQ(FindingLine(f), "- Algorithm 2 identifies better: **holds** (+3.1 points).\n");
  const Json g = Finding("staircase predicts best", false, "70 % vs 72 %");
  EXPECT_EQ(FindingLine(g), "- staircase predicts best: **does not hold** (70 % vs 72 %).\n");

  Json sections = Json::Object();
  Json elbow = Json::Object();
  elbow.Set("findings", Json::Array().Push(f).Push(g));
  sections.Set("hand_array", Json::Object());  // no findings: no row
  sections.Set("elbow_tests", elbow);
  std::string md;
  const Json all = FindingsSummary(sections, &md);
  ASSERT_EQ(all.Items().size(), 2u);
  EXPECT_EQ(all.Items()[1].Find("section")->AsString(), "elbow_tests");
  EXPECT_EQ(all.Items()[1].Find("claim")->AsString(), "staircase predicts best");
  EXPECT_NE(md.find("| elbow_tests | Algorithm 2 identifies better | holds | +3.1 points |\n"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| elbow_tests | staircase predicts best | does not hold | 70 % vs 72 % |\n"),
            std::string::npos);
  EXPECT_EQ(md.find("hand_array"), std::string::npos);
}

TEST(BenchmarkRun, ScalingEstimateBoundsEachLoopByItsLongestItemAndItsShare) {
  // One loop: items of 10 s in total, the longest 4 s, 6 s of loop wall time in an 8 s run: 2 s
  // serial. R ranks: at least 2 + max(4, 10/R), at most 2 + 10/R + 4 (1 − 1/R); plus the replay.
  WorkLoop::LoopCost c;
  c.label = "fit";
  c.items = 5;
  c.item_s_total = 10.0;
  c.item_s_max = 4.0;
  c.wall_s = 6.0;
  c.replay_s = 0.5;
  std::string md;
  const Json est = ScalingEstimate({c}, 8.0, &md);
  ASSERT_EQ(est.Items().size(), 6u);  // R = 1, 2, 4, 8, 16, 64
  const Json& r1 = est.Items()[0];
  EXPECT_EQ(r1.Find("ranks")->AsNumber(), 1.0);
  EXPECT_NEAR(r1.Find("at_least_s")->AsNumber(), 2.0 + 10.0 + 0.5, kTol);
  EXPECT_NEAR(r1.Find("at_most_s")->AsNumber(), 2.0 + 10.0 + 0.5, kTol);
  const Json& r2 = est.Items()[1];
  EXPECT_NEAR(r2.Find("at_least_s")->AsNumber(), 2.0 + 5.0 + 0.5, kTol);
  EXPECT_NEAR(r2.Find("at_most_s")->AsNumber(), 2.0 + 5.0 + 2.0 + 0.5, kTol);
  const Json& r64 = est.Items()[5];
  EXPECT_EQ(r64.Find("ranks")->AsNumber(), 64.0);
  EXPECT_NEAR(r64.Find("at_least_s")->AsNumber(), 2.0 + 4.0 + 0.5, kTol);
  EXPECT_NEAR(r64.Find("at_most_s")->AsNumber(), 2.0 + 10.0 / 64 + 4.0 * (1.0 - 1.0 / 64) + 0.5,
              kTol);
  EXPECT_NE(md.find("the rest of the run (2.0 s) is serial"), std::string::npos) << md;
  EXPECT_NE(md.find("| 2 | 7.5 | 9.5 |\n"), std::string::npos) << md;
  // Loops longer than the run (a clock's rounding): no negative serial part.
  std::string md2;
  const Json est2 = ScalingEstimate({c}, 5.0, &md2);
  EXPECT_NEAR(est2.Items()[0].Find("at_least_s")->AsNumber(), 10.5, kTol);
}

TEST(BenchmarkRun, WorkCountersOfTheRanksAddUp) {
  WorkCounters a;
  a.trials_simulated = 3;
  a.fits_run = 2;
  a.fits_cached = 1;
  a.by_kind = {{"simulation", 1.5}, {"spline-oe", 2.0}};
  WorkCounters b;
  b.trials_simulated = 4;
  b.fits_run = 5;
  b.by_kind = {{"simulation", 0.25}, {"tremor-arx", 1.0}};
  const WorkCounters sum = SumWorkCounters({a.ToJson().Dump(0), b.ToJson().Dump(0)});
  EXPECT_EQ(sum.trials_simulated, 7);
  EXPECT_EQ(sum.fits_run, 7);
  EXPECT_EQ(sum.fits_cached, 1);
  EXPECT_EQ(sum.by_kind, (std::map<std::string, double>{
                             {"simulation", 1.75}, {"spline-oe", 2.0}, {"tremor-arx", 1.0}}));
  EXPECT_EQ(SumWorkCounters({}).fits_run, 0);
}

}  // namespace
}  // namespace fesim::paper_benchmark
