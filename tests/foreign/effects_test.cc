// Tests of foreign/effects.h, hook by hook: the table, each effect's own parameterisation and
// scale, determinism per seed. (Their effect on whole trials is tested in simulate_test.cc.)
#include "foreign/effects.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "foreign/integrator.h"

namespace fesim::foreign {
namespace {

constexpr double kExactTol = 1e-12;
constexpr double kScale = 1.7;  // a scale ≠ 1, to see that it multiplies what it should

EffectContext ContextAtRest(const Person& p) {
  EffectContext ctx;
  ctx.q_rad = Eigen::Vector3d::Zero();
  ctx.qd_rad_s = Eigen::Vector3d::Zero();
  ctx.person = &p;
  return ctx;
}

std::unique_ptr<EffectModel> Make(const std::string& id, double scale = kScale,
                                  std::uint64_t seed = 1, double duration = 60.0) {
  return MakeEffect({id, scale}, {duration, seed, seed});
}

TEST(ForeignEffects, TableHoldsExactlyTheFifteenIds) {
  const std::vector<std::string> expected = {"fatigue",
                                             "potentiation",
                                             "delay",
                                             "tremor",
                                             "crosstalk",
                                             "moment_arm_posture",
                                             "force_length_velocity",
                                             "unequal_muscle_dynamics",
                                             "passive_stiffness_nonlinear",
                                             "stiction",
                                             "spasticity",
                                             "sensor_drift",
                                             "wander",
                                             "slip",
                                             "voluntary"};
  EXPECT_EQ(EffectIds(), expected);
  for (const std::string& id : expected) EXPECT_NE(Make(id), nullptr) << id;
}

TEST(ForeignEffects, UnknownIdAndBadScaleAreRejected) {
  try {
    Make("arm_support");
    FAIL();
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("arm_support"), std::string::npos);
    EXPECT_NE(msg.find("voluntary"), std::string::npos);  // lists the known ids
  }
  EXPECT_THROW(Make("fatigue", 0.0), std::invalid_argument);
  EXPECT_THROW(Make("fatigue", -1.0), std::invalid_argument);
}

TEST(ForeignEffects, StructuralEffectsChangeTheirParametersByTheScale) {
  const Person n = NominalPerson();
  Person p = n;
  Make("crosstalk")->ModifyPerson(&p);
  EXPECT_NEAR(p.placement[kEcr][kFlexChannel], 0.45 * kScale, kExactTol);
  EXPECT_NEAR(p.placement[kFdp][kExtChannel], 0.45 * kScale, kExactTol);
  EXPECT_EQ(p.placement[kEcr][kExtChannel], 1.0);

  p = n;
  Make("moment_arm_posture")->ModifyPerson(&p);
  for (int m = 0; m < kNumMuscles; ++m) {
    const auto& a = p.muscles[m].moment_arms[kWristCrossing];
    const auto& b = n.muscles[m].moment_arms[kWristCrossing];
    EXPECT_NEAR(a.r1_m_per_rad - b.r1_m_per_rad, 0.6 * kScale * b.r0_m, kExactTol);
    EXPECT_EQ(a.r0_m, b.r0_m);
  }

  p = n;
  Make("force_length_velocity")->ModifyPerson(&p);
  EXPECT_NEAR(p.muscles[kFcu].contraction.max_velocity_lopt_per_s, 10.0 / (1 + 3 * kScale),
              kExactTol);

  p = n;
  Make("unequal_muscle_dynamics")->ModifyPerson(&p);
  const double ratio = 1 + 0.5 * kScale;
  EXPECT_NEAR(p.muscles[kEcr].activation.force_activation_tau_s,
              n.muscles[kEcr].activation.force_activation_tau_s * ratio, kExactTol);
  EXPECT_NEAR(p.muscles[kFds].activation.coupling_deactivation_tau_s,
              n.muscles[kFds].activation.coupling_deactivation_tau_s / ratio, kExactTol);

  EXPECT_NEAR(Make("delay")->StimulationDelay_s(), 0.05 * kScale, kExactTol);
  EXPECT_EQ(Make("fatigue")->StimulationDelay_s(), 0.0);
}

TEST(ForeignEffects, JointLocalEffectsActOnlyAtTheJointTheyName) {
  // The diagnosis suite counts a cause named at another joint as not found, so the joint an
  // effect names must be the only one it touches: its torques, its friction and its moment arms.
  const Person n = NominalPerson();
  std::vector<std::string> local;
  for (const std::string& id : EffectIds()) {
    auto f = Make(id);
    const int j = f->JointIndex();
    if (j < 0) continue;
    local.push_back(id);
    EffectContext ctx = ContextAtRest(n);
    ctx.t_s = 10.0;
    ctx.q_rad = Eigen::Vector3d(0.5, 0.6, 0.7);
    ctx.qd_rad_s = Eigen::Vector3d(0.4, -0.3, 0.2);
    std::vector<double> x(static_cast<std::size_t>(f->NumStates()) + 1, 0.0);
    Eigen::Vector3d tau = Eigen::Vector3d::Zero();
    f->AddJointTorque(ctx, x.data(), &tau);
    f->AddFrictionTorque(ctx, Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.5, 0.5, 0.5), &tau);
    for (int k = 0; k < kNumJoints; ++k) {
      if (k != j) EXPECT_EQ(tau[k], 0.0) << id << " joint " << k;
    }
    Person p = n;
    f->ModifyPerson(&p);
    for (int m = 0; m < kNumMuscles; ++m) {
      for (std::size_t c = 0; c < p.muscles[m].moment_arms.size(); ++c) {
        if (static_cast<int>(c) == j) continue;
        EXPECT_EQ(p.muscles[m].moment_arms[c].r1_m_per_rad,
                  n.muscles[m].moment_arms[c].r1_m_per_rad)
            << id << " muscle " << m << " crossing " << c;
      }
    }
  }
  const std::vector<std::string> expected = {"tremor", "moment_arm_posture",
                                             "passive_stiffness_nonlinear", "stiction"};
  EXPECT_EQ(local, expected);
  EXPECT_EQ(Make("spasticity")->JointIndex(), -1);  // a reflex of all flexors
}

