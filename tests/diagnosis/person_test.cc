// Person calibration (diagnosis/person.h): the parameters a rig offers, their setters, the noise
// estimate, and a calibration that recovers a planted person and holds what the data do not see.
#include "diagnosis/person.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <set>

#include "diagnosis/mechanisms/library.h"
#include "identification/fullmodel/full_model_fit.h"
#include "tendons/tendon_network.h"

namespace fesim::diagnosis {
namespace {

LibraryContext HandContext(std::vector<std::string> channels = {"ext", "flex"}) {
  LibraryContext ctx;
  ctx.outputs = {"q.wrist_flexion", "q.mcp_flexion", "q.pip_flexion"};
  ctx.channels = std::move(channels);
  return ctx;
}

const ModelParameter& Named(const std::vector<ModelParameter>& params, const std::string& name) {
  for (const auto& p : params) {
    if (p.name == name) return p;
  }
  throw std::runtime_error("no parameter " + name);
}

TEST(Person, TheHandRigOffersGroupRecruitmentStrengthJointsRatesArmsAndHandMass) {
  const sim::ModelParams rig = identification::fullmodel::DefaultHandRig();
  const auto params = PersonParameters(rig, HandContext());
  std::set<std::string> names;
  for (const auto& p : params) {
    names.insert(p.name);
    EXPECT_LE(p.lower, p.start) << p.name;
    EXPECT_LE(p.start, p.upper) << p.name;
    EXPECT_TRUE(std::isfinite(p.prior_width) && p.prior_width > 0.0) << p.name;
    EXPECT_EQ(p.sensitivity, p.name != "omega_scale" && p.name != "mass.hand") << p.name;
  }
  std::set<std::string> expected;
  for (const char* g : {"ext", "ext.finger", "flex", "flex.finger"}) {
    for (const char* what : {"strength.", "beta.", "gamma."})
      expected.insert(what + std::string(g));
  }
  for (const char* j : {"wrist_flexion", "mcp_flexion", "pip_flexion"}) {
    for (const char* what : {"k.", "k3.", "b.", "rest."}) expected.insert(what + std::string(j));
  }
  for (const char* a :
       {"arm.ext.finger@mcp_flexion", "arm.ext.finger@pip_flexion", "arm.flex.finger@mcp_flexion",
        "arm.flex.finger@pip_flexion", "omega_scale", "mass.hand"}) {
    expected.insert(a);
  }
  EXPECT_EQ(names, expected);
  // The functions of one joint's angle name it (JointParametersAtBound); the others none.
  for (const auto& p : params) {
    const auto at = p.name.find('@');
    const bool of_angle = p.name.rfind("k.", 0) == 0 || p.name.rfind("k3.", 0) == 0 ||
                          p.name.rfind("rest.", 0) == 0;  // b: a function of speed
    const std::string joint = at != std::string::npos ? p.name.substr(at + 1)
                              : of_angle              ? p.name.substr(p.name.find('.') + 1)
                                                      : std::string();
    EXPECT_EQ(p.joint, joint) << p.name;
  }
  // A reduced model: the channels' input scales only.
  LibraryContext reduced = HandContext();
  reduced.reduced_model = "hammerstein-mimo";
  const auto scales = PersonParameters(rig, reduced);
  ASSERT_EQ(scales.size(), 2u);
  EXPECT_EQ(scales[0].name, "u_scale.ext");
  EXPECT_EQ(scales[0].target, ModelParameter::Target::kInputScale);
}

TEST(Person, SettersChangeTheirGroupOnlyAndMomentArmScalesKeepTheRestLength) {
  const sim::ModelParams rig = identification::fullmodel::DefaultHandRig();
  const auto params = PersonParameters(rig, HandContext());
  std::map<std::string, double> fmax;
  for (const auto& m : rig.muscles) fmax[m.name] = m.hill.max_isometric_force_n;
  sim::ModelParams m = rig;
  Named(params, "strength.flex").set(2.0, &m);
  for (const auto& mu : m.muscles) {
    const bool group = mu.name == "FCR" || mu.name == "FCU";
    EXPECT_DOUBLE_EQ(mu.hill.max_isometric_force_n, (group ? 2.0 : 1.0) * fmax[mu.name]) << mu.name;
  }
  m = rig;
  Named(params, "arm.flex.finger@mcp_flexion").set(1.4, &m);
  const std::vector<double> rest = RestPosture(rig);
  for (std::size_t j = 0; j < m.muscles.size(); ++j) {
    EXPECT_NEAR(tendons::MusculotendonLength(m.muscles[j].path, rest),
                tendons::MusculotendonLength(rig.muscles[j].path, rest), 1e-12);
    for (std::size_t c = 0; c < m.muscles[j].path.crossings.size(); ++c) {
      const auto& a = m.muscles[j].path.crossings[c];
      const auto& b = rig.muscles[j].path.crossings[c];
      const bool scaled =
          (m.muscles[j].name == "FDS" || m.muscles[j].name == "FDP") && a.joint == sim::kMcpFlexion;
      EXPECT_DOUBLE_EQ(a.arm.d_m, (scaled ? 1.4 : 1.0) * b.arm.d_m) << m.muscles[j].name;
    }
  }
  m = rig;
  Named(params, "rest.mcp_flexion").set(0.5, &m);
  EXPECT_EQ(m.coordinates[sim::kMcpFlexion].passive.rest_angle_rad, 0.5);
  EXPECT_EQ(m.coordinates[sim::kMcpFlexion].initial_rad,
            rig.coordinates[sim::kMcpFlexion].initial_rad);
}

TEST(Person, NoiseFromSecondDifferencesFindsWhiteNoiseOnAMovingSignal) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> e(0.0, 0.01);
  std::vector<double> y;
  for (int i = 0; i < 3600; ++i) {
    const double t = i / 60.0;
    y.push_back(0.4 * std::sin(2.0 * t) + 0.2 * std::tanh(5.0 * std::sin(0.7 * t)) + e(rng));
    if (i % 97 == 0) y.back() = NAN;  // dropouts are skipped
  }
  EXPECT_NEAR(NoiseFromSecondDifferences(y), 0.01, 0.0006);
  EXPECT_EQ(NoiseFromSecondDifferences({1.0, 2.0, 3.0}), 0.0);
}

/// A 40 s trial of pseudo-random ext/flex steps simulated on `truth` with noise σ.
DataView Steps(const sim::ModelParams& truth, const std::vector<std::string>& channels,
               double sigma, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> level(0.0, 6.0), hold(1.0, 3.0);
  std::normal_distribution<double> e(0.0, sigma);
  Trial t;
  for (int i = 0; i < 40 * 30; ++i) t.time.push_back(i / 30.0);
  for (const auto& ch : channels) {
    std::vector<double> u(t.size());
    double next = 0.0, value = 0.0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      if (t.time[i] >= next) {
        value = 40.0 * std::floor(level(rng));
        next += hold(rng);
      }
      u[i] = value;
    }
    t.AddColumn("u." + ch, u);
  }
  const std::vector<std::string> outputs = {"q.wrist_flexion", "q.mcp_flexion", "q.pip_flexion"};
  for (const auto& o : outputs) t.AddColumn(o, std::vector<double>(t.size(), 0.0));
  const Trial sim = identification::fullmodel::SimulateLike(truth, t, 1e-7);
  for (const auto& o : outputs) {
    auto& y = t.MutableColumn(o);
    for (std::size_t i = 0; i < y.size(); ++i) y[i] = sim.Column(o)[i] + e(rng);
  }
  DataView v;
  v.trials = {t};
  v.use = {std::vector<char>(t.size(), 1)};
  v.outputs = outputs;
  v.initial_q = {{truth.coordinates[sim::kWristFlexion].initial_rad,
                  truth.coordinates[sim::kMcpFlexion].initial_rad,
                  truth.coordinates[sim::kPipFlexion].initial_rad}};
  return v;
}

