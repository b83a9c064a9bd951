#include "sim/mechanisms.h"

#include <gtest/gtest.h>

#include <cmath>

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

}  // namespace
}  // namespace fesim::sim