TEST(ForeignEffects, FatigueLosesCapacityWithDriveAndRecoversAtRest) {
  const Person p = NominalPerson();
  auto f = Make("fatigue");
  ASSERT_EQ(f->NumStates(), kNumMuscles);
  std::vector<double> x(kNumMuscles), dx(kNumMuscles);
  f->InitialState(x.data());
  EffectContext ctx = ContextAtRest(p);
  ctx.coupling[kEcr] = p.muscles[kEcr].recruitment.max_fraction;  // ẽ = 1
  f->StateDerivative(ctx, x.data(), dx.data());
  EXPECT_NEAR(dx[kEcr], -0.025 * kScale, kExactTol);
  EXPECT_EQ(dx[kFcr], 0.0);
  x[kFcr] = 0.8;
  f->StateDerivative(ContextAtRest(p), x.data(), dx.data());
  EXPECT_NEAR(dx[kFcr], 0.2 / 127.0, kExactTol);
  MuscleArray cap;
  cap.fill(1.0);
  f->ScaleCapacity(ctx, x.data(), &cap);
  EXPECT_EQ(cap[kFcr], 0.8);
}

TEST(ForeignEffects, PotentiationRaisesCapacityUpToItsBound) {
  const Person p = NominalPerson();
  auto f = Make("potentiation");
  std::vector<double> x(kNumMuscles, 1.0);
  MuscleArray cap;
  cap.fill(1.0);
  f->ScaleCapacity(ContextAtRest(p), x.data(), &cap);
  EXPECT_NEAR(cap[kEdc], 1 + 0.35 * kScale, kExactTol);
  EXPECT_NEAR(f->CapacityBound(), 1 + 0.35 * kScale, kExactTol);
  std::vector<double> dx(kNumMuscles);
  f->StateDerivative(ContextAtRest(p), x.data(), dx.data());
  EXPECT_NEAR(dx[kEdc], -1.0 / 30.0, kExactTol);  // decays over tens of seconds
}

TEST(ForeignEffects, TremorIsAWristTorqueInTheFourToNineHertzBand) {
  const Person p = NominalPerson();
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    auto f = Make("tremor", 1.0, seed);
    EffectContext ctx = ContextAtRest(p);
    int crossings = 0;
    double prev = 0.0, peak = 0.0;
    const double t0 = 2.0, t1 = 22.0, dt = 1e-3;
    for (double t = t0; t < t1; t += dt) {
      ctx.t_s = t;
      Eigen::Vector3d tau = Eigen::Vector3d::Zero();
      f->AddJointTorque(ctx, nullptr, &tau);
      EXPECT_EQ(tau[1], 0.0);
      EXPECT_EQ(tau[2], 0.0);
      if (t > t0 && (tau[0] > 0) != (prev > 0)) ++crossings;
      prev = tau[0];
      peak = std::max(peak, std::abs(tau[0]));
    }
    const double frequency = crossings / 2.0 / (t1 - t0);
    EXPECT_GE(frequency, 4.0 - 0.1) << seed;
    EXPECT_LE(frequency, 9.0 + 0.1) << seed;
    EXPECT_LE(peak, 0.1 + kExactTol);
  }
  // Smooth onset: nothing at t = 0 (the trial starts at equilibrium).
  EffectContext ctx = ContextAtRest(p);
  Eigen::Vector3d tau = Eigen::Vector3d::Zero();
  Make("tremor")->AddJointTorque(ctx, nullptr, &tau);
  EXPECT_EQ(tau[0], 0.0);
}