TEST(Person, CalibrationRecoversAPlantedPersonAndHoldsWhatTheDataDoNotSee) {
  // Only the extensor channel stimulates: the flexor groups' recruitment and strength are
  // invisible and must stay at nominal; the wrist stiffness (× 1.5) and the extensors' strength
  // (× 0.7), which the data do see, are recovered.
  const sim::ModelParams rig = identification::fullmodel::DefaultHandRig();
  const LibraryContext ctx = HandContext({"ext"});
  const auto params = PersonParameters(rig, ctx);
  sim::ModelParams truth = rig;
  Named(params, "k.wrist_flexion")
      .set(1.5 * rig.coordinates[sim::kWristFlexion].passive.stiffness_nm_per_rad, &truth);
  Named(params, "strength.ext").set(0.7, &truth);
  const DataView v = Steps(truth, {"ext"}, 0.005, 3);
  FitOptions fo;
  fo.threads = 2;
  fo.tolerance = 1e-6;
  PersonCalibrationOptions o;
  o.iterations = 12;
  const PersonCalibration p = CalibratePerson(rig, ctx, v, fo, o);
  EXPECT_NEAR(p.noise_rad[0], 0.005, 0.0005);
  std::map<std::string, PersonValue> by;
  for (const auto& v2 : p.table) by[v2.name] = v2;
  EXPECT_TRUE(by["k.wrist_flexion"].fitted);
  // k and the cubic k3 share the stiffness over the steps' range: 1.60 seen.
  EXPECT_NEAR(by["k.wrist_flexion"].value / by["k.wrist_flexion"].nominal, 1.5, 0.15);
  EXPECT_NEAR(by["strength.ext"].value, 0.7, 0.1);
  // No flexor group exists without its channel; nothing reports at a bound here.
  EXPECT_EQ(by.count("strength.flex"), 0u);
  int held = 0;
  for (const auto& v2 : p.table) {
    if (!v2.fitted) {
      ++held;
      EXPECT_EQ(v2.value, v2.nominal) << v2.name;
      EXPECT_LT(v2.information, kIdentifiableInformation) << v2.name;
    }
  }
  EXPECT_GT(held, 0);
  // The calibrated model fits to the noise: Σr²/N ≈ σ².
  EXPECT_LT(p.fit.cost / static_cast<double>(v.Count()), 1.5 * 0.005 * 0.005);
}

}  // namespace
}  // namespace fesim::diagnosis
