#include "diagnosis/report.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "base/trial.h"

namespace fesim::diagnosis {
namespace {

Diagnosis Example() {
  Diagnosis d;
  d.cause = "tremor";
  d.confidence = 0.9;
  d.baseline_heldout_nrmse = 0.2;
  d.extended_heldout_nrmse = 0.1;
  d.gain = 0.5;
  d.notes = {"the person calibration stopped in a poorer minimum"};
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
  c.heldout_own_gain = 0.45;
  c.heldout_own_z = 7.5;
  c.parameters = {{"tremor.amplitude_nm", "N*m", 0.08, 0.002}};
  c.accepted = true;
  c.evidence = "peak at 6 Hz";
  CandidateResult n;
  n.id = "fatigue";
  n.label = "fatigue";
  n.person_at_bound = "k.wrist_flexion";
  n.score_on_accepted = 12.5;
  n.heldout_gain_on_accepted = 0.03;
  d.candidates = {c, n};
  d.split = "test";
  d.reason = "a tremor (periodic joint torque) explains what the calibrated model misses";
  d.baseline_heldout_nrmse_per_output = {0.2};
  d.extended_heldout_nrmse_per_output = {0.1};
  d.reference.method = "hammerstein-mimo";
  d.reference.heldout_nrmse = 0.15;
  d.reference.heldout_nrmse_per_output = {0.15};
  d.noise_rad = {0.01};
  PersonValue k;
  k.name = "k.wrist_flexion";
  k.unit = "N*m/rad";
  k.nominal = 0.8;
  k.value = 1.1;
  k.ci95 = 0.05;
  k.fitted = true;
  PersonValue mass;
  mass.name = "mass.hand";
  mass.unit = "1";
  mass.nominal = mass.value = 1.0;
  d.person = {k, mass};
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
  c.heldout_own_gain = 0.3301;
  c.parameters = {{"tremor.amplitude_nm", "N*m", 0.123268, 0.002}};
  const std::string line = CandidateLogLine(c);
  EXPECT_EQ(line.rfind("tremor@wrist_flexion ", 0), 0u) << line;
  EXPECT_NE(line.find("S   15543.3 dof 2 padj 0 infl 1.0 fitted 1 lr_padj 1e-09 gain 0.3227 own "
                      "0.3301 z nan | on top: S nan"),
            std::string::npos)
      << line;
  EXPECT_NE(line.find(" tremor.amplitude_nm=0.123268"), std::string::npos) << line;
}

TEST(Report, JsonMarksAJointNotChosenByTheFitAsNotJudged) {
  // A tremor fitted at the MCP too, whose wrist fit had the lower training Σr² (extension.h):
  // "judged" true for the judged fit, false for the other joint's, null when not fitted.
  Diagnosis d = Example();
  CandidateResult m = d.candidates[0];
  m.joint = "mcp_flexion";
  m.label = "tremor@mcp_flexion";
  m.accepted = false;
  m.not_judged = true;
  d.candidates.push_back(m);
  const Json j = DiagnosisJson(d);
  const auto& c = j.Find("candidates")->Items();
  ASSERT_EQ(c.size(), 3u);
  EXPECT_TRUE(c[0].Find("judged")->AsBool());
  EXPECT_TRUE(c[1].Find("judged")->IsNull());
  EXPECT_FALSE(c[2].Find("judged")->AsBool());
}

TEST(Report, JsonHasTheProductKeysPerCandidateTestsAndTheCalibratedPerson) {
  const Json j = DiagnosisJson(Example());
  const std::string text = j.Dump(0);
  // PRODUCT.md's keys first, in its order.
  EXPECT_EQ(text.find("{\"cause\":\"tremor\",\"confidence\":0.9,\"reason\":\"a tremor"), 0u)
      << text;
  for (const char* key : {"baseline", "extended", "gain", "candidates", "person", "reference"}) {
    EXPECT_NE(j.Find(key), nullptr) << key;
  }
  EXPECT_EQ(j.Find("baseline")->Find("heldout_nrmse")->AsNumber(), 0.2);
  EXPECT_EQ(j.Find("reference")->Find("method")->AsString(), "hammerstein-mimo");
  EXPECT_EQ(j.Find("reference")->Find("heldout_nrmse")->AsNumber(), 0.15);
  // Each candidate: its joint, statistic, p-values and whether it was accepted.
  const Json& c0 = j.Find("candidates")->Items()[0];
  for (const char* key : {"id", "score", "heldout_gain", "evidence", "joint", "statistic", "dof",
                          "p_value", "p_adjusted", "accepted", "decision"}) {
    EXPECT_NE(c0.Find(key), nullptr) << key;
  }
  EXPECT_EQ(c0.Find("joint")->AsString(), "wrist_flexion");
  EXPECT_TRUE(c0.Find("accepted")->AsBool());
  EXPECT_EQ(c0.Find("heldout_own_gain")->AsNumber(), 0.45);
  EXPECT_TRUE(j.Find("candidates")->Items()[1].Find("heldout_gain")->IsNull());  // not fitted
  EXPECT_TRUE(j.Find("candidates")->Items()[1].Find("heldout_own_gain")->IsNull());
  EXPECT_EQ(c0.Find("heldout_own_z")->AsNumber(), 7.5);
  EXPECT_TRUE(j.Find("candidates")->Items()[1].Find("heldout_own_z")->IsNull());
  EXPECT_TRUE(c0.Find("person_at_bound")->IsNull());
  EXPECT_EQ(j.Find("candidates")->Items()[1].Find("person_at_bound")->AsString(),
            "k.wrist_flexion");
  // The second round's figures, on top of the accepted tremor; null where not tested.
  EXPECT_TRUE(c0.Find("score_on_accepted")->IsNull());
  EXPECT_TRUE(c0.Find("heldout_gain_on_accepted")->IsNull());
  EXPECT_EQ(j.Find("candidates")->Items()[1].Find("score_on_accepted")->AsNumber(), 12.5);
  EXPECT_EQ(j.Find("candidates")->Items()[1].Find("heldout_gain_on_accepted")->AsNumber(), 0.03);
  // A fitted candidate's own fit, whether accepted or not; null when not fitted.
  const Json& amplitude = *c0.Find("parameters")->Find("tremor.amplitude_nm");
  EXPECT_EQ(amplitude.Find("value")->AsNumber(), 0.08);
  EXPECT_EQ(amplitude.Find("ci95")->AsNumber(), 0.002);
  EXPECT_EQ(amplitude.Find("unit")->AsString(), "N*m");
  EXPECT_TRUE(j.Find("candidates")->Items()[1].Find("parameters")->IsNull());
  // The person: values with units and intervals, and what was not calibrated says so.
  const Json& k = *j.Find("person")->Find("k.wrist_flexion");
  EXPECT_EQ(k.Find("value")->AsNumber(), 1.1);
  EXPECT_EQ(k.Find("unit")->AsString(), "N*m/rad");
  EXPECT_EQ(k.Find("ci95")->AsNumber(), 0.05);
  EXPECT_EQ(k.Find("status")->AsString(), "calibrated");
  EXPECT_EQ(j.Find("person")->Find("mass.hand")->Find("status")->AsString(),
            "held at nominal: not identifiable from these data");
  // The notes on the input and on the control, as sentences.
  ASSERT_EQ(j.Find("notes")->Items().size(), 1u);
  EXPECT_EQ(j.Find("notes")->Items()[0].AsString(),
            "the person calibration stopped in a poorer minimum");
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
  EXPECT_NE(md.find("](prediction_wrist_flexion.png)"), std::string::npos);
  // The fit beside the black box, per output.
  EXPECT_NE(md.find("| q.wrist_flexion | 0.2000 | 0.1000 | 0.1500 | 0.0100 |"), std::string::npos)
      << md;
  // Candidate columns: label, joint, χ², dof, p, held-out gain, z, on top, accepted, decision.
  EXPECT_NE(md.find("| tremor@wrist_flexion | wrist_flexion | 0.0 | 0 | 1 | 0.5000 |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| 0.0200 |  |"), std::string::npos) << md;
  EXPECT_NE(md.find("| mass.hand | 1 |  | 1 | 1 | held at nominal: not identifiable from these "
                    "data |"),
            std::string::npos)
      << md;
  for (const char* plot : {"residuals", "spectrum", "prediction"}) {
    EXPECT_EQ(ReadFile(dir + "/" + plot + "_wrist_flexion.png").substr(1, 3), "PNG") << plot;
  }
  const std::string json = ReadFile(dir + "/diagnosis.json");
  EXPECT_NE(json.find("\"cause\": \"tremor\""), std::string::npos);
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
