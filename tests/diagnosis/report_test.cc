#include "diagnosis/report.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "scenarios/trial.h"

namespace fesim::diagnosis {
namespace {

Diagnosis Example() {
  Diagnosis d;
  d.cause = "tremor";
  d.confidence = 0.9;
  d.baseline_heldout_nrmse = 0.2;
  d.extended_heldout_nrmse = 0.1;
  d.gain = 0.5;
  d.mechanisms = {"tremor@wrist_flexion"};
  d.mechanism_ids = {"tremor"};
  d.extension_parameters = {{"tremor@wrist_flexion:tremor.amplitude_nm", "N*m", 0.08, 0.002}};
  CandidateResult c;
  c.id = "tremor";
  c.joint = "wrist_flexion";
  c.label = "tremor@wrist_flexion";
  c.score = 300;
  c.fitted = true;
  c.heldout_gain = 0.5;
  c.accepted = true;
  c.evidence = "peak at 6 Hz";
  CandidateResult n;
  n.id = "fatigue";
  n.label = "fatigue";
  d.candidates = {c, n};
  d.split = "test";
  Trial t;
  for (int i = 0; i < 200; ++i) t.time.push_back(i / 60.0);
  std::vector<double> y(200), yh(200);
  for (int i = 0; i < 200; ++i) {
    y[i] = std::sin(i * 0.3);
    yh[i] = 0.0;
  }
  t.AddColumn("q.wrist_flexion", y);
  d.heldout.trials = {t};
  d.heldout.use = {std::vector<char>(200, 1)};
  d.heldout.outputs = {"q.wrist_flexion"};
  Trial p = t;
  p.MutableColumn("q.wrist_flexion") = yh;
  d.heldout_baseline = {p};
  d.heldout_extended = {t};
  return d;
}

TEST(Report, CandidateLogLineCarriesTheTestFitAndParameterFigures) {
  CandidateResult c;
  c.label = "tremor@wrist_flexion";
  c.score_statistic = 15543.3;
  c.dof = 2;
  c.p_adjusted = 0.0;
  c.fitted = true;
  c.lr_p_adjusted = 1e-9;
  c.heldout_gain = 0.3227;
  c.parameters = {{"tremor.amplitude_nm", "N*m", 0.123268, 0.002}};
  const std::string line = CandidateLogLine(c);
  EXPECT_EQ(line.rfind("tremor@wrist_flexion ", 0), 0u) << line;
  EXPECT_NE(
      line.find("S   15543.3 dof 2 padj 0 fitted 1 lr_padj 1e-09 gain 0.3227 | on top: S nan"),
      std::string::npos)
      << line;
  EXPECT_NE(line.find(" tremor.amplitude_nm=0.123268"), std::string::npos) << line;
}

TEST(Report, JsonHasExactlyTheProductKeys) {
  const std::string j = DiagnosisJson(Example()).Dump(0);
  EXPECT_EQ(j.find("{\"cause\":\"tremor\",\"confidence\":0.9,\"baseline\":{\"heldout_nrmse\":0.2},"
                   "\"extended\":{\"mechanisms\":[\"tremor\"],\"parameters\":{"),
            0u)
      << j;
  EXPECT_NE(j.find("\"heldout_nrmse\":0.1},\"gain\":0.5,\"candidates\":[{\"id\":\"tremor\","
                   "\"score\":300,\"heldout_gain\":0.5,\"evidence\":\"[wrist_flexion] peak at 6 "
                   "Hz\"},{\"id\":\"fatigue\",\"score\":0,\"heldout_gain\":null,"),
            std::string::npos)
      << j;
}

TEST(Report, WritesMarkdownJsonAndPlots) {
  const std::string dir = ::testing::TempDir() + "diag_report";
  std::filesystem::create_directories(dir);
  Diagnosis d = Example();
  d.candidates[1].fitted = true;
  d.candidates[1].heldout_gain = 0.1;
  d.candidates[1].heldout_gain_on_accepted = 0.02;  // second round: on top of the tremor
  WriteDiagnosisReport(d, "inputs", dir);
  const std::string md = ReadFile(dir + "/diagnosis.md");
  EXPECT_NE(md.find("**tremor**"), std::string::npos);
  EXPECT_NE(md.find("from 0.2000 to 0.1000"), std::string::npos);
  EXPECT_NE(md.find("](residuals_wrist_flexion.png)"), std::string::npos);
  // Ranking columns: candidate, score, held-out gain, on top (second round), accepted, evidence.
  EXPECT_NE(md.find("| tremor@wrist_flexion | 300.0 | 0.5000 |  | yes |"), std::string::npos);
  EXPECT_NE(md.find("| fatigue | 0.0 | 0.1000 | 0.0200 |  |"), std::string::npos) << md;
  EXPECT_EQ(ReadFile(dir + "/residuals_wrist_flexion.png").substr(1, 3), "PNG");
  EXPECT_EQ(ReadFile(dir + "/spectrum_wrist_flexion.png").substr(1, 3), "PNG");
  const std::string json = ReadFile(dir + "/diagnosis.json");
  EXPECT_NE(json.find("\"cause\": \"tremor\""), std::string::npos);
  // diagnosis.json keeps exactly PRODUCT.md's candidate keys; the second-round gain is in the
  // markdown only.
  EXPECT_EQ(json.find("on_top"), std::string::npos);
}

// Issue 10: when a write fails half-way (here diagnosis.md cannot replace a directory of that
// name; a full disk behaves alike, docs/reliability.md), the plots and the JSON already written
// are removed: the whole report or none of it.
TEST(Report, AFailedWriteLeavesNoPartOfTheReport) {
  const std::string dir = ::testing::TempDir() + "diag_report_fail";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir + "/diagnosis.md");
  EXPECT_THROW(WriteDiagnosisReport(Example(), "inputs", dir), std::runtime_error);
  std::string left;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    left += e.path().filename().string() + " ";
  }
  EXPECT_EQ(left, "diagnosis.md ");  // only the obstacle
}

}  // namespace
}  // namespace fesim::diagnosis
