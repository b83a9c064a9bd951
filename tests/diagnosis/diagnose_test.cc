// The quick slice of the diagnosis suites (bench/diagnosis_suite.cc, docs/diagnosis.md
// "Validation"): data sets from the independent simulator (foreign/) and from fesim's own model
// with wide persons, diagnosed blind. Two 40 s trials each (pseudo-random steps; the second held
// out), effects raised to the suites' floors.
#include "diagnosis/diagnose.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "diagnosis/extension.h"
#include "diagnosis/measured.h"
#include "diagnosis/noise_model.h"
#include "diagnosis/planted.h"
#include "foreign/dataset.h"
#include "scenarios/scenario.h"

namespace fesim::diagnosis {
namespace {

/// Fitted parameters must be within this relative error of the planted ones.
constexpr double kParameterRelTol = 0.3;

const Scenario& HandRig() {
  static const Scenario rig =
      LoadScenario(std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/hand_rig.yaml");
  return rig;
}

DiagnoseExecution TwoThreads() {
  DiagnoseExecution e;
  e.threads = 2;
  return e;
}

/// A foreign data set: person `seed`, two 40 s step trials, `effect` at the floor.
foreign::Dataset Foreign(std::uint64_t seed, const std::string& effect = "", double floor = 1.0) {
  foreign::DatasetSpec spec;
  spec.person_seed = seed;
  spec.seed = seed;
  spec.duration_s = 40.0;
  spec.protocols = {"steps", "steps"};
  spec.floor = floor;
  if (!effect.empty()) spec.effects = {{effect, 1.0}};
  return foreign::MakeDataset(spec);
}

/// Foreign suite data set `seed` (bench/diagnosis_suite.cc): three 60 s trials (steps, grid,
/// steps), `effect` raised to the noise RMS.
foreign::Dataset SuiteDataset(std::uint64_t seed, const std::string& effect) {
  foreign::DatasetSpec spec;
  spec.person_seed = spec.seed = seed;
  spec.effects = {{effect, 1.0}};
  return foreign::MakeDataset(spec);
}

/// An in-family data set: a wide person, two 40 s step trials, `mechanism` at `floor` × noise.
PlantedDataset Family(std::uint64_t seed, const std::string& mechanism = "", double floor = 0.5) {
  PlantedSpec spec;
  if (!mechanism.empty()) spec.mechanisms = {mechanism};
  spec.person = PersonSpread::kWide;
  spec.trials = 2;
  spec.duration_s = 40.0;
  spec.seed = seed;
  return mechanism.empty() ? MakePlantedDataset(HandRig(), spec)
                           : MakePlantedDatasetAtLeast(HandRig(), &spec, floor);
}

/// The verdict's reason and the fitted candidates' figures, for a failure message.
std::string Explain(const Diagnosis& d) {
  std::string s = d.reason + "\n";
  for (const auto& n : d.notes) s += "note: " + n + "\n";
  for (const auto& c : d.candidates) {
    if (!c.fitted) continue;
    s += c.label + ": p_adj " + std::to_string(c.p_adjusted) + ", LR p_adj " +
         std::to_string(c.lr_p_adjusted) + ", gain " + std::to_string(c.heldout_gain) +
         ", DM p_adj " + std::to_string(c.heldout_p_adjusted) + ": " + c.decision + "\n";
  }
  return s;
}

/// The planted value of `name` (NaN when not planted).
double Planted(const PlantedDataset& data, const std::string& name) {
  for (const auto& p : data.planted) {
    if (p.name == name) return p.value;
  }
  return NAN;
}

double Fitted(const Diagnosis& d, const std::string& name) {
  for (const auto& p : d.extension_parameters) {
    if (p.name == name) return p.value;
  }
  return NAN;
}

TEST(DiagnoseSettings, EveryFitChoiceChangesTheResumeCacheKey) {
  // A cached stage may be read back only by a run with the same settings (diagnose.h).
  const DiagnoseSettings base;
  std::vector<DiagnoseSettings> changed(5, base);
  changed[0].fit.simbody_right_hand_side = !base.fit.simbody_right_hand_side;
  changed[1].person.converged_stop = !base.person.converged_stop;
  changed[2].fit.hold_active_bounds = !base.fit.hold_active_bounds;
  changed[3].fit.stop_needs_predicted_decrease = !base.fit.stop_needs_predicted_decrease;
  changed[4].profile_gate = base.profile_gate + 0.5;
  std::vector<std::string> keys{base.KeyText()};
  for (const auto& c : changed) keys.push_back(c.KeyText());
  std::sort(keys.begin(), keys.end());
  EXPECT_EQ(std::unique(keys.begin(), keys.end()), keys.end());
}

TEST(DiagnoseForeign, ACleanPersonIsNoneAndTheCalibrationReachesTheBlackBox) {
  const foreign::Dataset data = Foreign(3);
  const Diagnosis d = Diagnose(HandRig().model, data.trials, {}, TwoThreads());
  EXPECT_EQ(d.cause, "none") << Explain(d);
  EXPECT_TRUE(d.mechanisms.empty());
  ASSERT_FALSE(d.reference.method.empty());
  EXPECT_LT(d.baseline_heldout_nrmse, 1.5 * d.reference.heldout_nrmse);
  // The person: calibrated values with intervals; the noise seen in the data.
  int calibrated = 0;
  for (const auto& v : d.person) {
    if (!v.fitted) continue;
    ++calibrated;
    EXPECT_TRUE(std::isfinite(v.value)) << v.name;
  }
  EXPECT_GE(calibrated, 10);
  for (double s : d.noise_rad) EXPECT_NEAR(s, 0.01, 0.002);
}

TEST(DiagnoseForeign, ATremorIsNamedOnAPersonTheModelHasNeverSeen) {
  const foreign::Dataset data = Foreign(4, "tremor");
  const Diagnosis d = Diagnose(HandRig().model, data.trials, {}, TwoThreads());
  EXPECT_EQ(d.cause, "tremor") << Explain(d);
  EXPECT_GE(d.confidence, 0.5);
  EXPECT_GT(d.gain, 0.0);
}

TEST(DiagnoseForeign, AWristTremorIsNamedAtTheWristWhereAFingerJointScoresHigher) {
  // Suite data set 1004 (three 60 s trials, a wrist tremor at 1.2 × the noise): the tremor shakes
  // the fingers too, and the MCP joint's score statistic is the larger (614 against the wrist's
  // 607). Each significant joint is fitted and the wrist's fit has the lower training Σr²
  // (14.4 against 16.2 at the MCP): the tremor is named at the wrist (Mechanism::joint_by_fit,
  // extension.h Screening).
  const foreign::Dataset data = SuiteDataset(1004, "tremor");
  const Diagnosis d = Diagnose(HandRig().model, data.trials, {}, TwoThreads());
  const auto at = [&](const std::string& label) {
    const auto it = std::find_if(d.candidates.begin(), d.candidates.end(),
                                 [&](const CandidateResult& c) { return c.label == label; });
    EXPECT_NE(it, d.candidates.end()) << label;
    return *it;
  };
  const CandidateResult wrist = at("tremor@wrist_flexion"), mcp = at("tremor@mcp_flexion");
  EXPECT_GT(mcp.score_statistic, wrist.score_statistic);  // the premise
  EXPECT_EQ(d.cause, "tremor") << Explain(d);
  EXPECT_TRUE(wrist.accepted) << Explain(d);
  EXPECT_TRUE(mcp.fitted);
  EXPECT_FALSE(mcp.accepted);
  EXPECT_NE(mcp.decision.find("chosen by the fit"), std::string::npos) << mcp.decision;
}

TEST(DiagnoseForeign, AnEffectOutsideTheLibraryIsNeverAConfidentName) {
  const foreign::Dataset data = Foreign(5, "slip");
  const Diagnosis d = Diagnose(HandRig().model, data.trials, {}, TwoThreads());
  EXPECT_TRUE(d.cause == "none" || d.cause == "unexplained" || d.confidence < 0.5)
      << d.cause << " " << d.confidence;
}

TEST(DiagnoseForeign, ACalibrationThatStallsFromNominalIsRetriedFromTheCorners) {
  // Suite data set 1017 (three 60 s trials, baseline wander at the floor). From nominal the
  // calibration stops at a posterior cost of 584 (seven steps; LM's damping grown to λ ≈ 500, the
  // linear model predicting 10⁻⁶ of the cost): the calibrated model misses the black box, and the
  // retry from the corner starts reaches 16.5, a held-out NRMSE below the black box's; the wander
  // is not credited to a candidate (docs/diagnosis.md, The person, step 3; Known limits).
  const foreign::Dataset data = SuiteDataset(1017, "wander");
  const Diagnosis d = Diagnose(HandRig().model, data.trials, {}, TwoThreads());
  EXPECT_TRUE(d.cause == "none" || d.cause == "unexplained" || d.confidence < 0.5) << Explain(d);
  const bool retried = std::any_of(d.notes.begin(), d.notes.end(), [](const std::string& n) {
    return n.find("corner starts") != std::string::npos;
  });
  EXPECT_TRUE(retried) << Explain(d);
  EXPECT_LT(d.baseline_heldout_nrmse, 0.2) << Explain(d);
  EXPECT_LT(d.baseline_heldout_nrmse, d.reference.heldout_nrmse) << Explain(d);
}

TEST(DiagnoseForeign, APersonFoundByACandidateFitBecomesTheControlAndTheTestsRunAgain) {
  // Suite data set 1006 (three 60 s trials, wrist moment arms planted posture dependent at
  // 4.8 × the noise) with the calibration cut short at 2 LM steps: it stops in a poorer minimum
  // than the person a candidate's fit (which frees the person) reaches; that person, refitted
  // alone with the candidate switched off, becomes the control, the candidates are judged against
  // it, and the note says so (extension.h, Control).
  const foreign::Dataset data = SuiteDataset(1006, "moment_arm_posture");
  DiagnoseSettings settings;
  settings.person.iterations = 2;
  const Diagnosis d = Diagnose(HandRig().model, data.trials, settings, TwoThreads());
  std::string note;
  for (const auto& n : d.notes) {
    if (n.find("poorer minimum") != std::string::npos) note = n;
  }
  ASSERT_FALSE(note.empty()) << d.baseline_heldout_nrmse << " " << Explain(d);
  // "… stopped in a poorer minimum (held-out NRMSE a) than the person refitted alone … (b)":
  // the baseline the candidates are judged against is the adopted b < a.
  const std::size_t at = note.find("held-out NRMSE ");
  ASSERT_NE(at, std::string::npos) << note;
  const double calibrated = std::stod(note.substr(at + 15));
  EXPECT_LT(d.baseline_heldout_nrmse, calibrated) << note;
}

TEST(DiagnoseForeign, ACrosstalkThePersonAbsorbsIsProfiledWhereTheModelIsWorseThanTheBlackBox) {
  // Suite data set 10010 (three 60 s trials, crosstalk at 41 × the noise): the calibrated person
  // absorbs most of it — crosstalk's score test is not significant (S 0.9) — and the calibrated
  // model predicts every output worse than the black box (held-out NRMSE 1.08–1.30 × its), yet
  // within the verdict's gate (1.5 × + 0.02). With the candidate's profile starts run where an
  // output is worse than the black box (DiagnoseSettings::profile_gate), crosstalk is fitted
  // from its profile and named; with the profile only beyond the verdict's gate it was `none`
  // (extension.h, profile starts).
  const foreign::Dataset data = SuiteDataset(10010, "crosstalk");
  const Diagnosis d = Diagnose(HandRig().model, data.trials, {}, TwoThreads());
  for (std::size_t o = 0; o < d.baseline_heldout_nrmse_per_output.size(); ++o) {  // the premise
    const double box = d.reference.heldout_nrmse_per_output[o];
    EXPECT_GT(d.baseline_heldout_nrmse_per_output[o], box) << o;
    EXPECT_LT(d.baseline_heldout_nrmse_per_output[o], 1.5 * box + 0.02) << o;
  }
  EXPECT_EQ(d.cause, "crosstalk") << Explain(d);
  EXPECT_GE(d.confidence, 0.5) << Explain(d);
  EXPECT_LT(d.extended_heldout_nrmse, d.reference.heldout_nrmse) << Explain(d);
}

TEST(DiagnoseForeign, ADriftIsJudgedOnItsOwnShareWithOneStepTimePerRecording) {
  // Suite data set 10024 (three 60 s trials, each reading drifting at its own rate, 1.8 × the
  // noise): the calibrated model's residual steps (q.mcp_flexion by 0.036 rad at 28.3 s of trial
  // 2), and with a step time searched per output a step added 2.9 × what a trend adds — the drift,
  // gaining 22 % on the held-out trial, was held as a structure outside the library
  // (`unexplained`). Judged on the residual its own fit leaves for it, with one step time for all
  // outputs of a recording, it is a trend (docs/diagnosis.md, Signature shape).
  const foreign::Dataset data = SuiteDataset(10024, "sensor_drift");
  const Diagnosis d = Diagnose(HandRig().model, data.trials, {}, TwoThreads());
  EXPECT_EQ(d.cause, "sensor_drift") << Explain(d);
  EXPECT_GE(d.confidence, 0.5) << Explain(d);
  for (const auto& c : d.candidates) {
    if (c.label == "sensor_drift") {
      EXPECT_TRUE(c.shape.empty()) << c.shape;
    }
  }
}

TEST(DiagnoseForeign, ACandidateIsCreditedOnlyWithItsOwnPartOfTheGain) {
  // Suite data set 6017 (three 60 s trials, a wrist passive stiffening at 1.1 × the noise): the
  // unequal_muscle_dynamics fit, which frees the person, gains 1.1 % on held-out data, but switched
  // off after the fit it leaves the fitted model almost as good (own part 0.2 %, not significant):
  // the gain came from the person's refit, and the candidate is neither accepted nor an
  // alternative (docs/diagnosis.md, "Extension and acceptance"). No candidate of a first round is
  // accepted without its own part.
  const foreign::Dataset data = SuiteDataset(6017, "passive_stiffness_nonlinear");
  const DiagnoseSettings settings;
  const Diagnosis d = Diagnose(HandRig().model, data.trials, settings, TwoThreads());
  EXPECT_NE(d.cause, "unequal_muscle_dynamics") << Explain(d);
  int credited_to_the_person = 0;
  for (const auto& c : d.candidates) {
    if (!c.fitted) continue;
    ASSERT_TRUE(std::isfinite(c.heldout_own_gain)) << c.label;
    const double own_p = settings.max_screened * NormalSurvival(c.heldout_own_z);
    const bool on_top = c.decision.find("on top of") != std::string::npos;
    if (!on_top && !OwnGainAccepted(c.heldout_own_gain, own_p, settings)) {
      EXPECT_FALSE(c.accepted) << c.label;
    }
    if (c.decision.find("own part of the held-out gain") != std::string::npos) {
      ++credited_to_the_person;
      EXPECT_GT(c.heldout_gain, 0.0) << c.label;
      EXPECT_LT(c.heldout_own_gain, 0.5 * c.heldout_gain) << c.label;
      EXPECT_FALSE(c.accepted) << c.label;
    }
  }
  EXPECT_GE(credited_to_the_person, 1) << Explain(d);
}

TEST(DiagnoseFamily, ACleanWidePersonIsNone) {
  const PlantedDataset data = Family(11);
  const Diagnosis d = Diagnose(HandRig().model, data.trials, {}, TwoThreads());
  EXPECT_EQ(d.cause, "none") << Explain(d);
}

TEST(DiagnoseFamily, AFatigueIsFittedWithTheWholePersonAndNamedNotADrift) {
  // Fatigue adds states the sensitivity integration lacks. Fitted with only the 6 person
  // parameters nearest its directions, this person's fatigue (seed 12, half the noise) was named
  // sensor_drift (docs/diagnosis.md, Known limits). With every person parameter free (their
  // columns by differences) it is fatigue, its rate 0.126/s for the planted 0.2/s
  // (docs/diagnosis.md, Extension and acceptance).
  const PlantedDataset data = Family(12, "fatigue");
  const Diagnosis d = Diagnose(HandRig().model, data.trials, {}, TwoThreads());
  EXPECT_EQ(d.cause, "fatigue") << Explain(d);
  const std::string k = "fatigue:fatigue.rate_per_s";
  EXPECT_NEAR(Fitted(d, k), Planted(data, k), 0.5 * Planted(data, k)) << Explain(d);
}

TEST(DiagnoseFamily, ADelayAtHalfTheNoiseIsNamedWithItsLength) {
  const PlantedDataset data = Family(12, "delay");
  const Diagnosis d = Diagnose(HandRig().model, data.trials, {}, TwoThreads());
  EXPECT_EQ(d.cause, "delay") << Explain(d);
  const std::string k = "delay:delay.s";
  EXPECT_NEAR(Fitted(d, k), Planted(data, k), kParameterRelTol * Planted(data, k));
}

TEST(Diagnose, AModelThatCannotReachTheBlackBoxIsUnexplainedWithTheReason) {
  // The stimulation reaches the other muscle group than the rig says (the two channels' columns
  // swapped in the record): no person calibration turns extensors into flexors, a black box
  // maps the inputs to the outputs all the same.
  PlantedDataset data = Family(13);
  for (auto& t : data.trials) {
    std::swap(t.MutableColumn("u.ext"), t.MutableColumn("u.flex"));
  }
  const Diagnosis d = Diagnose(HandRig().model, data.trials, {}, TwoThreads());
  EXPECT_EQ(d.cause, "unexplained");
  EXPECT_GE(d.confidence, 0.5);
  EXPECT_NE(d.reason.find("does not reach a black-box fit"), std::string::npos) << d.reason;
  EXPECT_NE(d.reason.find("q.wrist_flexion"), std::string::npos) << d.reason;
  EXPECT_NE(d.reason.find(d.reference.method), std::string::npos) << d.reason;
}

TEST(Diagnose, RejectsAnOutputThatIsNotFreeAndSplitsOneTrialInTime) {
  Trial t;
  for (int i = 0; i < 200; ++i) t.time.push_back(i / 50.0);
  t.AddColumn("u.ext", std::vector<double>(200, 100.0));
  t.AddColumn("q.elbow_flexion", std::vector<double>(200, 1.5));
  t.metadata["source"] = "m.csv";
  try {
    Diagnose(HandRig().model, {t}, {});
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
  SplitTrials({t, t, t, t}, {"q.elbow_flexion"}, 0.3, &train, &held, &how, 2);
  EXPECT_EQ(train.trials.size(), 2u);
  EXPECT_EQ(held.trials.size(), 2u);
  EXPECT_EQ(how, "trials 0-1 train, trials 2-3 (the last 2) held out whole");
  EXPECT_THROW(SplitTrials({t, t}, {"q.elbow_flexion"}, 0.3, &train, &held, &how, 2),
               std::invalid_argument);
  DiagnoseSettings bad;
  bad.max_fitted = 0;
  EXPECT_THROW(Diagnose(HandRig().model, {t}, bad), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::diagnosis
