// The MJCF writer (sim/mjcf.h): the text is well-formed and carries fesim's joints, muscles and
// moment arms; ActivationTrack reproduces fesim's activations. With MuJoCo (FESIM_WITH_MUJOCO),
// the model loads and its physics at one instant equals fesim's: mass matrix, passive torques,
// muscle torques at the rest posture and the accelerations of the whole model with its arm
// support.
#include "sim/mjcf.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <regex>
#include <string>
#include <vector>

#include "sim/default_model.h"
#include "sim/trial_runner.h"
#include "sim/upper_limb_model.h"
#include "tendons/landsmeer.h"
#include "tendons/tendon_network.h"

#if FESIM_TEST_WITH_MUJOCO
#include <mujoco/mujoco.h>
#endif

namespace fesim::sim {
namespace {

constexpr double kCoefTol = 1e-15;        // m: coefficients are written with 17 digits
constexpr double kFiniteDiffTol = 1e-9;   // m: central difference of l_MT, step 1e-5 rad
constexpr double kActivationTol = 1e-12;  // the same closed form as fesim's integrator
constexpr double kPhysicsRelTol = 1e-9;   // MuJoCo vs Simbody, relative to the largest entry

/// A minimal well-formedness check: every element closes in order and every attribute is
/// name="value" without '<', '&' or '"' inside.
bool WellFormed(const std::string& xml) {
  std::vector<std::string> open;
  const std::regex tag("<(/?)([A-Za-z_][A-Za-z0-9_]*)((?:\\s+[A-Za-z_]+=\"[^\"<&]*\")*)\\s*(/?)>");
  const std::regex any_tag("<[^!]");
  std::size_t tags = 0;
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), tag); it != std::sregex_iterator();
       ++it) {
    ++tags;
    const std::string name = (*it)[2];
    if ((*it)[4] == "/") continue;
    if ((*it)[1] == "/") {
      if (open.empty() || open.back() != name) return false;
      open.pop_back();
    } else {
      open.push_back(name);
    }
  }
  // Every '<' that is not a comment must have been a tag the regex accepted.
  const auto all =
      std::distance(std::sregex_iterator(xml.begin(), xml.end(), any_tag), std::sregex_iterator());
  return open.empty() && static_cast<std::size_t>(all) == tags;
}

std::vector<std::string> Matches(const std::string& xml, const std::string& pattern) {
  std::vector<std::string> out;
  const std::regex re(pattern);
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), re); it != std::sregex_iterator();
       ++it) {
    out.push_back((*it)[1]);
  }
  return out;
}

std::vector<double> RestAngles(const ModelParams& p) {
  std::vector<double> q(kNumCoordinates);
  for (int i = 0; i < kNumCoordinates; ++i) q[i] = p.coordinates[i].passive.rest_angle_rad;
  return q;
}

/// The default participant on the default scenario's arm support (scenarios/default.yaml).
ModelParams SupportedModel() {
  ModelParams p = DefaultModelParams();
  constexpr double kDeg = 3.14159265358979323846 / 180.0;
  p.coordinates[kShoulderElvPlane].initial_rad = 60 * kDeg;
  p.coordinates[kShoulderElevation].initial_rad = 56 * kDeg;
  p.coordinates[kElbowFlexion].initial_rad = 72 * kDeg;
  BandParams band;
  band.segment = kHumerus;
  band.cuff_in_segment_m = {0, -0.2, 0};
  band.anchor_in_ground_m = {0.15, 1.9, 0.35};
  band.stiffness_n_per_m = 150;
  band.slack_length_m = 0.25;
  p.bands = {band};
  WeightCompensationParams w;
  w.segment = kForearm;
  w.cuff_in_segment_m = {0, -0.12, 0};
  w.force_n = 10;
  p.weight_compensation = {w};
  return p;
}

TEST(Mjcf, XmlIsWellFormedAndHasFesimsJointsTendonsAndActuators) {
  const ModelParams p = SupportedModel();
  const std::string xml = WriteMjcf(p);
  ASSERT_TRUE(WellFormed(xml));
  const auto joints = Matches(xml, "<joint name=\"([^\"]*)\" type=\"hinge\"");
  ASSERT_EQ(joints.size(), static_cast<std::size_t>(kNumCoordinates));
  for (int c = 0; c < kNumCoordinates; ++c) EXPECT_EQ(joints[c], CoordinateNames()[c]);
  EXPECT_EQ(Matches(xml, "<body name=\"([^\"]*)\"").size(), static_cast<std::size_t>(kNumSegments));
  const auto tendons = Matches(xml, "<fixed name=\"([^\"]*)\"");
  ASSERT_EQ(tendons.size(), p.muscles.size());
  const auto actuators = Matches(xml, "<general name=\"([^\"]*)\"");
  ASSERT_EQ(actuators.size(), p.muscles.size() + 1);  // + the weight compensation
  for (std::size_t j = 0; j < p.muscles.size(); ++j) {
    EXPECT_EQ(tendons[j], p.muscles[j].name);
    EXPECT_EQ(actuators[j], p.muscles[j].name);
  }
  EXPECT_EQ(Matches(xml, "<spatial name=\"([^\"]*)\"").size(), 2u);  // band + compensation
}

