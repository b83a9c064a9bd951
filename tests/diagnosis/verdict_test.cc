#include "diagnosis/verdict.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "diagnosis/mechanisms/mechanism.h"
#include "identification/fullmodel/full_model_fit.h"

namespace fesim::diagnosis {
namespace {

/// The hand rig's library, a diagnosis whose model reaches the black box before and after the
/// extension, and the candidates' results as diagnose.cc lays them out (library order).
struct VerdictCase {
  std::vector<Candidate> library;
  Diagnosis d;
  DiagnoseSettings settings;

  VerdictCase() {
    LibraryContext ctx;
    ctx.outputs = {"q.wrist_flexion", "q.mcp_flexion", "q.pip_flexion"};
    ctx.channels = {"ext", "flex"};
    ctx.tremor_frequency_hz = {6.0, 6.0, 6.0};
    library = CandidateLibrary(identification::fullmodel::DefaultHandRig(), ctx);
    d.heldout.outputs = ctx.outputs;
    d.reference.method = "hammerstein-mimo";
    d.reference.heldout_nrmse_per_output = {0.3, 0.3, 0.3};
    d.baseline_heldout_nrmse = 0.2;
    d.baseline_heldout_nrmse_per_output = {0.2, 0.2, 0.2};
    d.extended_heldout_nrmse_per_output = {0.15, 0.15, 0.15};
    for (const auto& c : library) {
      CandidateResult cr;
      cr.id = c.id;
      cr.label = c.label;
      cr.control = c.control;
      d.candidates.push_back(cr);
    }
  }

  int Index(const std::string& label) const {
    for (std::size_t c = 0; c < library.size(); ++c) {
      if (library[c].label == label) return static_cast<int>(c);
    }
    ADD_FAILURE() << label;
    return -1;
  }

  /// Marks `label` fitted with a passing training test and held-out gain `gain`.
  void Fitted(const std::string& label, double gain, bool accepted) {
    CandidateResult& cr = d.candidates[Index(label)];
    cr.fitted = true;
    cr.lr_p_adjusted = 1e-6;
    cr.heldout_gain = gain;
    cr.accepted = accepted;
  }

