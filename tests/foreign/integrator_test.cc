// Tests of foreign/integrator.h: classical RK4 is fourth-order accurate and its real-axis
// stability limit is h|λ| ≈ 2.785.
#include "foreign/integrator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace fesim::foreign {
namespace {

constexpr double kOrderTol = 0.3;  // observed order within 4 ± this

/// Error at t = 2 of the harmonic oscillator x'' = −ω² x integrated with n steps.
double OscillatorError(int n) {
  const double w = 3.0;
  double x[2] = {1.0, 0.0};
  Rk4 rk4(2);
  const OdeFunction f = [w](double, const double* s, double* ds) {
    ds[0] = s[1];
    ds[1] = -w * w * s[0];
  };
  rk4.Integrate(f, 0.0, 2.0, 2.0 / n, x);
  return std::hypot(x[0] - std::cos(w * 2.0), x[1] + w * std::sin(w * 2.0));
}

TEST(ForeignIntegrator, Rk4IsFourthOrder) {
  const double e1 = OscillatorError(100), e2 = OscillatorError(200);
  EXPECT_NEAR(std::log2(e1 / e2), 4.0, kOrderTol);
  EXPECT_LT(e2, 1e-6);
}

TEST(ForeignIntegrator, Rk4ExactForCubicTimeSources) {
  // x' = t³: RK4 (Simpson's rule for a source in t only) integrates cubics exactly.
  double x = 0.0;
  Rk4 rk4(1);
  const OdeFunction f = [](double t, const double*, double* dx) { dx[0] = t * t * t; };
  rk4.Integrate(f, 0.0, 2.0, 0.7, &x);
  EXPECT_NEAR(x, 4.0, 1e-12);
}

TEST(ForeignIntegrator, Rk4RealAxisStabilityLimit) {
  auto amplification = [](double h_lambda) {
    double x = 1.0;
    Rk4 rk4(1);
    const OdeFunction f = [h_lambda](double, const double* s, double* ds) {
      ds[0] = -h_lambda * s[0];
    };
    rk4.Step(f, 0.0, 1.0, &x);
    return std::abs(x);
  };
  EXPECT_LT(amplification(2.0), 1.0);
  EXPECT_LT(amplification(2.78), 1.0);
  EXPECT_GT(amplification(2.79), 1.0);
}

TEST(ForeignIntegrator, StepCountCoversTheSpan) {
  EXPECT_EQ(StepCount(1.0, 0.25), 4);
  EXPECT_EQ(StepCount(1.0, 0.3), 4);
  EXPECT_EQ(StepCount(0.01, 1.0), 1);
  EXPECT_EQ(StepCount(0.0, 1.0), 1);
  EXPECT_THROW(StepCount(1.0, 0.0), std::invalid_argument);
  EXPECT_THROW(Rk4(0), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::foreign
