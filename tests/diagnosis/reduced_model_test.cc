// `fesim diagnose --model NAME`: reduced models as the diagnosed simulation (reduced_model.h).
#include "diagnosis/reduced_model.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include "diagnosis/diagnose.h"
#include "diagnosis/measured.h"
#include "diagnosis/mechanisms/library.h"
#include "diagnosis/planted.h"
#include "diagnosis/report.h"
#include "sim/mechanisms.h"

namespace fesim::diagnosis {
namespace {

constexpr double kPi = 3.14159265358979323846;

Scenario Rig() {
  return LoadScenario(std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/hand_rig.yaml");
}

identification::MethodEntry Method(const std::string& name) {
  for (auto& m : ReducedModelMethods()) {
    if (m.name == name) return m;
  }
  ADD_FAILURE() << name << " is not a reduced model";
  return {};
}

/// 10 s at 100 Hz with u.ext a 0/200 µs square wave (period 2 s) and u.flex 0 then 150 µs.
Trial InputTrial() {
  Trial t;
  std::vector<double> ext, flex, q;
  for (int i = 0; i <= 1000; ++i) {
    t.time.push_back(0.01 * i);
    ext.push_back((i / 100) % 2 == 1 ? 200.0 : 0.0);
    flex.push_back(i >= 500 ? 150.0 : 0.0);
    q.push_back(0.0);
  }
  t.AddColumn("u.ext", ext);
  t.AddColumn("u.flex", flex);
  t.AddColumn("q.wrist_flexion", q);
  return t;
}

TEST(ReducedModel, OnlyInputAndOutputMechanismsAndTheHammersteinFamily) {
  EXPECT_EQ(ReducedModelMechanisms(),
            (std::vector<std::string>{"fatigue", "potentiation", "delay", "tremor", "crosstalk",
                                      "sensor_drift"}));
  std::vector<std::string> names;
  for (const auto& m : ReducedModelMethods()) names.push_back(m.name);
  EXPECT_EQ(names, (std::vector<std::string>{"spline-arx", "spline-oe", "hammerstein-mimo"}));
}

TEST(ReducedModel, AffineStateStepIsTheExactSolutionForAHeldDrive) {
  sim::FatigueParams f;
  f.enabled = true;
  f.fatigue_time_s = 20.0;
  // Full activation: dφ/dt = (φ_min − φ)/T_fat, φ(t) = φ_min + (1 − φ_min) e^{−t/T_fat}.
  double phi = 1.0;
  for (int k = 0; k < 7; ++k) {
    phi = AffineStateStep(sim::FitnessDerivative(f, 1.0, 0.0), sim::FitnessDerivative(f, 1.0, 1.0),
                          phi, 1.5);
  }
  EXPECT_NEAR(phi, f.min_fitness + (1.0 - f.min_fitness) * std::exp(-10.5 / 20.0), 1e-14);
  // Partial activation, potentiation: against a fine explicit integration of dp/dt.
  sim::PotentiationParams p;
  p.enabled = true;
  double exact = 0.2, fine = 0.2;
  const double a = 0.37, h = 0.8;
  exact = AffineStateStep(sim::PotentiationDerivative(p, a, 0.0),
                          sim::PotentiationDerivative(p, a, 1.0), exact, h);
  for (int k = 0; k < 80000; ++k) fine += 1e-5 * sim::PotentiationDerivative(p, a, fine);
  EXPECT_NEAR(exact, fine, 1e-6);
}

TEST(ReducedModel, InputMechanismsHaveTheirDocumentedForms) {
  const Scenario rig = Rig();
  const Trial in = InputTrial();
  const std::vector<std::string> inputs = {"u.ext", "u.flex"};
  const std::map<std::string, double> u_ref = {{"u.ext", 200.0}, {"u.flex", 300.0}};
  sim::ModelParams m = rig.model;
  // Everything off: the inputs unchanged.
  EXPECT_EQ(ApplyInputMechanisms(m, in, inputs, u_ref).Column("u.ext"), in.Column("u.ext"));

  // Delay 25 ms = 2.5 samples: the rise at t = 1 s appears at 1.025 s, between samples.
  m.mechanisms.electromechanical_delay_s = 0.025;
  const Trial delayed = ApplyInputMechanisms(m, in, inputs, u_ref);
  const auto& d = delayed.Column("u.ext");
  EXPECT_EQ(d[101], 0.0);           // u(0.985 s)
  EXPECT_DOUBLE_EQ(d[102], 100.0);  // u(0.995 s), between u(0.99) = 0 and u(1.00) = 200
  EXPECT_EQ(d[103], 200.0);         // u(1.005 s)
  EXPECT_EQ(d[0], 0.0);
  m.mechanisms.electromechanical_delay_s = 0.0;

  // Fatigue with ā = 1 while u.ext is on (u = u_ref), recovery while off: the gain follows the
  // exact exponentials of sim/mechanisms.h's fitness model.
  m.mechanisms.fatigue.enabled = true;
  m.mechanisms.fatigue.fatigue_time_s = 5.0;
  const Trial fatigued = ApplyInputMechanisms(m, in, inputs, u_ref);
  const auto& g = fatigued.Column("u.ext");
  const sim::FatigueParams& fp = m.mechanisms.fatigue;
  double phi = 1.0;
  for (int i = 100; i < 150; ++i) {
    phi = AffineStateStep(sim::FitnessDerivative(fp, 1.0, 0.0),
                          sim::FitnessDerivative(fp, 1.0, 1.0), phi, 0.01);
  }
  EXPECT_NEAR(g[150] / 200.0, phi, 1e-12);
  EXPECT_NEAR(phi, fp.min_fitness + (1.0 - fp.min_fitness) * std::exp(-0.5 / 5.0), 1e-12);
  EXPECT_LT(g[199], g[101]);  // falls while stimulated
  m.mechanisms.fatigue.enabled = false;

  // Crosstalk: u_c + c w u_c' with w from the pad centroids' distance, the same both ways.
  m.mechanisms.crosstalk.fraction = 0.2;
  const Trial x = ApplyInputMechanisms(m, in, inputs, u_ref);
  const double w_ext = (x.Column("u.ext")[600] - in.Column("u.ext")[600]) / 150.0;  // ext off
  const double w_flex = (x.Column("u.flex")[300] - in.Column("u.flex")[300]) / 200.0;
  EXPECT_GT(w_ext, 0.0);
  EXPECT_LE(w_ext, 0.2);
  EXPECT_NEAR(w_ext, w_flex, 1e-12);
  EXPECT_EQ(x.Column("q.wrist_flexion"), in.Column("q.wrist_flexion"));
}

TEST(ReducedModel, TremorIsTheTorqueThroughTheJointCompliance) {
  const Scenario rig = Rig();
  sim::ModelParams m = rig.model;
  Trial out = InputTrial();
  AddOutputTremor(m, &out);  // off
  EXPECT_EQ(out.Column("q.wrist_flexion"), InputTrial().Column("q.wrist_flexion"));
  const int j = sim::CoordinateIndex("wrist_flexion");
  m.mechanisms.tremor.enabled = true;
  m.mechanisms.tremor.coordinate = j;
  m.mechanisms.tremor.amplitude_nm = 0.05;
  m.mechanisms.tremor.frequency_hz = 6.0;
  AddOutputTremor(m, &out);
  for (std::size_t i = 0; i < out.size(); i += 37) {
    EXPECT_NEAR(out.Column("q.wrist_flexion")[i],
                sim::TremorTorque(m.mechanisms.tremor, out.time[i]) / JointTorqueScale(m, j),
                1e-15);
  }
}

TEST(ReducedModel, TrainingTrialsAreCutAtTheSplitWithGapsFilled) {
  DataView v;
  Trial t = InputTrial();
  auto& q = t.MutableColumn("q.wrist_flexion");
  for (std::size_t i = 0; i < q.size(); ++i) q[i] = 0.001 * static_cast<double>(i);
  q[10] = q[11] = NAN;
  q[0] = NAN;
  v.trials = {t};
  v.use = {std::vector<char>(t.size(), 0)};
  for (int i = 0; i < 700; ++i) v.use[0][i] = 1;
  v.outputs = {"q.wrist_flexion"};
  std::map<std::string, double> u_ref;
  const std::vector<Trial> tr = ReducedTrainingTrials(v, {"ext", "flex"}, &u_ref);
  ASSERT_EQ(tr.size(), 1u);
  EXPECT_EQ(tr[0].size(), 700u);
  EXPECT_EQ(tr[0].NamesWithPrefix("u."), (std::vector<std::string>{"u.ext", "u.flex"}));
  EXPECT_NEAR(tr[0].Column("q.wrist_flexion")[10], 0.010, 1e-12);  // interpolated
  EXPECT_NEAR(tr[0].Column("q.wrist_flexion")[11], 0.011, 1e-12);
  EXPECT_NEAR(tr[0].Column("q.wrist_flexion")[0], 0.001, 1e-12);  // held at the start
  EXPECT_EQ(u_ref.at("u.ext"), 200.0);
  EXPECT_EQ(u_ref.at("u.flex"), 150.0);
}

TEST(ReducedModel, TheFittedSimulatorPredictsWhatIdentifyPredicts) {
  // The same fit as `fesim identify`: spline-oe on one input, hammerstein-mimo on two.
  const Scenario rig = Rig();
  PlantedSpec spec;
  spec.trials = 2;
  spec.protocol = "grid";
  spec.seed = 21;
  const PlantedDataset data = MakePlantedDataset(rig, spec);
  const MeasuredData md = PrepareMeasured(rig.model, data.trials, 0.3);
  std::map<std::string, double> u_ref;
  std::vector<Trial> train = ReducedTrainingTrials(md.train, md.channels, &u_ref);
  DataView held = md.heldout;
  held.use = {std::vector<char>(held.trials[0].size(), 1)};
  const Trial test = ReducedTrainingTrials(held, md.channels, &u_ref)[0];
  {
    const auto method = Method("hammerstein-mimo");
    const auto fitted = method.fit_simulator(train, nullptr);
    const auto result = method.run(train, {test}, nullptr);
    const Trial pred = fitted.simulate(test);
    for (const auto& o : fitted.outputs) {
      EXPECT_EQ(pred.Column(o), result.predictions[0].Column(o)) << o;
    }
    EXPECT_EQ(fitted.model_yaml, result.model_yaml);
  }
  for (auto& t : train) {  // one input, one output
    Trial s;
    s.time = t.time;
    s.AddColumn("u.ext", t.Column("u.ext"));
    s.AddColumn("q.wrist_flexion", t.Column("q.wrist_flexion"));
    t = s;
  }
  Trial s;
  s.time = test.time;
  s.AddColumn("u.ext", test.Column("u.ext"));
  s.AddColumn("q.wrist_flexion", test.Column("q.wrist_flexion"));
  const auto method = Method("spline-oe");
  const auto fitted = method.fit_simulator(train, nullptr);
  const auto result = method.run(train, {s}, nullptr);
  EXPECT_EQ(fitted.simulate(s).Column("q.wrist_flexion"),
            result.predictions[0].Column("q.wrist_flexion"));
}

/// Measured-like data in the reduced model's own form: `truth` (a hammerstein-mimo model
/// identified on a clean full-model record, so its parameters are realistic) simulated on a
/// record's inputs with the mechanisms of `m` applied the reduced way, drift · t added to every
/// output, and white noise of 1° (the hand rig's tracker).
Trial OwnFormTrial(const identification::FittedSimulator& truth, const Trial& record,
                   const sim::ModelParams& m, const std::map<std::string, double>& u_ref,
                   double drift_rad_s, unsigned seed) {
  Trial t = ReducedSimulator(truth, u_ref)(m, record, 0.0);
  for (const auto& c : truth.inputs) t.AddColumn(c, record.Column(c));
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, kPi / 180.0);
  for (const auto& o : truth.outputs) {
    auto& y = t.MutableColumn(o);
    for (std::size_t i = 0; i < y.size(); ++i) y[i] += drift_rad_s * t.time[i] + noise(rng);
  }
  return t;
}

double Parameter(const Diagnosis& d, const std::string& name) {
  for (const auto& p : d.extension_parameters) {
    if (p.name == name) return p.value;
  }
  ADD_FAILURE() << name << " not fitted";
  return NAN;
}

TEST(ReducedModel, DiagnosisOfAReducedModelFindsWhatItsOwnFormDataLack) {
  // Three 56 s step-grid trials (paper 000's protocol), the last held out. The data are the
  // reduced model's own form plus one planted mechanism; diagnose re-identifies the reduced model
  // on the first two trials and must name the mechanism, or none on clean data.
  const Scenario rig = Rig();
  PlantedSpec spec;
  spec.trials = 3;
  spec.protocol = "grid";
  spec.seed = 11;
  const PlantedDataset clean = MakePlantedDataset(rig, spec);
  DiagnoseSettings o;
  o.model = "hammerstein-mimo";
  DiagnoseExecution e;
  e.threads = 2;
  const MeasuredData md = PrepareMeasured(rig.model, clean.trials, o.holdout_fraction);
  std::map<std::string, double> u_ref;
  const identification::FittedSimulator truth =
      Method(o.model).fit_simulator(ReducedTrainingTrials(md.train, md.channels, &u_ref), nullptr);
  std::vector<Trial> records = md.train.trials;
  records.push_back(md.heldout.trials[0]);
  const int wrist = sim::CoordinateIndex("wrist_flexion");
  const double tremor_nm = 0.03 * JointTorqueScale(rig.model, wrist);
  for (const std::string id : {"none", "tremor", "sensor_drift", "fatigue", "potentiation"}) {
    SCOPED_TRACE(id);
    sim::ModelParams m = rig.model;
    double drift = 0.0;
    if (id == "tremor") {
      m.mechanisms.tremor.enabled = true;
      m.mechanisms.tremor.coordinate = wrist;
      m.mechanisms.tremor.amplitude_nm = tremor_nm;  // 1.7° at the wrist
      m.mechanisms.tremor.frequency_hz = 6.2;
    } else if (id == "sensor_drift") {
      drift = 0.001;
    } else if (id == "fatigue") {
      m.mechanisms.fatigue.enabled = true;
      m.mechanisms.fatigue.fatigue_time_s = 20.0;
    } else if (id == "potentiation") {
      m.mechanisms.potentiation.enabled = true;
      m.mechanisms.potentiation.gain = 0.5;
    }
    std::vector<Trial> data;
    for (std::size_t k = 0; k < records.size(); ++k) {
      data.push_back(OwnFormTrial(truth, records[k], m, u_ref, drift, 5 + k));
    }
    const Diagnosis d = Diagnose(rig.model, data, o, e);
    EXPECT_EQ(d.model, "hammerstein-mimo");
    std::string why = d.reason;
    for (const auto& c : d.candidates) {
      if (c.fitted) why += "\n  " + CandidateLogLine(c) + " | " + c.decision;
    }
    EXPECT_EQ(d.cause, id) << why;
    for (const auto& c : d.candidates) {  // the hand rig's channels use the array: crosstalk too
      const auto& ok = ReducedModelMechanisms();
      const bool reducible = std::find(ok.begin(), ok.end(), c.id) != ok.end();
      EXPECT_EQ(c.applicable, reducible) << c.label;
      if (!reducible && c.id != "arm_support") {  // (no elbow output: not applicable anyway)
        EXPECT_NE(c.not_applicable_reason.find("the reduced model hammerstein-mimo does not have"),
                  std::string::npos);
      }
    }
    if (id == "none") {
      EXPECT_GT(d.confidence, 0.9);
      continue;
    }
    EXPECT_GT(d.gain, 0.05);
    if (id == "tremor") {
      EXPECT_GT(d.confidence, 0.9);
      EXPECT_NEAR(Parameter(d, "tremor@wrist_flexion:tremor.frequency_hz"), 6.2, 0.01);
      EXPECT_NEAR(Parameter(d, "tremor@wrist_flexion:tremor.amplitude_nm"), tremor_nm,
                  0.2 * tremor_nm);
    }
  }
}

}  // namespace
}  // namespace fesim::diagnosis