TEST(ForeignEffects, ATremorKeepsItsFrequencyAcrossThePersonsTrialsButNotItsPhase) {
  // The frequency is the person's (person_seed), the phase the trial's (seed): zero crossings
  // over 20 s agree to one, the torques at one instant differ.
  const Person p = NominalPerson();
  const auto crossings_and_torque = [&](std::uint64_t trial_seed) {
    auto f = MakeEffect({"tremor", 1.0}, {60.0, trial_seed, 7});
    EffectContext ctx = ContextAtRest(p);
    int crossings = 0;
    double prev = 0.0, at_5s = 0.0;
    for (double t = 2.0; t < 22.0; t += 1e-3) {
      ctx.t_s = t;
      Eigen::Vector3d tau = Eigen::Vector3d::Zero();
      f->AddJointTorque(ctx, nullptr, &tau);
      if (t > 2.0 && (tau[0] > 0) != (prev > 0)) ++crossings;
      if (std::abs(t - 5.0) < 5e-4) at_5s = tau[0];
      prev = tau[0];
    }
    return std::make_pair(crossings, at_5s);
  };
  const auto a = crossings_and_torque(1), b = crossings_and_torque(2);
  EXPECT_NEAR(a.first, b.first, 1);
  EXPECT_GT(std::abs(a.second - b.second), 1e-3);
}

TEST(ForeignEffects, PassiveStiffeningIsOddAboutRestWithNoStiffnessThere) {
  const Person p = NominalPerson();
  auto f = Make("passive_stiffness_nonlinear");
  auto torque = [&](double q) {
    EffectContext ctx = ContextAtRest(p);
    ctx.q_rad[0] = p.joints[0].rest_angle_rad + q;
    Eigen::Vector3d tau = Eigen::Vector3d::Zero();
    f->AddJointTorque(ctx, nullptr, &tau);
    return tau[0];
  };
  EXPECT_EQ(torque(0.0), 0.0);
  EXPECT_NEAR(torque(0.5), -torque(-0.5), kExactTol);
  EXPECT_NEAR(torque(0.5), -kScale * 0.3 * (std::sinh(2.0) - 2.0) / 4.0, kExactTol);
  EXPECT_NEAR((torque(1e-4) - torque(-1e-4)) / 2e-4, 0.0, 1e-6);
  EXPECT_LT(torque(0.8) / 0.8, 4 * torque(0.4) / 0.4);  // stiffening
}

TEST(ForeignEffects, StictionHoldsTheWristBelowStaticAndSlidesWithCoulombAbove) {
  const Person p = NominalPerson();
  auto f = Make("stiction", 1.0);
  const Eigen::Matrix3d m_inv =
      (Eigen::Matrix3d() << 900, -400, 50, -400, 2e4, -9e3, 50, -9e3, 1.5e5).finished();
  EffectContext ctx = ContextAtRest(p);
  // At rest with a small net torque: the friction cancels the wrist acceleration exactly.
  const Eigen::Vector3d small(0.03, 0.01, -0.002);
  Eigen::Vector3d fr = Eigen::Vector3d::Zero();
  f->AddFrictionTorque(ctx, m_inv, small, &fr);
  EXPECT_NEAR((m_inv * (small + fr))[0], 0.0, 1e-12);
  EXPECT_EQ(fr[1], 0.0);
  // A large net torque breaks away: the friction is the static limit.
  const Eigen::Vector3d large(0.5, 0.0, 0.0);
  fr.setZero();
  f->AddFrictionTorque(ctx, m_inv, large, &fr);
  EXPECT_NEAR(fr[0], -0.06, kExactTol);
  // Sliding: Coulomb friction against the velocity.
  ctx.qd_rad_s[0] = -0.3;
  fr.setZero();
  f->AddFrictionTorque(ctx, m_inv, large, &fr);
  EXPECT_NEAR(fr[0], 0.04, kExactTol);
}

