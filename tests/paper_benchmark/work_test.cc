#include "paper_benchmark/work.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <string>

#include "base/trial.h"

namespace fesim::paper_benchmark {
namespace {

TEST(ParallelFor, RunsEveryIndexAndReportsEveryFailure) {
  std::vector<std::atomic<int>> hits(50);
  ParallelFor(hits.size(), 3, "item", [&](std::size_t i) { ++hits[i]; });
  for (const auto& h : hits) EXPECT_EQ(h.load(), 1);
  std::atomic<int> ran{0};
  try {
    ParallelFor(20, 2, "fit", [&](std::size_t i) {
      ++ran;
      if (i == 7 || i == 13) throw std::runtime_error("boom " + std::to_string(i));
    });
    FAIL() << "no exception";
  } catch (const WorkItemsFailed& e) {
    EXPECT_STREQ(e.what(), "2 work items failed: fit 7: boom 7; fit 13: boom 13");
    ASSERT_EQ(e.items().size(), 2u);
    EXPECT_EQ(e.items()[1].index, 13u);
    EXPECT_EQ(e.items()[1].label, "fit");
  }
  EXPECT_EQ(ran.load(), 20);  // the others still ran
  // One failure: just its message.
  try {
    ParallelFor(5, 2, "trial", [&](std::size_t i) {
      if (i == 4) throw std::runtime_error("integrator failed");
    });
    FAIL() << "no exception";
  } catch (const WorkItemsFailed& e) {
    EXPECT_STREQ(e.what(), "trial 4: integrator failed");
  }
}

TEST(WorkLoop, InjectedFaultFailsExactlyThatItem) {
  WorkLoop loop(2, nullptr);
  loop.InjectFault("fit 3");
  std::vector<std::atomic<int>> hits(6);
  try {
    loop.Run("fit", hits.size(), [&](std::size_t i) { ++hits[i]; });
    FAIL() << "no exception";
  } catch (const WorkItemsFailed& e) {
    EXPECT_STREQ(e.what(), "fit 3: injected fault");
  }
  for (std::size_t i = 0; i < hits.size(); ++i) EXPECT_EQ(hits[i].load(), i == 3 ? 0 : 1) << i;
  loop.Run("other", 4, [&](std::size_t) {});  // other labels unaffected
}

TEST(Resample, LinearBetweenSamplesNanOutside) {
  Trial t;
  t.time = {0.0, 1.0, 3.0};
  t.AddColumn("q.x", {0.0, 2.0, 6.0});
  const auto v = Resample(t, "q.x", {-0.5, 0.0, 0.25, 2.0, 3.0, 3.5});
  EXPECT_TRUE(std::isnan(v[0]));
  EXPECT_DOUBLE_EQ(v[1], 0.0);
  EXPECT_DOUBLE_EQ(v[2], 0.5);
  EXPECT_DOUBLE_EQ(v[3], 4.0);
  EXPECT_DOUBLE_EQ(v[4], 6.0);
  EXPECT_TRUE(std::isnan(v[5]));
}

TEST(Progress, FractionBelowOneAndTimeLeft) {
  std::vector<double> fractions;
  std::vector<std::string> labels;
  Progress p([&](double f, const std::string& s) {
    fractions.push_back(f);
    labels.push_back(s);
  });
  p.Plan(10.0);
  p.Done(5.0, "half");
  p.Done(10.0, "overrun");  // the plan was an underestimate
  ASSERT_EQ(fractions.size(), 2u);
  EXPECT_DOUBLE_EQ(fractions[0], 0.5);
  EXPECT_DOUBLE_EQ(fractions[1], 0.99);
  EXPECT_NE(labels[0].find("half, ~"), std::string::npos) << labels[0];
  EXPECT_NE(labels[0].find(" s left"), std::string::npos) << labels[0];
}

Trial Data(double gain) {
  Trial t;
  t.metadata["note"] = "x";
  for (int i = 0; i < 20; ++i) t.time.push_back(0.1 * i);
  std::vector<double> u, y;
  for (int i = 0; i < 20; ++i) {
    u.push_back(i % 5 * 10.0);
    y.push_back(gain * u.back());
  }
  t.AddColumn("u.a", u);
  t.AddColumn("q.b", y);
  t.metadata["trial_hash"] = Fnv1a64Hex(FormatTrialCsv(t));
  return t;
}

TEST(FitRunner, CachesByMethodOptionsAndTrialContent) {
  int calls = 0;
  identification::MethodEntry m;
  m.name = "gain";
  m.run = [&calls](const std::vector<Trial>& train, const std::vector<Trial>& test,
                   const identification::ProgressFn&) {
    ++calls;
    // Least-squares gain of q.b on u.a (the option "gain.scale" multiplies it).
    double num = 0, den = 0;
    for (const auto& t : train) {
      for (std::size_t i = 0; i < t.size(); ++i) {
        num += t.Column("u.a")[i] * t.Column("q.b")[i];
        den += t.Column("u.a")[i] * t.Column("u.a")[i];
      }
    }
    const auto it = train[0].metadata.find("gain.scale");
    const double g = num / den * (it == train[0].metadata.end() ? 1.0 : std::stod(it->second));
    identification::MethodResult r;
    r.model_yaml = "gain: {value: " + std::to_string(g) + "}\n";
    for (const auto& t : test) {
      Trial p;
      p.time = t.time;
      std::vector<double> y;
      for (double u : t.Column("u.a")) y.push_back(g * u + 1.0 / 3.0);
      p.AddColumn("q.b", y);
      r.predictions.push_back(p);
    }
    r.metrics.Set("gain", g);
    return r;
  };
  const std::string dir = ::testing::TempDir() + "fit_runner_cache";
  std::system(("rm -rf " + dir).c_str());
  FitRunner runner(dir, {m});
  const Trial a = Data(0.5), b = Data(0.7);
  const FitOutput first = runner.Run("gain", {a}, {b});
  EXPECT_FALSE(first.cached);
  const FitOutput again = runner.Run("gain", {a}, {b});
  EXPECT_TRUE(again.cached);
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(again.model_yaml, first.model_yaml);
  EXPECT_EQ(FormatTrialCsv(again.predictions[0]), FormatTrialCsv(first.predictions[0]));
  EXPECT_EQ(again.metrics.Dump(), first.metrics.Dump());
  EXPECT_DOUBLE_EQ(again.metrics.Find("gain")->AsNumber(), 0.5);
  // A new runner on the same directory (a resumed run) finds it too.
  FitRunner resumed(dir, {m});
  EXPECT_TRUE(resumed.Run("gain", {a}, {b}).cached);
  EXPECT_EQ(resumed.fits_cached(), 1);
  // Other options or other data are other fits.
  EXPECT_FALSE(runner.Run("gain", {a}, {b}, {{"gain.scale", "2"}}).cached);
  EXPECT_FALSE(runner.Run("gain", {b}, {b}).cached);
  EXPECT_EQ(calls, 3);
  EXPECT_EQ(runner.fits_run(), 3);
  EXPECT_EQ(runner.fits_cached(), 1);
}

TEST(GenerateStudy, SimulatesOnceThenReadsTheSameTrialsBack) {
  const std::string src = FESIM_SOURCE_DIR_PATH;
  const std::string study = ::testing::TempDir() + "gen_study.yaml";
  WriteFileAtomic(study,
                  "study: gen_study\nscenario: " + src +
                      "/scenarios/bench_elbow_rig.yaml\nrepetitions: 2\ncohort: {size: 1}\n"
                      "protocols:\n  - name: ramp\n    stimulation: {type: protocol, protocol: "
                      "{name: ramp, channel: bic, u_max_us: 200, duration_s: 6, rest_s: 1}}\n");
  // `scenario:` is resolved relative to the study's directory: give it an absolute path.
  const std::string cache = ::testing::TempDir() + "gen_study_cache";
  std::system(("rm -rf " + cache).c_str());
  const StudyTrials first = GenerateStudy(study, 3, cache, 2, nullptr);
  ASSERT_EQ(first.measured.size(), 2u);
  EXPECT_EQ(first.simulated, 2);
  const StudyTrials second = GenerateStudy(study, 3, cache, 2, nullptr);
  EXPECT_EQ(second.simulated, 0);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(FormatTrialCsv(second.measured[i]), FormatTrialCsv(first.measured[i]));
    EXPECT_EQ(FormatTrialCsv(second.truth[i]), FormatTrialCsv(first.truth[i]));
    // trial_hash is the hash of the content without it.
    Trial t = first.measured[i];
    const std::string h = TrialHash(t);
    t.metadata.erase("trial_hash");
    EXPECT_EQ(h, Fnv1a64Hex(FormatTrialCsv(t)));
    // The identifier's view: the torque sensor's rows, the driven channel only.
    EXPECT_EQ(first.measured[i].NamesWithPrefix("u."), std::vector<std::string>{"u.bic"});
    EXPECT_TRUE(first.measured[i].Has("tau.elbow_flexion"));
    EXPECT_NEAR(first.measured[i].time[1] - first.measured[i].time[0], 1.0 / 50.0, 1e-12);
  }
  // The two repetitions differ only by noise (different noise seeds).
  EXPECT_NE(TrialHash(first.measured[0]), TrialHash(first.measured[1]));
  std::string measured_path;  // seed 3's, the only entry so far
  for (const auto& entry : std::filesystem::recursive_directory_iterator(cache)) {
    const std::string p = entry.path().string();
    if (p.size() > 11 && p.compare(p.size() - 11, 11, "ramp_r1.csv") == 0) measured_path = p;
  }
  ASSERT_FALSE(measured_path.empty());
  // Another seed is another cache entry.
  EXPECT_EQ(GenerateStudy(study, 4, cache, 2, nullptr).simulated, 2);
  // Issue 28: a cached trial truncated at a row boundary (still a valid CSV) or edited is not
  // taken: its trial is simulated again and comes back whole.
  const std::string whole = ReadFile(measured_path);
  WriteFileAtomic(measured_path, whole.substr(0, whole.rfind('\n', whole.size() - 2) + 1));
  const StudyTrials third = GenerateStudy(study, 3, cache, 2, nullptr);
  EXPECT_EQ(third.simulated, 1);
  EXPECT_EQ(ReadFile(measured_path), whole);
  EXPECT_EQ(FormatTrialCsv(third.measured[0]), FormatTrialCsv(first.measured[0]));
}

}  // namespace
}  // namespace fesim::paper_benchmark
