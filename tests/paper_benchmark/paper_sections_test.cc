// The steps of the elbow-tests and tremor-wrist sections (paper_benchmark/paper_sections.h) on
// known inputs; the whole sections run in benchmark_test.cc.
#include "paper_benchmark/paper_sections.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <map>
#include <set>
#include <stdexcept>
#include <string>

#include "identification/inverse_dynamics.h"
#include "scenarios/scenario.h"
#include "scenarios/study.h"
#include "sim/reaching.h"

namespace fesim::paper_benchmark {
namespace {

constexpr double kTol = 1e-9;  // Best Fit % and amplitudes from a few sums: rounding only.

Trial Record(const std::vector<double>& time,
             const std::vector<std::pair<std::string, std::vector<double>>>& columns) {
  Trial t;
  t.time = time;
  for (const auto& [name, values] : columns) t.AddColumn(name, values);
  return t;
}

TEST(PaperSections, FitAgainstTruthRemovesTheSensorsZeroOffset) {
  // The measured torque is the truth less 2 N·m (a sensor zeroed at rest); a prediction equal to
  // the measured record fits the truth perfectly once that offset is removed.
  const std::vector<double> time = {0.0, 0.1, 0.2, 0.3, 0.4};
  const std::vector<double> y = {1.0, 3.0, 2.0, 5.0, 4.0};
  std::vector<double> truth_y = y;
  for (double& v : truth_y) v += 2.0;
  const Trial measured = Record(time, {{"tau.elbow_flexion", y}});
  const Trial truth = Record(time, {{"tau.elbow_flexion", truth_y}});
  EXPECT_NEAR(FitAgainstTruth(measured, truth, measured, "tau.elbow_flexion"), 100.0, kTol);
  // A prediction off by 1 N·m everywhere: Best Fit 100 (1 − ‖1‖/‖y − ȳ‖).
  std::vector<double> off = y;
  for (double& v : off) v += 1.0;
  const Trial prediction = Record(time, {{"tau.elbow_flexion", off}});
  const double y_mean = 3.0;
  double ss = 0.0;
  for (double v : y) ss += (v - y_mean) * (v - y_mean);
  EXPECT_NEAR(FitAgainstTruth(prediction, truth, measured, "tau.elbow_flexion"),
              100.0 * (1.0 - std::sqrt(5.0) / std::sqrt(ss)), kTol);
}

TEST(PaperSections, FitCellShowsDivergedPredictionsAsBelowMinus100) {
  EXPECT_EQ(FitCell(85.26), "85.3");
  EXPECT_EQ(FitCell(-99.94), "-99.9");
  EXPECT_EQ(FitCell(-150.0), "< −100");
  EXPECT_EQ(FitCell(NAN), "–");
}

TEST(PaperSections, OutputColumnPrefersTorqueThenAngle) {
  EXPECT_EQ(OutputColumn(Record({0.0}, {{"u.ext", {0}}, {"q.wrist", {0}}, {"tau.elbow", {0}}})),
            "tau.elbow");
  EXPECT_EQ(OutputColumn(Record({0.0}, {{"u.ext", {0}}, {"q.wrist", {0}}})), "q.wrist");
  try {
    OutputColumn(Record({0.0}, {{"u.ext", {0}}}));
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "benchmark: prediction without a tau.* or q.* column");
  }
}

TEST(PaperSections, AgonistFirstPutsThePositivelyCorrelatedChannelFirst) {
  const std::vector<double> time = {0.0, 0.1, 0.2, 0.3};
  const std::vector<double> a = {0, 100, 0, 100}, b = {100, 0, 100, 0};
  const std::vector<double> q = {-0.1, 0.1, -0.1, 0.1};  // follows a − b
  const Trial right = Record(time, {{"u.fcr", a}, {"u.ecr", b}, {"q.wrist_flexion", q}});
  const Trial same = AgonistFirst(right);
  EXPECT_EQ(same.names, right.names);
  const Trial swapped_in = Record(time, {{"u.ecr", b}, {"u.fcr", a}, {"q.wrist_flexion", q}});
  const Trial swapped = AgonistFirst(swapped_in);
  EXPECT_EQ(swapped.names, (std::vector<std::string>{"u.fcr", "u.ecr", "q.wrist_flexion"}));
  EXPECT_EQ(swapped.Column("u.fcr"), a);
  EXPECT_EQ(swapped.Column("q.wrist_flexion"), q);
  EXPECT_EQ(swapped.time, time);
  // Not two inputs and one output: unchanged.
  const Trial three = Record(time, {{"u.x", a}, {"u.y", b}, {"u.z", a}, {"q.w", q}});
  EXPECT_EQ(AgonistFirst(three).names, three.names);
}

// Over paper 001's 0.2–4 Hz multisine the wrist lags by more than 90° above its
// resonance, so the zero-lag correlation of the input with the angle can be negative although the
// agonist drives the angle positive at low frequency; the order must follow the low-frequency gain.
TEST(PaperSections, AgonistFirstFollowsTheLowFrequencyGainNotTheLaggedResponse) {
  const double kPi = 3.14159265358979;
  std::vector<double> time, fcr, ecr, q;
  for (int k = 0; k < 3000; ++k) {  // 30 s at 100 Hz
    const double s = 0.01 * k;
    const double u = 20.0 * std::sin(2 * kPi * 0.2 * s) + 40.0 * std::sin(2 * kPi * 3.0 * s);
    time.push_back(s);
    fcr.push_back(60.0 + std::max(u, 0.0));
    ecr.push_back(60.0 + std::max(-u, 0.0));
    // In phase at 0.2 Hz, 170° behind at 3 Hz (above the resonance).
    q.push_back(0.002 * 20.0 * std::sin(2 * kPi * 0.2 * s) +
                0.002 * 40.0 * std::sin(2 * kPi * 3.0 * s - 170.0 * kPi / 180.0));
  }
  double raw = 0.0;
  for (std::size_t i = 0; i < q.size(); ++i) raw += (fcr[i] - ecr[i]) * q[i];
  ASSERT_LT(raw, 0.0);  // the unfiltered correlation points the wrong way
  const Trial in = Record(time, {{"u.ecr", ecr}, {"u.fcr", fcr}, {"q.wrist_flexion", q}});
  EXPECT_EQ(AgonistFirst(in).names,
            (std::vector<std::string>{"u.fcr", "u.ecr", "q.wrist_flexion"}));
}

// The benchmark's scenarios follow the papers' protocols where the papers give a number.
TEST(PaperProtocols, ReachingScenariosRepeatEachPathThreeTimesOnAnArmSupport) {
  // Paper 004 §II.A: each home–target path three times; a mobile arm support at the forearm and
  // the end of the humerus.
  for (const char* file : {"bench_reaching.yaml", "bench_reaching_quick.yaml"}) {
    const Scenario sc = LoadScenario(std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/" + file);
    ASSERT_TRUE(sc.reaching.has_value()) << file;
    EXPECT_EQ(sc.reaching->repetitions, 3) << file;
    EXPECT_FALSE(sc.model.bands.empty()) << file;
    EXPECT_FALSE(sc.model.weight_compensation.empty()) << file;
  }
}

// Paper 004 §II.A, the subject with SCI: four trajectories (mouth → high-left, high-right,
// low-right; shoulder → low-right), three times each, 3 s per reach, distances 16–36 cm, peak
// hand speeds 10–23 cm/s; §II.C: four folds, each leaving out every repetition of one trajectory.
TEST(PaperProtocols, SparseReachingIsFourTrajectoriesThreeTimesAndFoldsLeaveOutWholeOnes) {
  constexpr double kPeakSpeedFactor = 1.875;  // max ds/dτ of the minimum-jerk profile
  constexpr double kRoundingM = 0.005;        // the paper's whole centimetres
  for (const char* file : {"bench_reaching_sparse.yaml", "bench_reaching_sparse_quick.yaml"}) {
    const Scenario sc = LoadScenario(std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/" + file);
    ASSERT_TRUE(sc.reaching.has_value()) << file;
    const protocols::ReachingParams& r = *sc.reaching;
    EXPECT_EQ(r.repetitions, 3) << file;
    EXPECT_DOUBLE_EQ(r.reach_duration_s, 3.0) << file;
    ASSERT_EQ(r.paths.size(), 4u) << file;
    ASSERT_EQ(r.homes_m.size(), 2u) << file;
    // Three trajectories from the mouth (home 0), one from the shoulder (home 1), to the same
    // low-right target.
    EXPECT_EQ(r.paths[2][1], r.paths[3][1]) << file;
    EXPECT_EQ(r.paths[3][0], 1) << file;
    for (const auto& [h, g] : r.paths) {
      double d2 = 0.0;
      for (int i = 0; i < 3; ++i) d2 += std::pow(r.targets_m[g][i] - r.homes_m[h][i], 2);
      const double d = std::sqrt(d2), v = kPeakSpeedFactor * d / r.reach_duration_s;
      EXPECT_GE(d, 0.16 - kRoundingM) << file;
      EXPECT_LE(d, 0.36 + kRoundingM) << file;
      EXPECT_GE(v, 0.10 - kRoundingM) << file;
      EXPECT_LE(v, 0.23 + kRoundingM) << file;
    }
    EXPECT_FALSE(sc.model.bands.empty()) << file;
    EXPECT_GT(sc.trial.sensors.force.noise_std, 0.0) << file;
    EXPECT_GT(sc.trial.sensors.angles.noise_std, 0.0) << file;
  }
  const Scenario sc = LoadScenario(std::string(FESIM_SOURCE_DIR_PATH) +
                                   "/scenarios/bench_reaching_sparse_quick.yaml");
  const std::vector<Trial> trials =
      sim::SimulateReaching(sc.model, *sc.reaching, {}, sc.trial.sensors, 1);
  ASSERT_EQ(trials.size(), 12u);
  std::map<std::string, std::set<std::string>> repetitions;
  for (const Trial& t : trials) {
    repetitions[t.metadata.at("trajectory")].insert(t.metadata.at("repetition"));
  }
  ASSERT_EQ(repetitions.size(), 4u);
  for (const auto& [id, reps] : repetitions) EXPECT_EQ(reps.size(), 3u) << id;
  const identification::ReachingData data = identification::ExtractReachingData(trials);
  ASSERT_EQ(data.group_names.size(), 4u);
  // Every sample of a trial is in its trajectory's group.
  for (std::size_t k = 0; k < trials.size(); ++k) {
    const int g = data.group[static_cast<std::size_t>(data.trial_begin[k])];
    EXPECT_EQ(data.group_names[static_cast<std::size_t>(g)], trials[k].metadata.at("trajectory"));
    for (auto i = data.trial_begin[k]; i < data.trial_begin[k + 1]; ++i) {
      EXPECT_EQ(data.group[static_cast<std::size_t>(i)], g);
    }
  }
  // Leave-one-trajectory-out: 4 folds, one per trajectory, each leaving out its 3 reaches.
  const identification::InvDynOptions options;
  const identification::InvDynModel full = identification::FitInvDyn(
      identification::InvDynKind::kParametric, data.joints, data.X, data.tau, options);
  const identification::InvDynCv cv = identification::LeaveOneTrajectoryOut(
      identification::InvDynKind::kParametric, data, options, full);
  ASSERT_EQ(cv.folds.size(), 4u);
  EXPECT_EQ(std::set<std::string>(cv.folds.begin(), cv.folds.end()).size(), 4u);
  for (const auto& id : cv.folds) EXPECT_EQ(repetitions.count(id), 1u) << id;
}

TEST(PaperProtocols, TremorStudyTrialsLastThreeMinutes) {
  // Paper 001 §4.1: trials "lasting for approximately 3 minutes"; multisine 0.2–4 Hz.
  const Study st =
      LoadStudy(std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/bench_tremor.yaml", 1);
  ASSERT_FALSE(st.items.empty());
  for (const auto& item : st.items) EXPECT_DOUBLE_EQ(item.scenario.trial.duration_s, 180.0);
  EXPECT_NE(st.source_text.find("name: multisine"), std::string::npos);
  EXPECT_EQ(st.source_text.find("f_min_hz"), std::string::npos);  // the 0.2–4 Hz default band
  EXPECT_EQ(st.source_text.find("f_max_hz"), std::string::npos);
}

TEST(PaperSections, ElbowJobsCoverEveryFitOnceInMethodMajorOrder) {
  const std::vector<ElbowJob> jobs = ElbowJobs(2, 3, 4, 2);
  // Per method, participant and protocol: one cross-validation fit (r = −1) and one per trial.
  ASSERT_EQ(jobs.size(), 2u * 3u * 4u * 3u);
  EXPECT_EQ(jobs[0].m, 0);
  EXPECT_EQ(jobs[0].r, -1);
  EXPECT_EQ(jobs[1].r, 0);
  EXPECT_EQ(jobs[2].r, 1);
  EXPECT_EQ(jobs[3].a, 1);
  EXPECT_EQ(jobs[12].p, 1);
  EXPECT_EQ(jobs.back().m, 1);
  EXPECT_EQ(jobs.back().p, 2);
  EXPECT_EQ(jobs.back().a, 3);
  EXPECT_EQ(jobs.back().r, 1);
}

TEST(PaperSections, ElbowBestFitsGoToIdentificationValidationAndCrossValidation) {
  // One method, one participant, two protocols, two trials each.
  const std::vector<ElbowJob> jobs = ElbowJobs(1, 1, 2, 2);
  std::vector<ElbowJobFigures> figures(jobs.size());
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    const ElbowJob& j = jobs[i];
    ElbowJobFigures& f = figures[i];
    if (j.r >= 0) {  // evaluated on both trials of its protocol
      for (int r = 0; r < 2; ++r) {
        f.bf.push_back(10.0 * j.a + r + (r == j.r ? 50.0 : 0.0));
        f.bf_truth.push_back(NAN);
        f.test_proto.push_back(j.a);
        f.test_rep.push_back(r);
      }
    } else {  // evaluated on every trial of both protocols
      for (int b = 0; b < 2; ++b) {
        for (int r = 0; r < 2; ++r) {
          f.bf.push_back(100.0 * j.a + 10.0 * b + r);
          f.bf_truth.push_back(b != j.a ? 1000.0 + b : NAN);
          f.test_proto.push_back(b);
          f.test_rep.push_back(r);
        }
      }
    }
  }
  const ElbowBestFits b = GatherElbowBestFits(jobs, figures, 1, 2);
  // Identification: the fitted trial itself (+50); validation: every trial of the protocol, the
  // fitted one included (paper 002 §6: "all the trials in the same type of the tests").
  EXPECT_EQ(b.ident[0][1], (std::vector<double>{60.0, 61.0}));
  EXPECT_EQ(b.valid[0][1], (std::vector<double>{60.0, 11.0, 10.0, 61.0}));
  EXPECT_EQ(b.cross[0][0][1], (std::vector<double>{10.0, 11.0}));
  EXPECT_EQ(b.cross[0][1][0], (std::vector<double>{100.0, 101.0}));
  EXPECT_EQ(b.cross_truth[0][0], (std::vector<double>{1001.0, 1001.0}));  // other protocol only
  EXPECT_EQ(b.cross_truth[0][1], (std::vector<double>{1000.0, 1000.0}));
}

TEST(PaperSections, PaperTableThreeRanksFrnFirstByTheMeanOverTheOtherTests) {
  // [Le 2010] Table 3, off the diagonal: (a) TR (17.76, 47.94), FRN (83.96, 71.40), Staircase
  // (79.53, 42.67); (b) TR (41.08, 64.11), FRN (68.75, 67.86), Staircase (80.72, 45.00).
  const auto m = PaperCrossMeanOfOthers();
  ASSERT_EQ(m.size(), 3u);
  EXPECT_NEAR(m.at("TR"), (32.85 + 52.595) / 2.0, 1e-9);
  EXPECT_NEAR(m.at("FRN"), (77.68 + 68.305) / 2.0, 1e-9);
  EXPECT_NEAR(m.at("Staircase"), (61.10 + 62.86) / 2.0, 1e-9);
}

TEST(PaperSections, TremorAmplitudeDividesByTheArxDenominatorAtTheTremorFrequency) {
  // |λ| = 5; without poles the amplitude is |λ|.
  EXPECT_NEAR(TremorAngleAmplitude({}, 3.0, 4.0, 6.0, 0.01), 5.0, kTol);
  // A_P(z) = 1 − 0.5 z⁻¹ at ωT = π (f = 50 Hz, T = 10 ms): A = 1.5.
  EXPECT_NEAR(TremorAngleAmplitude({-0.5}, 3.0, 4.0, 50.0, 0.01), 5.0 / 1.5, kTol);
  // At ωT = π/2 (f = 25 Hz): A = 1 − 0.5 (−j) = 1 + 0.5 j.
  EXPECT_NEAR(TremorAngleAmplitude({-0.5}, 3.0, 4.0, 25.0, 0.01), 5.0 / std::sqrt(1.25), kTol);
  // Two poles, against the polynomial evaluated directly.
  const double w = 2.0 * M_PI * 6.0 * 0.01;
  const std::complex<double> z_inv = std::polar(1.0, -w);
  const std::complex<double> A = 1.0 - 1.6 * z_inv + 0.64 * z_inv * z_inv;
  EXPECT_NEAR(TremorAngleAmplitude({-1.6, 0.64}, 0.1, 0.0, 6.0, 0.01), 0.1 / std::abs(A), kTol);
}

}  // namespace
}  // namespace fesim::paper_benchmark
