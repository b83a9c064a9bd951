#include "sim/mechanisms.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "tests/testing/rk4.h"

namespace fesim::sim {
namespace {

constexpr double kTol = 1e-12;

TEST(Mechanisms, FitnessHasTheRienerSteadyStateAndRate) {
  const FatigueParams p{true, 20.0, 300.0, 0.3};
  const double a = 0.4;
  const double rate = a / 20.0 + (1 - a) / 300.0;                   // 1/τ
  const double steady = (0.3 * a / 20.0 + (1 - a) / 300.0) / rate;  // φ∞
  EXPECT_NEAR(FitnessDerivative(p, a, steady), 0.0, kTol);
  EXPECT_NEAR(FitnessDerivative(p, a, 1.0), -rate * (1.0 - steady), kTol);  // linear in φ
  EXPECT_NEAR(FitnessDerivative(p, 0.0, 0.5), 0.5 / 300.0, kTol);           // recovery at rest
}

TEST(Mechanisms, PotentiationBuildsWithActivityAndDecaysAtRest) {
  const PotentiationParams p{true, 0.5, 5.0, 60.0};
  EXPECT_GT(PotentiationDerivative(p, 1.0, 0.0), 0.0);
  EXPECT_NEAR(PotentiationDerivative(p, 0.0, 0.6), -0.01, kTol);
  const double steady = (1.0 / 5.0) / (1.0 / 5.0 + 1.0 / 60.0);
  EXPECT_NEAR(PotentiationDerivative(p, 1.0, steady), 0.0, kTol);
}

TEST(Mechanisms, StretchReflexDriveIsASmoothRampAboveThreshold) {
  StretchReflexParams p;
  p.gain = 0.5;
  p.threshold_per_s = 0.1;
  // Far from the threshold the ramp is G·max(0, ṽ − ṽ_th) within G ε²/(4 |ṽ − ṽ_th|) (ε 0.05 /s).
  EXPECT_NEAR(StretchReflexDrive(p, 1.1), 0.5 * 1.0, 0.5 * 0.0025 / 4.0);
  EXPECT_NEAR(StretchReflexDrive(p, -0.9), 0.0, 0.5 * 0.0025 / 4.0);
  EXPECT_NEAR(StretchReflexDrive(p, 0.1), 0.5 * 0.5 * 0.05, kTol);  // G ε / 2 at the threshold
  for (double v = -1.0; v < 1.0; v += 0.01) {
    EXPECT_LT(StretchReflexDrive(p, v), StretchReflexDrive(p, v + 0.01));
  }
  p.gain = 0.0;
  EXPECT_EQ(StretchReflexDrive(p, 2.0), 0.0);
}

TEST(Mechanisms, StretchReflexActivationStepHasUnitGainAndTheCascadesMeanDelay) {
  // Step of drive D from rest through the loop lag τ_d and eq. (6) (Ω): r → D, and the area
  // between D and r is D (τ_d + 2/Ω) — the mean delays of a first-order lag (τ_d) and of a
  // critically damped second-order stage (2/Ω) add.
  StretchReflexParams p;
  p.loop_delay_s = 0.04;
  const double omega = 7.0, drive = 0.3, h = 1e-4;
  std::array<double, 3> x{0.0, 0.0, 0.0};
  double deficit = 0.0;
  auto f = [&](double, const std::array<double, 3>& s) {
    return StretchReflexDerivative(p, omega, drive, s);
  };
  for (int i = 0; i < 100000; ++i) {  // 10 s
    const double before = x[1];
    x = test_util::Rk4Step(f, i * h, x, h);
    deficit += h * (drive - 0.5 * (before + x[1]));  // trapezoid
  }
  EXPECT_NEAR(x[0], drive, 1e-9);
  EXPECT_NEAR(x[1], drive, 1e-9);
  EXPECT_NEAR(deficit, drive * (0.04 + 2.0 / omega), 1e-6);
}

TEST(Mechanisms, TremorIsASinusoidAtItsFrequency) {
  TremorParams p;
  p.enabled = true;
  p.frequency_hz = 6.0;
  p.amplitude_nm = 0.2;
  EXPECT_NEAR(TremorTorque(p, 1.0 / 24.0), 0.2, kTol);  // quarter period
  EXPECT_NEAR(TremorTorque(p, 0.5), 0.0, 1e-12);        // 3 whole periods
  p.enabled = false;
  EXPECT_EQ(TremorTorque(p, 0.1), 0.0);
}

TEST(Mechanisms, ReflexOnlyAboveThresholdAndOpposesMotion) {
  EXPECT_EQ(ReflexTorque(2.0, 1.0, 0.8), 0.0);
  EXPECT_NEAR(ReflexTorque(2.0, 1.0, 1.5), -1.0, kTol);
  EXPECT_NEAR(ReflexTorque(2.0, 1.0, -3.0), 4.0, kTol);
}

TEST(Mechanisms, ReflexDirectionBiasSplitsTheGainBetweenStretchOfFlexorsAndOfExtensors) {
  // β = 1: the flexors alone resist extension (q̇ < 0) at twice the gain, nothing on flexion.
  EXPECT_NEAR(ReflexTorque(2.0, 1.0, -3.0, 1.0), 8.0, kTol);
  EXPECT_EQ(ReflexTorque(2.0, 1.0, 3.0, 1.0), 0.0);
  // β = −1 the mirror image; β = ½: gains 3 and 1, their mean the symmetric G.
  EXPECT_NEAR(ReflexTorque(2.0, 1.0, 3.0, -1.0), -8.0, kTol);
  EXPECT_EQ(ReflexTorque(2.0, 1.0, -3.0, -1.0), 0.0);
  EXPECT_NEAR(ReflexTorque(2.0, 1.0, -3.0, 0.5), 6.0, kTol);
  EXPECT_NEAR(ReflexTorque(2.0, 1.0, 3.0, 0.5), -2.0, kTol);
  // Dissipative for every β in [−1, 1]: τ q̇ ≤ 0.
  for (const double beta : {-1.0, -0.3, 0.0, 0.7, 1.0}) {
    for (const double qd : {-4.0, -1.2, 1.2, 4.0})
      EXPECT_LE(ReflexTorque(2.0, 1.0, qd, beta) * qd, 0.0);
  }
}

}  // namespace
}  // namespace fesim::sim