TEST(ForeignEffects, SpasticityIsAVelocityThresholdReflexThroughAnErlangDelay) {
  const Person p = NominalPerson();
  auto f = Make("spasticity", 1.0);
  ASSERT_EQ(f->NumStates(), 16);
  EffectContext ctx = ContextAtRest(p);
  const double v_lopt = 0.6;  // FCR stretched at 0.6 l_opt/s
  ctx.lengthening_velocity_m_s[kFcr] = v_lopt * p.muscles[kFcr].contraction.optimal_fibre_length_m;
  ctx.lengthening_velocity_m_s[kEcr] = 1.0;  // extensors have no reflex here
  std::vector<double> x(16, 0.0);
  Rk4 rk4(16);
  const OdeFunction rhs = [&](double, const double* s, double* ds) {
    f->StateDerivative(ctx, s, ds);
  };
  auto drive_after = [&](double t) {
    std::fill(x.begin(), x.end(), 0.0);
    rk4.Integrate(rhs, 0.0, t, 1e-4, x.data());
    MuscleArray d{};
    f->AddDrive(ctx, x.data(), &d);
    EXPECT_EQ(d[kEcr], 0.0);
    return d[kFcr];
  };
  const double steady = 0.08 * (v_lopt - 0.1 - 0.025);  // G·(ṽ − ṽ_th − ε/2)
  EXPECT_NEAR(drive_after(1.0), steady, 1e-9);
  // Erlang(4, mean 40 ms) step response at its mean: 1 − e⁻⁴(1 + 4 + 8 + 32/3).
  EXPECT_NEAR(drive_after(0.04) / steady, 1 - std::exp(-4.0) * (1 + 4 + 8 + 32.0 / 3.0), 1e-7);
  // Below threshold: nothing.
  ctx.lengthening_velocity_m_s[kFcr] = 0.05 * p.muscles[kFcr].contraction.optimal_fibre_length_m;
  EXPECT_EQ(drive_after(0.5), 0.0);
}

TEST(ForeignEffects, SensorArtefactsAreSeededOffsets) {
  auto drift = Make("sensor_drift", kScale, 4);
  const Eigen::Vector3d d10 = drift->ReadingOffset(10.0);
  EXPECT_LT((drift->ReadingOffset(20.0) - 2 * d10).norm(), kExactTol);
  for (int j = 0; j < kNumJoints; ++j) {
    EXPECT_GE(std::abs(d10[j]), kScale * 0.7 * 5e-4 * 10 - kExactTol);
    EXPECT_LE(std::abs(d10[j]), kScale * 1.3 * 5e-4 * 10 + kExactTol);
  }
  EXPECT_EQ(drift->ReadingOffset(10.0), Make("sensor_drift", kScale, 4)->ReadingOffset(10.0));
  EXPECT_NE(drift->ReadingOffset(10.0), Make("sensor_drift", kScale, 5)->ReadingOffset(10.0));

  auto slip = Make("slip", 1.0, 2, 40.0);
  double t_jump = -1.0;
  for (double t = 0.0; t <= 40.0; t += 0.01) {
    if (slip->ReadingOffset(t).norm() > 0.0) {
      t_jump = t;
      break;
    }
  }
  ASSERT_GT(t_jump, 0.3 * 40 - 0.01);
  EXPECT_LT(t_jump, 0.7 * 40 + 0.01);
  const Eigen::Vector3d step = slip->ReadingOffset(39.0);
  EXPECT_EQ(step, slip->ReadingOffset(t_jump + 1.0));
  for (int j = 0; j < kNumJoints; ++j) {
    EXPECT_GE(std::abs(step[j]), 0.02);
    EXPECT_LE(std::abs(step[j]), 0.04);
  }

  auto wander = Make("wander", 1.0, 3);
  double peak = 0.0;
  for (double t = 0.0; t < 60.0; t += 0.05)
    peak = std::max(peak, wander->ReadingOffset(t).cwiseAbs().maxCoeff());
  EXPECT_GT(peak, 0.01);
  EXPECT_LE(peak, 0.04 + kExactTol);
  EXPECT_NE(wander->ReadingOffset(7.0), Make("wander", 1.0, 4)->ReadingOffset(7.0));
}

TEST(ForeignEffects, VoluntaryBurstsDriveOnlyFingerMusclesAndAreSeeded) {
  const Person p = NominalPerson();
  auto v = Make("voluntary", 1.0, 6);
  EffectContext ctx = ContextAtRest(p);
  double total = 0.0, peak = 0.0;
  for (double t = 0.0; t < 60.0; t += 0.01) {
    ctx.t_s = t;
    MuscleArray d{};
    v->AddDrive(ctx, nullptr, &d);
    for (int m : {kEcr, kEcu, kFcr, kFcu}) EXPECT_EQ(d[m], 0.0);
    for (int m : {kEdc, kFds, kFdp}) {
      total += d[m];
      peak = std::max(peak, d[m]);
    }
    if (t < 1.0) {
      EXPECT_EQ(d[kFds] + d[kEdc], 0.0);
    }
  }
  EXPECT_GT(total, 0.0);
  EXPECT_LE(peak, 0.10 + kExactTol);
  EXPECT_LE(peak, v->DriveBound());
  MuscleArray a{}, b{};
  ctx.t_s = 0.0;
  for (double t = 0.0; t < 60.0; t += 0.05) {
    ctx.t_s = t;
    v->AddDrive(ctx, nullptr, &a);
    Make("voluntary", 1.0, 6)->AddDrive(ctx, nullptr, &b);
  }
  EXPECT_EQ(a, b);
}

}  // namespace
}  // namespace fesim::foreign