TEST(Mjcf, TendonCoefficientsAreFesimsMomentArmsAtTheRestPostureWithMuJoCosSign) {
  const ModelParams p = DefaultModelParams();
  const std::string xml = WriteMjcf(p);
  const std::vector<double> rest = RestAngles(p);
  for (const MuscleParams& m : p.muscles) {
    // The <fixed> element of this muscle and its (joint, coef) pairs.
    const std::regex block("<fixed name=\"" + m.name + "\">([\\s\\S]*?)</fixed>");
    std::smatch found;
    ASSERT_TRUE(std::regex_search(xml, found, block)) << m.name;
    const std::string body = found[1];
    ASSERT_EQ(Matches(body, "<joint joint=\"([^\"]*)\"").size(), m.path.crossings.size()) << m.name;
    for (const tendons::Crossing& c : m.path.crossings) {
      const std::string joint = CoordinateNames()[c.joint];
      const auto coef = Matches(body, "joint=\"" + joint + "\" coef=\"([^\"]*)\"");
      ASSERT_EQ(coef.size(), 1u) << m.name << " " << joint;
      // fesim's r = −∂l_MT/∂q; MuJoCo's tendon length grows with coef·q, so coef = −r.
      const double r = tendons::MomentArm(c.arm, rest[c.joint] - c.q_ref_rad);
      EXPECT_NEAR(std::stod(coef[0]), -r, kCoefTol) << m.name << " " << joint;
      // The same from fesim's musculotendon length, by central difference at rest.
      std::vector<double> lo = rest, hi = rest;
      constexpr double kH = 1e-5;
      lo[c.joint] -= kH;
      hi[c.joint] += kH;
      const double dl_dq =
          (tendons::MusculotendonLength(m.path, hi) - tendons::MusculotendonLength(m.path, lo)) /
          (2 * kH);
      EXPECT_NEAR(std::stod(coef[0]), dl_dq, kFiniteDiffTol) << m.name << " " << joint;
    }
  }
}

TEST(Mjcf, RejectsWhatItCannotExpressNamingIt) {
  ModelParams p = DefaultModelParams();
  p.coordinates[kElbowFlexion].mode = CoordinateMode::kLocked;
  try {
    WriteMjcf(p);
    FAIL() << "a locked coordinate was written";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("elbow_flexion"), std::string::npos) << e.what();
  }
  ModelParams q = DefaultModelParams();
  q.mechanisms.tremor.enabled = true;
  EXPECT_THROW(WriteMjcf(q), std::invalid_argument);
  MjcfOptions bad;
  bad.timestep_s = 0.0;
  EXPECT_THROW(WriteMjcf(DefaultModelParams(), bad), std::invalid_argument);
  ModelParams quote = DefaultModelParams();
  quote.muscles[0].name = "EC\"RL";  // would end the attribute
  EXPECT_THROW(WriteMjcf(quote), std::invalid_argument);
}

TEST(Mjcf, ActivationTrackEqualsFesimsActivationsThroughATrial) {
  // Deactivation at half Ω (muscles::IntervalOmega): the track picks each interval's Ω as the
  // integrator does.
  ModelParams p = DefaultModelParams();
  for (auto& m : p.muscles) m.deactivation_ratio = 0.5;
  const UpperLimbModel model(p);
  TrialRequest r;
  r.duration_s = 5.0;
  r.stimulation.times = {0.0, 1.5, 3.25};
  r.stimulation.values = {
      {150, 0, 120, 80, 60, 0}, {250, 200, 0, 160, 0, 90}, {0, 100, 300, 0, 40, 40}};
  r.sensors.angles.coordinates.clear();
  r.sensors.truth_rate_hz = 100.0;
  const TrialResult result = RunTrial(model, r);
  const ActivationTrack track(p, r.stimulation);
  double peak = 0.0;
  for (std::size_t i = 0; i < result.truth.size(); ++i) {
    const double t = result.truth.time[i];
    const std::vector<double> a = track.At(t);
    for (std::size_t j = 0; j < p.muscles.size(); ++j) {
      const double fesim_a = result.truth.Column("a." + p.muscles[j].name)[i];
      EXPECT_NEAR(a[j], fesim_a, kActivationTol) << p.muscles[j].name << " at " << t;
      peak = std::max(peak, fesim_a);
    }
  }
  EXPECT_GT(peak, 0.1);  // the stimulation did recruit
}

