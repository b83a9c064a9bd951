// The steps of the hand-array section (paper_benchmark/hand_array.h) on known inputs; the whole
// section runs in benchmark_test.cc.
#include "paper_benchmark/hand_array.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>

#include "sim/default_model.h"
#include "tendons/tendon_network.h"

namespace fesim::paper_benchmark {
namespace {

constexpr double kTol = 1e-12;  // means of a few numbers: rounding only.

std::string Message(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "no exception";
}

TEST(HandArray, FoldFiguresSurviveTheCacheRoundTrip) {
  FoldFigures f;
  f.error = {0.25, 0.5, 0.125};
  f.truth_error = {0.0625};
  f.step_wall_s = 3.5;
  f.iterations = 17;
  f.parameters = {{"A.ext.ECRL", 0.75}, {"k.wrist_flexion", 1.5}};
  const FoldFigures g = FoldFromJson(Json::Parse(FoldJson(f).Dump(0)));
  EXPECT_EQ(g.iterations, 17);
  EXPECT_EQ(g.error, f.error);
  EXPECT_EQ(g.truth_error, f.truth_error);
  EXPECT_EQ(g.step_wall_s, f.step_wall_s);
  EXPECT_EQ(g.parameters, f.parameters);
}

TEST(HandArray, LayoutNeedsTwoFoldsAndAtMostTwoProtocols) {
  StudyLayout ok;
  ok.protocols = {"step_grid", "multisine"};
  ok.participants = 2;
  ok.reps = 2;
  EXPECT_NO_THROW(CheckHandArrayLayout("hand.yaml", ok));
  StudyLayout one_fold = ok;
  one_fold.reps = 1;
  EXPECT_EQ(Message([&] { CheckHandArrayLayout("hand.yaml", one_fold); }),
            "hand.yaml: repetitions: needs >= 2 data sets (folds)");
  StudyLayout three = ok;
  three.protocols.push_back("ramp");
  EXPECT_EQ(Message([&] { CheckHandArrayLayout("hand.yaml", three); }),
            "hand.yaml: protocols: at most 2 (the step grid and an unseen input)");
}

TEST(HandArray, FixedTendonMatrixKeepsArmsAndLengthsOfTheInitialPosture) {
  const sim::ModelParams m = sim::DefaultModelParams();
  sim::ModelParams fixed = m;
  FixTendonMatrix(&fixed);
  std::vector<double> q0(sim::kNumCoordinates), q1(sim::kNumCoordinates);
  for (int i = 0; i < sim::kNumCoordinates; ++i) {
    q0[i] = m.coordinates[i].initial_rad;
    q1[i] = q0[i] + 0.3;
  }
  for (std::size_t j = 0; j < m.muscles.size(); ++j) {
    const tendons::MusclePath& before = m.muscles[j].path;
    const tendons::MusclePath& after = fixed.muscles[j].path;
    EXPECT_NEAR(tendons::MusculotendonLength(after, q0), tendons::MusculotendonLength(before, q0),
                1e-12)
        << m.muscles[j].name;
    for (std::size_t c = 0; c < before.crossings.size(); ++c) {
      const auto& cb = before.crossings[c];
      const auto& ca = after.crossings[c];
      const double r0 = tendons::MomentArm(cb.arm, q0[cb.joint] - cb.q_ref_rad);
      // Constant: the same arm at the initial posture and 0.3 rad away from it.
      EXPECT_NEAR(tendons::MomentArm(ca.arm, q0[ca.joint] - ca.q_ref_rad), r0, kTol);
      EXPECT_NEAR(tendons::MomentArm(ca.arm, q1[ca.joint] - ca.q_ref_rad), r0, kTol);
    }
  }
}

TEST(HandArray, AssumptionSwitchesChangeWhatTheyName) {
  const auto switches = AssumptionSwitches();
  ASSERT_EQ(switches.size(), 4u);
  EXPECT_EQ(switches[0].id, "A3");
  EXPECT_EQ(switches[1].id, "A5");
  EXPECT_EQ(switches[2].id, "A6");
  EXPECT_EQ(switches[3].id, "A7");
  const sim::ModelParams m = sim::DefaultModelParams();
  sim::ModelParams a3 = m, a6 = m, a7 = m;
  switches[0].apply(&a3);
  for (const auto& c : a3.coordinates) {
    EXPECT_EQ(c.passive.coulomb_friction_nm, 0.0);
    EXPECT_EQ(c.passive.static_friction_nm, 0.0);
    EXPECT_EQ(c.passive.reflex_gain_nms_per_rad, 0.0);
  }
  switches[2].apply(&a6);
  double mean = 0.0;
  for (const auto& mu : m.muscles) mean += mu.activation_omega_rad_s / m.muscles.size();
  for (const auto& mu : a6.muscles) EXPECT_NEAR(mu.activation_omega_rad_s, mean, 1e-12);
  switches[3].apply(&a7);
  for (std::size_t j = 0; j < m.muscles.size(); ++j) {
    EXPECT_DOUBLE_EQ(a7.muscles[j].hill.max_contraction_velocity,
                     1000.0 * m.muscles[j].hill.max_contraction_velocity);
  }
}

/// Folds of one model for 2 participants × 2 folds × 2 joints: error = base + 0.1 p + 0.01 k
/// (+ 0.001 for the second joint), step = step_s · (1 + k).
std::vector<FoldFigures> Folds(double base, double step_s) {
  std::vector<FoldFigures> folds;
  for (int p = 0; p < 2; ++p) {
    for (int k = 0; k < 2; ++k) {
      FoldFigures f;
      const double e = base + 0.1 * p + 0.01 * k;
      f.error = {e, e + 0.001};
      f.step_wall_s = step_s * (1 + k);
      folds.push_back(f);
    }
  }
  return folds;
}

TEST(HandArray, TablesAverageFoldsPerParticipantThenParticipants) {
  const std::vector<FoldFigures> full = Folds(0.5, 2.0), ham = Folds(0.25, 0.001);
  const std::vector<std::string> joints = {"q.wrist_flexion", "q.mcp_flexion"};
  const HandArrayTables t = TablesOneTwo({HandArrayModel{"full model (12)", &full, true},
                                          HandArrayModel{"Hammerstein (16)", &ham, true}},
                                         joints, 2, 2);
  // Participant 1, wrist: mean of 0.5 and 0.51; participant 2: 0.6, 0.61; over participants 0.555.
  EXPECT_NEAR(t.mean_error[0][0], 0.555, kTol);
  EXPECT_NEAR(t.mean_error[0][1], 0.556, kTol);
  EXPECT_NEAR(t.mean_error[1][0], 0.305, kTol);
  ASSERT_EQ(t.steps[0].size(), 4u);  // every fold's step time
  EXPECT_NEAR(t.means.Find("full_model")->Find("local_step_wall_s")->AsNumber(), 3.0, kTol);
  const Json& p1 = t.rows.Items()[0];
  EXPECT_EQ(p1.Find("participant")->AsString(), "p1");
  EXPECT_NEAR(p1.Find("hammerstein")->Find("wrist_flexion")->AsNumber(), 0.255, kTol);
  EXPECT_NEAR(p1.Find("hammerstein")->Find("local_step_wall_s_mean")->AsNumber(), 0.0015, kTol);
  // Sample standard deviation of 0.001 and 0.002.
  EXPECT_NEAR(p1.Find("hammerstein")->Find("local_step_wall_s_std")->AsNumber(), std::sqrt(0.5e-6),
              kTol);
  // Step times: full model with 1 decimal, Hammerstein with 4; the paper's row beside.
  EXPECT_NE(t.markdown.find("| p1 | 0.505 | 0.506 | 3.0 ± 1.4 | 0.255 | 0.256 | 0.0015 ± 0.0007 |"),
            std::string::npos)
      << t.markdown;
  EXPECT_NE(t.markdown.find("| **mean** | **0.555** | **0.556** | **3.0** |"), std::string::npos);
  EXPECT_NE(
      t.markdown.find("| paper 000 mean (Tables 1–2) | 0.617 | 0.500 | 1019 | 0.499 | 0.480 | "
                      "0.178 |"),
      std::string::npos);
}

TEST(HandArray, TablesLeaveOutAModelThatIsNotFitted) {
  const std::vector<FoldFigures> full(4), ham = Folds(0.25, 0.001);
  const HandArrayTables t = TablesOneTwo({HandArrayModel{"full model (12)", &full, false},
                                          HandArrayModel{"Hammerstein (16)", &ham, true}},
                                         {"q.wrist_flexion", "q.mcp_flexion"}, 2, 2);
  EXPECT_EQ(t.markdown.find("full"), std::string::npos);
  EXPECT_EQ(t.means.Find("full_model"), nullptr);
  EXPECT_TRUE(t.steps[0].empty());
  EXPECT_EQ(t.mean_error[0], std::vector<double>(2, 0.0));
  EXPECT_NE(t.markdown.find("| participant | Hammerstein wrist_flexion | Hammerstein mcp_flexion "
                            "| Hammerstein step s (mean ± sd) |"),
            std::string::npos)
      << t.markdown;
}

TEST(HandArray, ForearmMeanOmegaAveragesTheMusclesCrossingWristOrFingers) {
  sim::ModelParams m;
  m.muscles.clear();
  const auto add = [&](double omega, std::vector<int> joints) {
    sim::MuscleParams mu;
    mu.activation_omega_rad_s = omega;
    for (int j : joints) {
      tendons::Crossing c;
      c.joint = j;
      mu.path.crossings.push_back(c);
    }
    m.muscles.push_back(mu);
  };
  add(10.0, {sim::kElbowFlexion});                     // upper arm: left out
  add(4.0, {sim::kElbowFlexion, sim::kWristFlexion});  // crosses the wrist: in
  add(8.0, {sim::kMcpFlexion, sim::kPipFlexion});      // finger: in
  add(99.0, {});                                       // no crossing: left out
  EXPECT_NEAR(ForearmMeanOmega(m), 6.0, kTol);
  m.muscles.resize(1);
  EXPECT_EQ(ForearmMeanOmega(m), 0.0);  // none: 0, not NaN (as the section reports it)
}

TEST(HandArray, UpperMedianTakesTheUpperOfTheTwoMiddleValues) {
  EXPECT_EQ(UpperMedian({3.0, 1.0, 2.0}), 2.0);
  EXPECT_EQ(UpperMedian({4.0, 1.0, 3.0, 2.0}), 3.0);
  EXPECT_TRUE(std::isnan(UpperMedian({})));
}

}  // namespace
}  // namespace fesim::paper_benchmark
