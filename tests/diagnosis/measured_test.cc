// Step 1 of `fesim diagnose` on measured trials (diagnosis/measured.h): output rows, tracker
// dropouts, checks against the rig and their one-line messages.
#include "diagnosis/measured.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "scenarios/scenario.h"

namespace fesim::diagnosis {
namespace {

const sim::ModelParams& Rig() {
  static const Scenario rig =
      LoadScenario(std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/hand_rig.yaml");
  return rig.model;
}

/// `n` rows at `rate_hz`: `input` = 100 µs, q.wrist_flexion = 0.1 sin t, q.mcp_flexion = 0.05.
Trial Record(int n, double rate_hz, const std::string& input = "u.ext") {
  Trial t;
  t.metadata["source"] = "m.csv";
  std::vector<double> w, m;
  for (int i = 0; i < n; ++i) {
    t.time.push_back(i / rate_hz);
    w.push_back(0.1 * std::sin(t.time.back()));
    m.push_back(0.05);
  }
  t.AddColumn(input, std::vector<double>(n, 100.0));
  t.AddColumn("q.wrist_flexion", w);
  t.AddColumn("q.mcp_flexion", m);
  return t;
}

void SetRow(Trial* t, std::size_t row, double value) {
  for (std::size_t k = 0; k < t->names.size(); ++k) {
    if (t->names[k].rfind("q.", 0) == 0) t->columns[k][row] = value;
  }
}

// Found while writing the fuzz seeds (issue 10): a row at which every output is NaN (a tracker
// dropout) was dropped as if it belonged to another sensor's grid, and the record was then
// rejected as "sampling is not uniform". --help promises that NaN gaps are skipped.
TEST(PrepareMeasured, TrackerDropoutsStayOnTheGridAndAreMasked) {
  Trial t = Record(200, 50.0);
  for (std::size_t row : {10u, 57u, 58u, 170u}) SetRow(&t, row, NAN);
  const MeasuredData d = PrepareMeasured(Rig(), {t}, 0.3);
  ASSERT_EQ(d.heldout.trials.size(), 1u);
  EXPECT_EQ(d.heldout.trials[0].size(), 200u);
  EXPECT_TRUE(std::isnan(d.heldout.trials[0].Column("q.wrist_flexion")[57]));
  EXPECT_EQ(d.train.trials[0].size() + 60, 200u);  // t < 2.8 s trains: 140 rows
  EXPECT_EQ(d.outputs, (std::vector<std::string>{"q.wrist_flexion", "q.mcp_flexion"}));
  EXPECT_EQ(d.channels, std::vector<std::string>{"ext"});
  const long counted = d.train.Count() + d.heldout.Count();
  EXPECT_EQ(counted, 2 * (200 - 4));  // dropouts do not count
}

TEST(PrepareMeasured, ATwoRateRecordKeepsTheOutputGridWithItsDropouts) {
  // Inputs at 100 Hz, angles at 50 Hz (NaN on the odd rows), one angle dropout at row 100.
  Trial t = Record(400, 100.0);
  for (std::size_t row = 1; row < 400; row += 2) SetRow(&t, row, NAN);
  SetRow(&t, 100, NAN);
  const MeasuredData d = PrepareMeasured(Rig(), {t}, 0.3);
  const Trial& all = d.heldout.trials[0];
  ASSERT_EQ(all.size(), 200u);  // rows 0, 2, …, 398
  for (std::size_t i = 1; i < all.size(); ++i) {
    EXPECT_NEAR(all.time[i] - all.time[i - 1], 0.02, 1e-12) << i;
  }
  EXPECT_TRUE(std::isnan(all.Column("q.wrist_flexion")[50]));  // the dropout, kept
}

TEST(PrepareMeasured, ARoundedTrackerLogWithDropoutsKeepsEveryRowAndItsInitialPosture) {
  // Issue 28: a 60 Hz tracker log whose time is written to 4 decimals (steps 0.0166 and 0.0167)
  // and that has NaN rows where the tracker lost the hand was cut to 28 samples ("need at least
  // 100"): the grid came from the smallest rounded step. Every row stays, the record is resampled
  // to its median step, the dropouts stay gaps, and the initial posture is the median of the
  // first samples.
  Trial t = Record(600, 60.0);
  for (double& time : t.time) time = std::round(time * 1e4) / 1e4;
  for (std::size_t row : {0u, 30u, 31u, 32u, 400u}) SetRow(&t, row, NAN);
  const MeasuredData d = PrepareMeasured(Rig(), {t}, 0.3);
  const Trial& all = d.heldout.trials[0];
  EXPECT_EQ(all.size(), 600u);
  EXPECT_TRUE(d.notes.empty());
  long gaps = 0;
  for (double v : all.Column("q.wrist_flexion")) gaps += std::isnan(v) ? 1 : 0;
  EXPECT_EQ(gaps, 5);
  ASSERT_EQ(d.train.initial_q.size(), 1u);
  EXPECT_NEAR(d.train.initial_q[0][0], 0.1 * std::sin(2.0 / 60.0), 1e-4);  // rows 1-3: row 2
  EXPECT_EQ(d.train.initial_q[0][1], 0.05);
}

TEST(PrepareMeasured, BadTrialsAreOneLineErrorsNamingFileAndColumn) {
  const auto error = [](const Trial& t) {
    try {
      PrepareMeasured(Rig(), {t}, 0.3);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  Trial t = Record(200, 50.0);
  t.columns[0][7] = NAN;
  EXPECT_EQ(error(t), "m.csv: column u.ext: NaN input");
  EXPECT_EQ(error(Record(200, 50.0, "u.nope")), "m.csv: column u.nope: no such channel in the rig");
  // Uneven sampling is resampled (ResampleToUniform), but time must increase.
  t = Record(200, 50.0);
  t.time[120] = t.time[119];
  EXPECT_NE(error(t).find("m.csv: column time: not increasing at row 120"), std::string::npos)
      << error(t);
  t = Record(200, 50.0);
  t.time[120] += 0.01;
  EXPECT_EQ(error(t), "no error");
  const MeasuredData d = PrepareMeasured(Rig(), {t}, 0.3);
  ASSERT_EQ(d.notes.size(), 1u);
  EXPECT_NE(d.notes[0].find("m.csv: sampling not uniform; resampled to"), std::string::npos)
      << d.notes[0];
  EXPECT_EQ(error(Record(90, 50.0)), "m.csv: 90 samples, need at least 100");
  t = Record(200, 50.0);
  t.columns[0].assign(200, 0.0);
  EXPECT_EQ(error(t), "diagnose: no trial stimulates any channel");
}

TEST(PrepareMeasured, ResampleToUniformInterpolatesOutputsKeepsGapsAndHoldsInputs) {
  Trial t;
  t.time = {0.0, 0.1, 0.2, 0.35, 0.4, 0.5};  // median step 0.1 s
  t.AddColumn("u.ext", {0, 0, 100, 100, 200, 200});
  t.AddColumn("q.wrist_flexion", {0.0, 0.1, 0.2, 0.35, NAN, 0.5});
  const Trial r = ResampleToUniform(t, "m.csv");
  ASSERT_EQ(r.size(), 6u);
  EXPECT_TRUE(IsUniformlySampled(r.time));
  EXPECT_NEAR(r.time[3], 0.3, 1e-12);
  const auto& q = r.Column("q.wrist_flexion");
  const auto& u = r.Column("u.ext");
  EXPECT_NEAR(q[3], 0.3, 1e-12);  // linear between 0.2 s and 0.35 s
  EXPECT_TRUE(std::isnan(q[4]));  // 0.4 s was a dropout: not invented
  EXPECT_NEAR(q[5], 0.5, 1e-12);
  EXPECT_EQ(u[3], 100.0);  // the nearest row (0.35 s), not interpolated towards 200
  EXPECT_EQ(u[4], 200.0);
  EXPECT_EQ(u[2], 100.0);
  t.time[2] = 0.1;
  try {
    ResampleToUniform(t, "m.csv");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("m.csv: column time: not increasing at row 2"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace fesim::diagnosis