#if FESIM_TEST_WITH_MUJOCO

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

ModelPtr Load(const std::string& xml) {
  auto vfs = std::make_unique<mjVFS>();
  mj_defaultVFS(vfs.get());
  if (mj_makeEmptyFileVFS(vfs.get(), "fesim.xml", static_cast<int>(xml.size())) != 0) return {};
  std::memcpy(vfs->filedata[vfs->nfile - 1], xml.data(), xml.size());
  char error[1000] = "";
  ModelPtr m(mj_loadXML("fesim.xml", vfs.get(), error, sizeof error));
  mj_deleteVFS(vfs.get());
  EXPECT_TRUE(m) << error;
  EXPECT_STREQ(error, "") << "the compiler warned";  // e.g. a singular inertia matrix at qpos0
  return m;
}

/// Simbody's state at the model's initial posture with stimulation and activations 0, realised
/// to Acceleration; speeds set to `u_rad_s` per coordinate.
SimTK::State SimbodyState(const UpperLimbModel& model, const std::vector<double>& u_rad_s) {
  SimTK::State s = model.MakeInitialState();
  for (int i = 0; i < kNumCoordinates; ++i) {
    model.CoordinateBody(i).setOneU(s, 0, u_rad_s[i]);
  }
  model.system().realize(s, SimTK::Stage::Acceleration);
  return s;
}