  ExtensionOutcome Outcome(const std::vector<std::string>& accepted, int cause) const {
    ExtensionOutcome e;
    int params = 0;
    for (const auto& label : accepted) {
      e.accepted.push_back(Index(label));
      params += static_cast<int>(library[Index(label)].params.size());
    }
    e.cause = cause;
    e.fit.x = Eigen::VectorXd::Constant(params, 0.5);
    e.fit.ci95 = Eigen::VectorXd::Constant(params, 0.1);
    e.on_top_reference.assign(library.size(), NAN);
    return e;
  }
};

TEST(Verdict, AMisfitOnlyAControlExplainsIsNoneWithTheControlNamedInTheReason) {
  VerdictCase s;
  s.Fitted("passive_asymmetry@wrist_flexion", 0.12, true);
  s.Fitted("spasticity@wrist_flexion", 0.05, false);
  const ExtensionOutcome e = s.Outcome({"passive_asymmetry@wrist_flexion"}, -1);
  s.d.gain = 0.25;
  MakeVerdict(s.library, e, 0, s.settings, &s.d);
  EXPECT_EQ(s.d.cause, "none");
  EXPECT_NE(s.d.reason.find("25.0 %"), std::string::npos) << s.d.reason;
  EXPECT_NE(s.d.reason.find("passive_asymmetry@wrist_flexion"), std::string::npos) << s.d.reason;
  EXPECT_TRUE(s.d.mechanisms.empty());
  ASSERT_EQ(s.d.extension_parameters.size(), 1u);
  EXPECT_EQ(s.d.extension_parameters[0].name, "passive_asymmetry@wrist_flexion:passive.asymmetry");
}

// docs/diagnosis.md, Extension and acceptance (the person-at-bound condition): a candidate kept
// out because the person's parameters of its joint ended at a bound leaves `none`, and the reason
// names it, its gain and those parameters (clean foreign 7006: moment_arm_posture@pip, 44 %).
TEST(Verdict, NoneNamesTheCandidateThePersonAtABoundKeptOut) {
  VerdictCase s;
  s.Fitted("moment_arm_posture@pip_flexion", 0.44, false);
  s.d.candidates[s.Index("moment_arm_posture@pip_flexion")].person_at_bound =
      "arm.ext.finger@pip_flexion";
  s.Fitted("passive_stiffness_nonlinear@pip_flexion", 0.05, false);
  s.d.candidates[s.Index("passive_stiffness_nonlinear@pip_flexion")].person_at_bound =
      "k3.pip_flexion";
  s.d.baseline_heldout_nrmse_per_output = s.d.extended_heldout_nrmse_per_output;
  MakeVerdict(s.library, s.Outcome({}, -1), 0, s.settings, &s.d);
  EXPECT_EQ(s.d.cause, "none");
  EXPECT_NE(s.d.reason.find("moment_arm_posture@pip_flexion gains 44.0 %"), std::string::npos)
      << s.d.reason;
  EXPECT_NE(s.d.reason.find("arm.ext.finger@pip_flexion"), std::string::npos) << s.d.reason;
  EXPECT_EQ(s.d.reason.find("k3.pip_flexion"), std::string::npos) << s.d.reason;  // the largest
  // Without one: the plain reason.
  VerdictCase t;
  t.Fitted("moment_arm_posture@pip_flexion", 0.01, false);
  t.d.baseline_heldout_nrmse_per_output = t.d.extended_heldout_nrmse_per_output;
  MakeVerdict(t.library, t.Outcome({}, -1), 0, t.settings, &t.d);
  EXPECT_EQ(t.d.cause, "none");
  EXPECT_EQ(t.d.reason.find("not named"), std::string::npos) << t.d.reason;
}

// docs/diagnosis.md, Extension and acceptance: a tremor's joints not chosen by the fit are
// reported but not judged, so they are no alternative to the cause — foreign 8018 (fatigue, a
// wrist tremor on top) would otherwise have its fatigue's confidence cut by the MCP tremor's gain.
TEST(Verdict, AJointNotChosenByTheFitIsNoAlternativeToTheCause) {
  const auto verdict = [](bool not_judged) {
    VerdictCase s;
    s.Fitted("fatigue", 0.20, true);
    s.Fitted("tremor@wrist_flexion", 0.15, true);
    s.Fitted("tremor@mcp_flexion", 0.15, false);
    s.d.candidates[s.Index("tremor@mcp_flexion")].not_judged = not_judged;
    ExtensionOutcome e = s.Outcome({"fatigue", "tremor@wrist_flexion"}, s.Index("fatigue"));
    e.cause_lr_p = 1e-6;
    e.cause_gain = 0.20;
    MakeVerdict(s.library, e, 0, s.settings, &s.d);
    return s.d;
  };
  const Diagnosis not_chosen = verdict(true);
  EXPECT_EQ(not_chosen.cause, "fatigue") << not_chosen.reason;
  EXPECT_GT(not_chosen.confidence, 0.99);
  // Judged, the same fit is an alternative: (1 − 0.15 / 0.20) leaves fatigue at 0.25, no single
  // cause.
  const Diagnosis judged = verdict(false);
  EXPECT_EQ(judged.cause, "unexplained") << judged.reason;
}

TEST(Verdict, AMechanismBeyondAControlIsNamedAndAControlAsGoodAsTheMechanismMakesItNone) {
  VerdictCase s;
  // A mechanism accepted on top of a control: named, the control's parameters kept.
  s.Fitted("passive_asymmetry@wrist_flexion", 0.12, true);
  s.Fitted("tremor@wrist_flexion", 0.30, true);
  ExtensionOutcome e = s.Outcome({"passive_asymmetry@wrist_flexion", "tremor@wrist_flexion"},
                                 s.Index("tremor@wrist_flexion"));
  e.cause_lr_p = 1e-6;
  e.cause_gain = 0.30;
  MakeVerdict(s.library, e, 0, s.settings, &s.d);
  EXPECT_EQ(s.d.cause, "tremor");
  EXPECT_EQ(s.d.mechanisms, std::vector<std::string>{"tremor@wrist_flexion"});
  EXPECT_GT(s.d.extension_parameters.size(), 1u);

  // A mechanism accepted alone while a control not accepted explains as much: none.
  VerdictCase t;
  t.Fitted("spasticity@wrist_flexion", 0.050, true);
  t.Fitted("passive_asymmetry@wrist_flexion", 0.049, false);
  e = t.Outcome({"spasticity@wrist_flexion"}, t.Index("spasticity@wrist_flexion"));
  e.cause_lr_p = 1e-6;
  e.cause_gain = 0.050;
  MakeVerdict(t.library, e, 0, t.settings, &t.d);
  EXPECT_EQ(t.d.cause, "none") << t.d.reason;
  EXPECT_NE(t.d.reason.find("normal variation"), std::string::npos) << t.d.reason;

  // … and when the other candidate is a mechanism, `unexplained`.
  VerdictCase u;
  u.Fitted("spasticity@wrist_flexion", 0.050, true);
  u.Fitted("stiction@wrist_flexion", 0.049, false);
  MakeVerdict(u.library, e, 0, u.settings, &u.d);
  EXPECT_EQ(u.d.cause, "unexplained") << u.d.reason;

  // Two mechanisms that each gain under min_heldout_gain on a model within the black-box gate:
  // a normal person's small misfit they share, `none` (docs/diagnosis.md, Verdict).
  VerdictCase v;
  v.Fitted("passive_stiffness_nonlinear@wrist_flexion", 0.010, true);
  v.Fitted("moment_arm_posture@pip_flexion", 0.008, false);
  ExtensionOutcome small = v.Outcome({"passive_stiffness_nonlinear@wrist_flexion"},
                                     v.Index("passive_stiffness_nonlinear@wrist_flexion"));
  small.cause_lr_p = 1e-6;
  small.cause_gain = 0.010;
  MakeVerdict(v.library, small, 0, v.settings, &v.d);
  EXPECT_EQ(v.d.cause, "none") << v.d.reason;
  EXPECT_NE(v.d.reason.find("moment_arm_posture@pip_flexion: 0.8 %"), std::string::npos)
      << v.d.reason;
  // The same gains on a model that misses the black box: `unexplained`.
  VerdictCase w;
  w.Fitted("passive_stiffness_nonlinear@wrist_flexion", 0.010, true);
  w.Fitted("moment_arm_posture@pip_flexion", 0.008, false);
  w.d.baseline_heldout_nrmse_per_output = {0.2, 0.9, 0.2};
  MakeVerdict(w.library, small, 0, w.settings, &w.d);
  EXPECT_EQ(w.d.cause, "unexplained") << w.d.reason;
}

// A sensor offset that steps once (a glove slip, outside the library) fits as a drift and gains
// on the held-out data; its shape contradicts the drift (mechanisms/sensor_drift.cc), so the
// verdict names the structure, not `none` and not the drift.
TEST(Verdict, AFitThatGainsButWhoseSignatureTheResidualContradictsIsUnexplainedWithTheShape) {
  VerdictCase s;
  s.Fitted("passive_asymmetry@pip_flexion", 0.04, true);
  s.Fitted("sensor_drift", 0.17, false);
  s.d.candidates[s.Index("sensor_drift")].shape =
      "the offset steps rather than drifts (q.pip_flexion steps by -0.052 rad at 30.1 s)";
  const ExtensionOutcome e = s.Outcome({"passive_asymmetry@pip_flexion"}, -1);
  MakeVerdict(s.library, e, 0, s.settings, &s.d);
  EXPECT_EQ(s.d.cause, "unexplained");
  EXPECT_DOUBLE_EQ(s.d.confidence, 1.0);
  EXPECT_NE(s.d.reason.find("17.0 %"), std::string::npos) << s.d.reason;
  EXPECT_NE(s.d.reason.find("steps by -0.052 rad at 30.1 s"), std::string::npos) << s.d.reason;
  EXPECT_TRUE(s.d.mechanisms.empty());
  // A contradicted fit that does not gain on the held-out data is no structure: `none`.
  VerdictCase weak;
  weak.Fitted("passive_asymmetry@pip_flexion", 0.04, true);
  weak.Fitted("sensor_drift", 0.01, false);
  weak.d.candidates[weak.Index("sensor_drift")].shape = "the offset steps rather than drifts";
  MakeVerdict(weak.library, weak.Outcome({"passive_asymmetry@pip_flexion"}, -1), 0, weak.settings,
              &weak.d);
  EXPECT_EQ(weak.d.cause, "none");
}

// A mechanism accepted beside a contradicted fit that gains more (foreign glove slip 1018:
// moment_arm_posture@pip 1.4 %, the slip as a drift 10.5 %, its score test on top of the
// mechanism no longer significant, so no alternative): named at most at 0.45, the reason naming
// the larger structure; a contradicted fit that gains less leaves the confidence as it is.
TEST(Verdict, ACauseBesideALargerStructureOutsideTheLibraryIsNotConfident) {
  const auto verdict = [](double cause_gain, double drift_gain) {
    VerdictCase s;
    s.Fitted("moment_arm_posture@pip_flexion", cause_gain, true);
    s.Fitted("sensor_drift", drift_gain, false);
    CandidateResult& drift = s.d.candidates[s.Index("sensor_drift")];
    drift.shape =
        "the offset steps rather than drifts (q.pip_flexion steps by -0.054 rad at 30.1 s)";
    drift.score_on_accepted = 0.5;
    ExtensionOutcome e =
        s.Outcome({"moment_arm_posture@pip_flexion"}, s.Index("moment_arm_posture@pip_flexion"));
    e.cause_lr_p = 1e-6;
    e.cause_gain = cause_gain;
    MakeVerdict(s.library, e, 0, s.settings, &s.d);
    return s.d;
  };
  const Diagnosis larger = verdict(0.014, 0.105);
  EXPECT_EQ(larger.cause, "moment_arm_posture") << larger.reason;
  EXPECT_LE(larger.confidence, 0.45);
  EXPECT_NE(larger.reason.find("would gain 10.5 % on the held-out data (this cause 1.4 %)"),
            std::string::npos)
      << larger.reason;
  EXPECT_NE(larger.reason.find("steps by -0.054 rad"), std::string::npos) << larger.reason;
  const Diagnosis smaller = verdict(0.05, 0.03);
  EXPECT_EQ(smaller.cause, "moment_arm_posture") << smaller.reason;
  EXPECT_GT(smaller.confidence, 0.99) << smaller.reason;
  EXPECT_EQ(smaller.reason.find("larger structure"), std::string::npos) << smaller.reason;
}

}  // namespace
}  // namespace fesim::diagnosis
