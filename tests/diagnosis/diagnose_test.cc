// The quick slice of the planted-effect suite (issue 7): datasets from the ground-truth simulator
// with a participant unlike the rig's nominal one, one 40 s trial each (blocked held-out
// segment: the last 30 %), a mechanism planted at effect scale 1.5 (effect RMS of the order of
// the 1° sensor noise, diagnosis/planted.h), and the diagnosis run blind. The full suite with the
// rates is bench/diagnosis_suite.cc → docs/diagnosis.md.
#include "diagnosis/diagnose.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>

#include "diagnosis/planted.h"

namespace fesim::diagnosis {
namespace {

/// Fitted parameters must be within this relative error of the planted ones (issue 7: 20 %).
constexpr double kParameterRelTol = 0.2;

const Scenario& Rig() {
  static const Scenario rig =
      LoadScenario(std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/hand_rig.yaml");
  return rig;
}

struct Case {
  PlantedDataset data;
  Diagnosis result;
};

/// The elbow rig of the arm_support cases (elbow free against gravity, bic/tri pairs).
const Scenario& ElbowRig() {
  static const Scenario rig =
      LoadScenario(std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/elbow_support_rig.yaml");
  return rig;
}

PlantedSpec Spec(const std::vector<std::string>& mechanisms, std::uint64_t seed,
                 const std::string& protocol) {
  PlantedSpec spec;
  spec.mechanisms = mechanisms;
  spec.effect_scale = 1.5;
  spec.trials = 1;
  spec.duration_s = 40.0;
  spec.protocol = protocol;
  spec.seed = seed;
  return spec;
}

/// An elbow-rig data set: bic/tri steps up to 240 µs (elbow ≈ 35–130°), effect scale 1.
PlantedSpec ElbowSpec(const std::vector<std::string>& mechanisms, std::uint64_t seed) {
  PlantedSpec spec = Spec(mechanisms, seed, "steps");
  spec.effect_scale = 1.0;
  spec.channels = {"bic", "tri"};
  spec.max_us = 240.0;
  return spec;
}

/// A default-suite data set (bench/diagnosis_suite.cc): three 60 s trials on the hand rig.
PlantedSpec SuiteSpec(const std::string& mechanism, double scale, const std::string& protocol,
                      std::uint64_t seed) {
  PlantedSpec spec;
  spec.mechanisms = {mechanism};
  spec.effect_scale = scale;
  spec.protocol = protocol;
  spec.seed = seed;
  return spec;
}

Case DiagnosedOn(const Scenario& rig, const PlantedSpec& spec, DiagnoseOptions o = {}) {
  Case r;
  r.data = MakePlantedDataset(rig, spec);
  o.fit.threads = 2;
  r.result = Diagnose(rig.model, r.data.trials, o);
  return r;
}

Case Diagnosed(const std::vector<std::string>& mechanisms, std::uint64_t seed,
               const std::string& protocol = "steps") {
  return DiagnosedOn(Rig(), Spec(mechanisms, seed, protocol));
}

void ExpectFound(const Case& r, const std::string& id) {
  EXPECT_EQ(r.result.cause, id);
  EXPECT_GT(r.result.gain, 0.0);
  EXPECT_LT(r.result.extended_heldout_nrmse, r.result.baseline_heldout_nrmse);
}

double Fitted(const Case& r, const std::string& name) {
  for (const auto& p : r.result.extension_parameters) {
    if (p.name == name) return p.value;
  }
  return NAN;
}

double Planted(const Case& r, const std::string& name) {
  for (const auto& p : r.data.planted) {
    if (p.name == name) return p.value;
  }
  return NAN;
}

TEST(DiagnosePlanted, CleanDataGiveNone) {
  for (std::uint64_t seed : {11u, 12u}) {
    const Case r = Diagnosed({}, seed, seed % 2 ? "steps" : "grid");
    EXPECT_EQ(r.result.cause, "none") << "seed " << seed;
    EXPECT_TRUE(r.result.mechanisms.empty());
    EXPECT_EQ(r.result.gain, 0.0);
    // The calibration found the participant's stiffness (all joints scaled alike).
    EXPECT_NEAR(r.result.subject_parameters[0].value, 0.8 * r.data.stiffness_scale,
                0.05 * 0.8 * r.data.stiffness_scale);
  }
}

TEST(DiagnosePlanted, TremorIsNamedWithItsAmplitudeAndFrequency) {
  const Case r = Diagnosed({"tremor"}, 21);
  ExpectFound(r, "tremor");
  const std::string a = "tremor@wrist_flexion:tremor.amplitude_nm";
  const std::string f = "tremor@wrist_flexion:tremor.frequency_hz";
  EXPECT_NEAR(Fitted(r, a), Planted(r, a), kParameterRelTol * Planted(r, a));
  EXPECT_NEAR(Fitted(r, f), Planted(r, f), 0.01);
}

TEST(DiagnosePlanted, FatigueIsNamedOnLaterHeldOutDataWithItsRate) {
  const Case r = Diagnosed({"fatigue"}, 22);
  ExpectFound(r, "fatigue");
  const std::string k = "fatigue:fatigue.rate_per_s";
  EXPECT_NEAR(Fitted(r, k), Planted(r, k), kParameterRelTol * Planted(r, k));
}

TEST(DiagnosePlanted, FurtherCandidatesAreFittedInBatchesWhileNoneOfTheFittedPasses) {
  // One candidate per batch: the significant candidates (one joint per id) are fitted in the
  // order of their score statistic until one passes both tests, and no further.
  DiagnoseOptions o;
  o.max_fitted = 1;
  o.max_screened = 6;
  const Case r = DiagnosedOn(Rig(), Spec({"crosstalk"}, 28, "steps"), o);
  std::vector<const CandidateResult*> ranked;
  std::set<std::string> ids;
  for (const auto& cr : r.result.candidates) {
    if (cr.applicable && cr.p_adjusted < o.alpha) ranked.push_back(&cr);
  }
  std::stable_sort(ranked.begin(), ranked.end(), [](const auto* a, const auto* b) {
    return a->score_statistic > b->score_statistic;
  });
  std::vector<const CandidateResult*> unique;
  for (const auto* cr : ranked) {
    if (ids.insert(cr->id).second) unique.push_back(cr);
  }
  const auto passes = [&](const CandidateResult& cr) {
    return cr.fitted && cr.lr_p_adjusted < o.alpha && cr.heldout_gain > o.min_heldout_gain;
  };
  std::size_t first_pass = unique.size();
  for (std::size_t k = 0; k < unique.size(); ++k) {
    if (passes(*unique[k])) {
      first_pass = k;
      break;
    }
  }
  ASSERT_LT(first_pass, unique.size()) << "nothing passed";
  std::size_t fitted = 0;
  for (const auto& cr : r.result.candidates) fitted += cr.fitted ? 1 : 0;
  EXPECT_EQ(fitted, first_pass + 1);
  for (std::size_t k = 0; k <= first_pass; ++k) EXPECT_TRUE(unique[k]->fitted) << unique[k]->label;
  // This dataset's best-scoring candidate is not the planted one and fails: a second batch ran.
  EXPECT_GE(first_pass, 1u) << unique[0]->label;
  ExpectFound(r, "crosstalk");
}

TEST(DiagnosePlanted, GridCrosstalkIsFoundInAFurtherBatchWhileTheFirstPassLeavesStructure) {
  // Default-suite dataset 1048 (three 60 s grid trials, crosstalk at scale 1.5): crosstalk ranks
  // 4th by score; moment_arm_posture@wrist passes in the first batch but leaves the held-out
  // residual structured. Without batches_while_structured it is the (wrong) name; with it the
  // second batch fits crosstalk, whose held-out gain is larger (docs/diagnosis.md, session 10).
  const PlantedSpec spec = SuiteSpec("crosstalk", 1.5, "grid", 1048);
  DiagnoseOptions first_pass_only;
  first_pass_only.batches_while_structured = false;
  const Case stop = DiagnosedOn(Rig(), spec, first_pass_only);
  EXPECT_EQ(stop.result.cause, "moment_arm_posture");
  EXPECT_LE(stop.result.confidence, 0.4);  // structure left: never a confident wrong name
  const Case r = DiagnosedOn(Rig(), spec);
  ExpectFound(r, "crosstalk");
  const std::string k = "crosstalk:crosstalk.fraction";
  EXPECT_NEAR(Fitted(r, k), Planted(r, k), kParameterRelTol * Planted(r, k));
}

TEST(DiagnosePlanted, CrosstalkIsNamedWithItsFraction) {
  // The baseline takes most of the crosstalk into strength_scale and the input scales; only a
  // fit that re-optimises them (profiled screening, diagnose.h) finds the rest.
  const Case r = Diagnosed({"crosstalk"}, 28);
  ExpectFound(r, "crosstalk");
  const std::string k = "crosstalk:crosstalk.fraction";
  EXPECT_NEAR(Fitted(r, k), Planted(r, k), kParameterRelTol * Planted(r, k));
}

TEST(DiagnosePlanted, ArmSupportIsNamedWithItsForceOnTheElbowRig) {
  const Case r = DiagnosedOn(ElbowRig(), ElbowSpec({"arm_support"}, 5));
  ExpectFound(r, "arm_support");
  const std::string k = "arm_support:support.weight_compensation_n";
  EXPECT_NEAR(Fitted(r, k), Planted(r, k), kParameterRelTol * Planted(r, k));
}

TEST(DiagnosePlanted, CleanElbowRigWithIrregularSamplingGivesNone) {
  // A jittery logger: every 4th time stamp 0.2 ms late and every 50th row lost. The record is
  // resampled to its median step (10 ms), not rejected, and nothing is named.
  PlantedDataset data = MakePlantedDataset(ElbowRig(), ElbowSpec({}, 6));
  Trial& t = data.trials[0];
  Trial irregular;
  irregular.metadata = t.metadata;
  std::vector<std::vector<double>> cols(t.names.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (i % 50 == 25) continue;
    irregular.time.push_back(t.time[i] + (i % 4 == 1 ? 2e-4 : 0.0));
    for (std::size_t c = 0; c < t.names.size(); ++c) cols[c].push_back(t.columns[c][i]);
  }
  for (std::size_t c = 0; c < t.names.size(); ++c) irregular.AddColumn(t.names[c], cols[c]);
  DiagnoseOptions o;
  o.fit.threads = 2;
  const Diagnosis d = Diagnose(ElbowRig().model, {irregular}, o);
  EXPECT_EQ(d.cause, "none");
  ASSERT_EQ(d.notes.size(), 1u);
  EXPECT_NE(d.notes[0].find("resampled"), std::string::npos) << d.notes[0];
}

TEST(Diagnose, ResampleToUniformInterpolatesOutputsKeepsGapsAndHoldsInputs) {
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

TEST(DiagnosePlanted, SensorDriftIsNamed) {
  const Case r = Diagnosed({"sensor_drift"}, 23);
  ExpectFound(r, "sensor_drift");
  EXPECT_GT(r.result.confidence, 0.5);
  const std::string k = "sensor_drift:drift.q.wrist_flexion";
  EXPECT_NEAR(Fitted(r, k), Planted(r, k), kParameterRelTol * Planted(r, k));
}

TEST(DiagnosePlanted, StictionIsNamed) {
  const Case r = Diagnosed({"stiction"}, 24);
  ExpectFound(r, "stiction");
  ASSERT_FALSE(r.result.mechanisms.empty());
  EXPECT_EQ(r.result.mechanisms[0], "stiction@wrist_flexion");
}

TEST(DiagnosePlanted, StictionStaticExcessIsFoundFromAScannedStartOfTheRefit) {
  // Default-suite dataset 1104 (three 60 s grid trials, stiction at scale 1): the fits at the
  // default difference step stopped with F_s − F_c 40 % low (0.0237 N·m for 0.0396) while the
  // Coulomb level was within 10 %. The refit from the scanned static excess × 1.5 (its Σr² 0.8 %
  // above the fit's) ends within 6 % (Candidate::refit_scan_*, docs/diagnosis.md, session 11).
  const Case r = DiagnosedOn(Rig(), SuiteSpec("stiction", 1.0, "grid", 1104));
  ExpectFound(r, "stiction");
  for (const std::string k : {"stiction@wrist_flexion:friction.coulomb_nm",
                              "stiction@wrist_flexion:friction.static_excess_nm"}) {
    EXPECT_NEAR(Fitted(r, k), Planted(r, k), kParameterRelTol * Planted(r, k)) << k;
  }
}

TEST(DiagnosePlanted, DelayIsNamed) {
  const Case r = Diagnosed({"delay"}, 25);
  ExpectFound(r, "delay");
  const std::string k = "delay:delay.s";
  EXPECT_NEAR(Fitted(r, k), Planted(r, k), kParameterRelTol * Planted(r, k));
}

TEST(DiagnosePlanted, PassiveStiffnessNonlinearIsNamedOnTheGridWithItsSharpness) {
  // One grid trial: its first 70 % (training) keeps the wrist within −23…24°, the held-out tail
  // flexes it to 54°. The planted limit stiffening (κ = 5/rad) must already show in training
  // (with κ = 8/rad it did not: score χ² 5.7, verdict "unexplained"). K_L (the stiffness at the
  // 80° limit) is an extrapolation from these postures and is not checked; κ is.
  const Case r = Diagnosed({"passive_stiffness_nonlinear"}, 1002, "grid");
  ExpectFound(r, "passive_stiffness_nonlinear");
  ASSERT_FALSE(r.result.mechanisms.empty());
  EXPECT_EQ(r.result.mechanisms[0], "passive_stiffness_nonlinear@wrist_flexion");
  const std::string k = "passive_stiffness_nonlinear@wrist_flexion:passive.sharpness_per_rad";
  EXPECT_NEAR(Fitted(r, k), Planted(r, k), kParameterRelTol * Planted(r, k));
}

TEST(DiagnosePlanted, TwoMechanismsAtOnceAreBothNamed) {
  const Case r = Diagnosed({"tremor", "sensor_drift"}, 26);
  ASSERT_EQ(r.result.mechanism_ids.size(), 2u);
  EXPECT_TRUE(
      (r.result.mechanism_ids[0] == "tremor" && r.result.mechanism_ids[1] == "sensor_drift") ||
      (r.result.mechanism_ids[0] == "sensor_drift" && r.result.mechanism_ids[1] == "tremor"));
}

TEST(DiagnosePlanted, ASecondMechanismThatTheFirstPartlyAbsorbsIsFoundOnTopOfIt) {
  // fatigue + sensor_drift on the grid (the suite's pair 10 of seed 1000, docs/diagnosis.md):
  // fatigue is accepted first and its rate takes up part of the drift (0.41/s for 0.30/s);
  // sensor_drift passed on its own, but the earlier second round fitted it with the subject
  // parameters and fatigue frozen, gained nothing over the extended model and named fatigue
  // alone. Profiled on top of the extended model, both are named and fatigue's rate returns.
  const Case r = Diagnosed({"fatigue", "sensor_drift"}, 1010, "grid");
  ASSERT_EQ(r.result.mechanism_ids.size(), 2u);
  const std::set<std::string> ids(r.result.mechanism_ids.begin(), r.result.mechanism_ids.end());
  EXPECT_EQ(ids, (std::set<std::string>{"fatigue", "sensor_drift"}));
  EXPECT_GT(r.result.gain, 0.0);
  const std::string k = "fatigue:fatigue.rate_per_s";
  EXPECT_NEAR(Fitted(r, k), Planted(r, k), kParameterRelTol * Planted(r, k));
  const std::string d = "sensor_drift:drift.q.wrist_flexion";
  EXPECT_NEAR(Fitted(r, d), Planted(r, d), kParameterRelTol * Planted(r, d));
}

TEST(DiagnosePlanted, AnEffectOutsideTheLibraryIsNeverAConfidentWrongName) {
  const Case r = Diagnosed({"outside"}, 27);
  EXPECT_TRUE(r.result.cause == "unexplained" || r.result.confidence < 0.5)
      << r.result.cause << " " << r.result.confidence;
}

TEST(Diagnose, RejectsAnOutputThatIsNotFreeAndSplitsOneTrialInTime) {
  Trial t;
  for (int i = 0; i < 200; ++i) t.time.push_back(i / 50.0);
  t.AddColumn("u.ext", std::vector<double>(200, 100.0));
  t.AddColumn("q.elbow_flexion", std::vector<double>(200, 1.5));
  t.metadata["source"] = "m.csv";
  try {
    Diagnose(Rig().model, {t}, DiagnoseOptions());
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "m.csv: column q.elbow_flexion: joint is not free in the scenario (locked or "
              "prescribed)");
  }
  DataView train, held;
  std::string how;
  SplitTrials({t}, {"q.elbow_flexion"}, 0.3, &train, &held, &how);
  ASSERT_EQ(train.trials.size(), 1u);
  EXPECT_LT(train.trials[0].time.back(), 0.7 * t.time.back() + 1e-9);
  int held_count = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (held.use[0][i]) {
      ++held_count;
      EXPECT_GE(t.time[i], train.trials[0].time.back());  // held-out data later than the fit
    }
  }
  EXPECT_EQ(held_count + static_cast<int>(train.trials[0].size()), 200);
  SplitTrials({t, t, t}, {"q.elbow_flexion"}, 0.3, &train, &held, &how);
  EXPECT_EQ(train.trials.size(), 2u);
  EXPECT_EQ(held.trials.size(), 1u);
}

}  // namespace
}  // namespace fesim::diagnosis