double MaxAbs(const std::vector<double>& v) {
  double m = 0.0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

TEST(MjcfMuJoCo, LoadsWithFesimsMassHingesAndTendonJacobian) {
  const ModelParams p = SupportedModel();
  const ModelPtr m = Load(WriteMjcf(p));
  ASSERT_TRUE(m);
  ASSERT_EQ(m->njnt, kNumCoordinates);
  ASSERT_EQ(m->nv, kNumCoordinates);
  for (int c = 0; c < kNumCoordinates; ++c) {
    EXPECT_EQ(m->jnt_type[c], mjJNT_HINGE);
    EXPECT_EQ(mj_name2id(m.get(), mjOBJ_JOINT, CoordinateNames()[c].c_str()), c);
  }
  double fesim_mass = 0.0, mujoco_mass = 0.0;
  for (const auto& s : p.segments) fesim_mass += s.mass_kg;
  for (int b = 0; b < m->nbody; ++b) mujoco_mass += m->body_mass[b];
  EXPECT_NEAR(mujoco_mass, fesim_mass, 1e-12 * fesim_mass);
  // MuJoCo's tendon Jacobian ten_J = ∂L/∂q at the rest posture is −R of fesim.
  DataPtr d(mj_makeData(m.get()));
  const std::vector<double> rest = RestAngles(p);
  for (int i = 0; i < kNumCoordinates; ++i) d->qpos[i] = rest[i];
  mj_forward(m.get(), d.get());
  const std::vector<double> coef = MjcfTendonCoefficients(p);
  const int nm = static_cast<int>(p.muscles.size());
  std::vector<tendons::MusclePath> paths;
  for (const auto& mp : p.muscles) paths.push_back(mp.path);
  const std::vector<double> r = tendons::MomentArmMatrix(paths, rest);
  for (int j = 0; j < nm; ++j) {
    for (int i = 0; i < kNumCoordinates; ++i) {
      EXPECT_NEAR(d->ten_J[j * m->nv + i], -r[i * nm + j], kCoefTol)
          << p.muscles[j].name << " " << CoordinateNames()[i];
    }
  }
}

TEST(MjcfMuJoCo, PassiveTorqueIsMinusStiffnessTimesDisplacementMinusDamping) {
  const ModelParams p = DefaultModelParams();  // no arm support: only the joints are springs
  const ModelPtr m = Load(WriteMjcf(p));
  ASSERT_TRUE(m);
  DataPtr d(mj_makeData(m.get()));
  constexpr double kDq = 0.1, kQd = 0.2;
  for (int i = 0; i < kNumCoordinates; ++i) {
    d->qpos[i] = p.coordinates[i].passive.rest_angle_rad + kDq;
    d->qvel[i] = kQd;
  }
  mj_forward(m.get(), d.get());
  for (int i = 0; i < kNumCoordinates; ++i) {
    const PassiveJointParams& j = p.coordinates[i].passive;
    const double expected = -j.stiffness_nm_per_rad * kDq - j.damping_nms_per_rad * kQd;
    EXPECT_NEAR(d->qfrc_passive[i], expected, 1e-12 * (1 + std::abs(expected)))
        << CoordinateNames()[i];
  }
}

TEST(MjcfMuJoCo, MuscleTorqueAtTheRestPostureEqualsFesimsIsometricTorque) {
  const ModelParams p = DefaultModelParams();
  const ModelPtr m = Load(WriteMjcf(p));
  ASSERT_TRUE(m);
  DataPtr d(mj_makeData(m.get()));
  const std::vector<double> rest = RestAngles(p), zero(kNumCoordinates, 0.0);
  std::vector<tendons::MusclePath> paths;
  for (const auto& mp : p.muscles) paths.push_back(mp.path);
  const int nm = static_cast<int>(p.muscles.size());
  const std::vector<double> tau0 =
      MuscleAndPassiveTorques(p, paths, rest, zero, std::vector<double>(nm, 0.0));
  for (int j = 0; j < nm; ++j) {
    std::vector<double> a(nm, 0.0);
    a[j] = 0.7;
    const std::vector<double> tau = MuscleAndPassiveTorques(p, paths, rest, zero, a);
    mj_resetData(m.get(), d.get());
    for (int i = 0; i < kNumCoordinates; ++i) d->qpos[i] = rest[i];
    d->ctrl[j] = a[j];
    mj_forward(m.get(), d.get());
    std::vector<double> fesim(kNumCoordinates);
    for (int i = 0; i < kNumCoordinates; ++i) fesim[i] = tau[i] - tau0[i];
    for (int i = 0; i < kNumCoordinates; ++i) {
      EXPECT_NEAR(d->qfrc_actuator[i], fesim[i], 1e-9 * MaxAbs(fesim))
          << p.muscles[j].name << " " << CoordinateNames()[i];
    }
  }
}

/// Mass matrix and accelerations of the whole supported arm at its initial posture, moving,
/// against Simbody: fesim's muscles made negligible (F_max 1 nN: their passive fibre force is
/// not in the MJCF) and its exponential range limits off (MuJoCo's act only past the range).
TEST(MjcfMuJoCo, MassMatrixAndAccelerationsEqualSimbodys) {
  ModelParams p = SupportedModel();
  for (auto& mp : p.muscles) mp.hill.max_isometric_force_n = 1e-9;
  for (auto& c : p.coordinates) c.passive.limit_stiffness_nm_per_rad = 0.0;
  const std::vector<double> u = {0.3, -0.2, 0.5, 1.0, -0.4, 0.8, 0.2, -1.5, 2.0, 1.2};
  const UpperLimbModel model(p);
  const SimTK::State s = SimbodyState(model, u);
  SimTK::Matrix simbody_m;
  model.matter().calcM(s, simbody_m);

  const ModelPtr m = Load(WriteMjcf(p));
  ASSERT_TRUE(m);
  DataPtr d(mj_makeData(m.get()));
  mj_resetDataKeyframe(m.get(), d.get(), 0);
  for (int i = 0; i < kNumCoordinates; ++i) d->qvel[i] = u[i];
  mj_forward(m.get(), d.get());
  std::vector<mjtNum> full(kNumCoordinates * kNumCoordinates);
  mj_fullM(m.get(), full.data(), d->qM);

  double m_scale = 0.0;
  for (double x : full) m_scale = std::max(m_scale, std::abs(x));
  std::vector<double> simbody_udot(kNumCoordinates), mujoco_qacc(kNumCoordinates);
  for (int i = 0; i < kNumCoordinates; ++i) {
    const int ui = model.CoordinateBody(i).getFirstUIndex(s);
    EXPECT_NEAR(d->qpos[i], model.GetQ(s, i), 1e-15) << CoordinateNames()[i];
    for (int k = 0; k < kNumCoordinates; ++k) {
      const int uk = model.CoordinateBody(k).getFirstUIndex(s);
      EXPECT_NEAR(full[i * kNumCoordinates + k], simbody_m(ui, uk), kPhysicsRelTol * m_scale)
          << "M(" << CoordinateNames()[i] << ", " << CoordinateNames()[k] << ")";
    }
    simbody_udot[i] = s.getUDot()[ui];
    mujoco_qacc[i] = d->qacc[i];
  }
  EXPECT_EQ(d->nefc, 0);  // no joint limit engaged: the accelerations are the unconstrained ones
  const double scale = MaxAbs(simbody_udot);
  for (int i = 0; i < kNumCoordinates; ++i) {
    EXPECT_NEAR(mujoco_qacc[i], simbody_udot[i], kPhysicsRelTol * scale) << CoordinateNames()[i];
  }
}

#endif  // FESIM_TEST_WITH_MUJOCO

}  // namespace
}  // namespace fesim::sim
