// Tests of foreign/muscle.h: moment arms are exactly −∂l_MT/∂q (every crossing, DIP coupling
// included), recruitment key points and monotonicity, the two-stage activation step response
// against its closed form, and the contraction curves' key points and smoothness.
#include "foreign/muscle.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

#include "foreign/integrator.h"
#include "foreign/person.h"
#include "foreign/random.h"

namespace fesim::foreign {
namespace {

constexpr double kFdStep = 1e-5;          // rad; l_MT is a cubic, so central differences are exact
constexpr double kMomentArmTolM = 1e-11;  // m: rounding of l_MT (~0.3 m) over 2·kFdStep
constexpr double kExactTol = 1e-12;
constexpr double kStepResponseTol = 1e-8;  // RK4 at 0.1 ms against the closed form
constexpr double kRk4StepS = 1e-4;

TEST(ForeignMuscle, MomentArmsAreMinusTheLengthGradientForEveryCrossing) {
  std::mt19937_64 rng(5);
  for (const Person& p : {NominalPerson(), DrawPerson(PersonSpread{}, 9)}) {
    for (int m = 0; m < kNumMuscles; ++m) {
      MuscleParams mu = p.muscles[m];
      // Give every crossing a posture dependence so r1 and r2 are exercised too.
      for (MomentArmPoly& a : mu.moment_arms) {
        if (!a.crosses) continue;
        a.r1_m_per_rad = 0.003;
        a.r2_m_per_rad2 = -0.002;
      }
      for (int trial = 0; trial < 10; ++trial) {
        const Eigen::Vector3d q(UniformIn(rng, -1.2, 1.2), UniformIn(rng, -0.4, 1.6),
                                UniformIn(rng, 0.0, 1.8));
        const Eigen::Vector3d r = GeneralisedMomentArms(mu, q, p.body.dip_pip_ratio);
        for (int j = 0; j < 3; ++j) {
          Eigen::Vector3d dq = Eigen::Vector3d::Zero();
          dq[j] = kFdStep;
          const double fd = -(MusculotendonLength(mu, q + dq, p.body.dip_pip_ratio) -
                              MusculotendonLength(mu, q - dq, p.body.dip_pip_ratio)) /
                            (2 * kFdStep);
          EXPECT_NEAR(r[j], fd, kMomentArmTolM) << kMuscleNames[m] << " joint " << j;
        }
      }
    }
  }
}

TEST(ForeignMuscle, CrossingsAreAnatomical) {
  const Person p = NominalPerson();
  auto crosses = [&](int m, int j) { return p.muscles[m].moment_arms[j].crosses; };
  for (int m = 0; m < kNumMuscles; ++m) EXPECT_TRUE(crosses(m, kWristCrossing));
  for (int m : {kEcr, kEcu, kFcr, kFcu}) {
    for (int j : {kMcpCrossing, kPipCrossing, kDipCrossing}) EXPECT_FALSE(crosses(m, j));
  }
  for (int j : {kMcpCrossing, kPipCrossing, kDipCrossing}) {
    EXPECT_TRUE(crosses(kEdc, j));
    EXPECT_TRUE(crosses(kFdp, j));
  }
  EXPECT_TRUE(crosses(kFds, kPipCrossing));
  EXPECT_FALSE(crosses(kFds, kDipCrossing));  // FDS inserts on the middle phalanx
  // Signs at q = 0: flexors r > 0, extensors r < 0 (r = −∂l_MT/∂q).
  for (int m = 0; m < kNumMuscles; ++m) {
    const double r0 = p.muscles[m].moment_arms[kWristCrossing].r0_m;
    EXPECT_EQ(r0 > 0, !IsExtensor(m)) << kMuscleNames[m];
  }
}

TEST(ForeignMuscle, DipCrossingActsThroughTheCoupling) {
  MuscleParams m;
  m.moment_arms[kDipCrossing] = {true, 0.005, 0.0, 0.0};
  const Eigen::Vector3d r = GeneralisedMomentArms(m, Eigen::Vector3d(0, 0, 0.4), 2.0 / 3.0);
  EXPECT_NEAR(r[2], 2.0 / 3.0 * 0.005, kExactTol);
  EXPECT_NEAR(MusculotendonLength(m, Eigen::Vector3d(0, 0, 0.6), 2.0 / 3.0),
              m.contraction.mt_length_at_zero_m - 0.005 * 0.4, kExactTol);
}

TEST(ForeignMuscle, RecruitmentHasThresholdSaturationAndIsMonotone) {
  const RecruitmentParams r{60.0, 260.0, 0.35};
  EXPECT_EQ(Recruitment(r, 0.0), 0.0);
  EXPECT_EQ(Recruitment(r, 60.0), 0.0);
  EXPECT_NEAR(Recruitment(r, 160.0), 0.175, kExactTol);  // smoothstep(½) = ½
  EXPECT_NEAR(Recruitment(r, 260.0), 0.35, kExactTol);
  EXPECT_NEAR(Recruitment(r, 300.0), 0.35, kExactTol);
  double prev = -1.0;
  for (double u = 0.0; u <= 300.0; u += 0.5) {
    const double w = Recruitment(r, u);
    EXPECT_GE(w, prev);
    prev = w;
  }
  // Flat ends: zero slope at threshold and saturation (C¹ curve).
  EXPECT_NEAR(Recruitment(r, 60.001) / 0.001, 0.0, 1e-4);
  EXPECT_NEAR((0.35 - Recruitment(r, 259.999)) / 0.001, 0.0, 1e-4);
}

/// The two-stage cascade driven by a constant input from a state; returns a(t).
double CascadeResponse(double input, double e0, double a0, const ActivationParams& p, double t) {
  double x[2] = {e0, a0};
  Rk4 rk4(2);
  const OdeFunction f = [&](double, const double* s, double* ds) {
    ds[0] = FirstOrderRate(input, s[0], p.coupling_activation_tau_s, p.coupling_deactivation_tau_s);
    ds[1] = FirstOrderRate(s[0], s[1], p.force_activation_tau_s, p.force_deactivation_tau_s);
  };
  rk4.Integrate(f, 0.0, t, kRk4StepS, x);
  return x[1];
}

/// Closed-form step response of two first-order lags τ1 then τ2 (τ1 ≠ τ2) from rest to 1.
double TwoLagStep(double t1, double t2, double t) {
  return 1.0 - (t1 * std::exp(-t / t1) - t2 * std::exp(-t / t2)) / (t1 - t2);
}

TEST(ForeignMuscle, ActivationStepResponsesMatchTheTimeConstantsAnalytically) {
  const ActivationParams p;  // defaults
  for (double t : {0.05, 0.1, 0.2, 0.4, 0.8}) {
    // Rise from rest: both stages rise, so the activation constants apply.
    EXPECT_NEAR(CascadeResponse(1.0, 0.0, 0.0, p, t),
                TwoLagStep(p.coupling_activation_tau_s, p.force_activation_tau_s, t),
                kStepResponseTol);
    // Fall from steady state: both stages fall, so the deactivation constants apply.
    EXPECT_NEAR(CascadeResponse(0.0, 1.0, 1.0, p, t),
                1.0 - TwoLagStep(p.coupling_deactivation_tau_s, p.force_deactivation_tau_s, t),
                kStepResponseTol);
  }
  // Activation is faster than deactivation, and the rise (10–90 %) is of the order of FES's
  // 0.1–0.3 s (numerically from the closed form).
  auto rise = [](double t1, double t2) {
    double t10 = -1, t90 = -1;
    for (double t = 0; t < 5.0; t += 1e-4) {
      const double a = TwoLagStep(t1, t2, t);
      if (t10 < 0 && a >= 0.1) t10 = t;
      if (t90 < 0 && a >= 0.9) t90 = t;
    }
    return t90 - t10;
  };
  const double up = rise(p.coupling_activation_tau_s, p.force_activation_tau_s);
  const double down = rise(p.coupling_deactivation_tau_s, p.force_deactivation_tau_s);
  EXPECT_GT(up, 0.1);
  EXPECT_LT(up, 0.5);
  EXPECT_GT(down, up);
}

TEST(ForeignMuscle, ForceLengthIsAParabolaOfWidthW) {
  EXPECT_NEAR(ForceLength(1.0, 0.56), 1.0, kExactTol);
  EXPECT_NEAR(ForceLength(1.28, 0.56), 0.75, kExactTol);
  EXPECT_EQ(ForceLength(0.44, 0.56), 0.0);
  EXPECT_EQ(ForceLength(1.6, 0.56), 0.0);
  EXPECT_EQ(ForceLength(0.3, 0.56), 0.0);
}

TEST(ForeignMuscle, ForceVelocityIsHillsHyperbolaAndSmoothAtZero) {
  const double k = 0.25, fe = 1.8;
  EXPECT_NEAR(ForceVelocity(0.0, k, fe), 1.0, kExactTol);
  EXPECT_NEAR(ForceVelocity(-1.0, k, fe), 0.0, kExactTol);
  EXPECT_EQ(ForceVelocity(-1.5, k, fe), 0.0);
  // Hill: (F + a)(v + b) = (F0 + a) b with a = k F0, b = k v_max.
  for (double x : {0.1, 0.3, 0.6}) {
    const double f = ForceVelocity(-x, k, fe);
    EXPECT_NEAR((f + k) * (x + k), (1 + k) * k, kExactTol);
  }
  EXPECT_NEAR(ForceVelocity(1e6, k, fe), fe, 1e-5);
  const double h = 1e-7;
  const double left = (1.0 - ForceVelocity(-h, k, fe)) / h;
  const double right = (ForceVelocity(h, k, fe) - 1.0) / h;
  EXPECT_NEAR(left, ForceVelocityMaxSlope(k), 1e-5);
  EXPECT_NEAR(right, ForceVelocityMaxSlope(k), 1e-5);
}

TEST(ForeignMuscle, PassiveForceIsTheGradientOfItsEnergy) {
  ContractionParams c;
  c.max_force_n = 120;
  c.optimal_fibre_length_m = 0.05;
  for (double lm = 0.03; lm < 0.08; lm += 0.002) {
    const double h = 1e-7;
    const double fd = (PassiveFibreEnergy(c, lm + h) - PassiveFibreEnergy(c, lm - h)) / (2 * h);
    EXPECT_NEAR(
        c.max_force_n * PassiveFibreForce(lm / c.optimal_fibre_length_m, c.passive_coefficient), fd,
        1e-5);
  }
  // MuscleForce composes the curves: at l_opt, isometric, a = 0.5, capacity 0.8 → 0.4 F_max.
  EXPECT_NEAR(MuscleForce(c, 0.5, 0.8, c.optimal_fibre_length_m, 0.0), 0.4 * 120, 1e-12);
}

TEST(ForeignMuscle, ValidationNamesTheField) {
  MuscleParams m;
  m.recruitment.saturation_us = 10.0;  // below the threshold
  try {
    ValidateMuscle(m, "person.muscles.ecr");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("person.muscles.ecr.recruitment.saturation_us"),
              std::string::npos);
  }
  MuscleParams n;
  n.moment_arms[kMcpCrossing].r0_m = 0.01;  // not crossing, yet a moment arm
  EXPECT_THROW(ValidateMuscle(n, "m"), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::foreign
