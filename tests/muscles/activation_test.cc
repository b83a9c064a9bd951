#include "muscles/activation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

namespace fesim::muscles {
namespace {

constexpr double kRk4Step = 1e-4;  // s
constexpr double kTol = 1e-10;

/// One classical Runge–Kutta step of eq. (6) with constant input w.
ActivationState Rk4Step(double omega, double w, const ActivationState& s) {
  const auto f = [&](const ActivationState& x) { return ActivationDerivative(omega, w, x); };
  const auto add = [](ActivationState x, ActivationState d, double h) {
    return ActivationState{x.a + h * d.a, x.a_dot + h * d.a_dot};
  };
  const auto k1 = f(s);
  const auto k2 = f(add(s, k1, kRk4Step / 2));
  const auto k3 = f(add(s, k2, kRk4Step / 2));
  const auto k4 = f(add(s, k3, kRk4Step));
  return {s.a + kRk4Step / 6 * (k1.a + 2 * k2.a + 2 * k3.a + k4.a),
          s.a_dot + kRk4Step / 6 * (k1.a_dot + 2 * k2.a_dot + 2 * k3.a_dot + k4.a_dot)};
}

TEST(Activation, Rk4IntegrationMatchesAnalyticStepResponse) {
  for (double omega : {3.0, 8.0, 15.0}) {
    const double w = 0.7;
    ActivationState s;
    for (int i = 1; i <= 20000; ++i) {  // 2 s
      s = Rk4Step(omega, w, s);
      if (i % 1000 == 0) {
        const auto exact = ActivationStepResponse(omega, w, i * kRk4Step);
        EXPECT_NEAR(s.a, exact.a, kTol);
        EXPECT_NEAR(s.a_dot, exact.a_dot, kTol * omega * omega);
      }
    }
  }
}

TEST(Activation, FreeResponseSolvesTheOdeFromAnyState) {
  // RK4 from a non-rest state with a new input equals the closed form; from rest it is the
  // step response.
  const double omega = 7.0, w = 0.3;
  const ActivationState start{0.6, -1.5};
  ActivationState s = start;
  for (int i = 1; i <= 10000; ++i) {
    s = Rk4Step(omega, w, s);
    if (i % 1000 == 0) {
      const auto exact = ActivationFreeResponse(omega, w, start, i * kRk4Step);
      EXPECT_NEAR(s.a, exact.a, kTol);
      EXPECT_NEAR(s.a_dot, exact.a_dot, kTol * omega * omega);
    }
  }
  const auto step = ActivationStepResponse(omega, w, 0.4);
  const auto free = ActivationFreeResponse(omega, w, {}, 0.4);
  EXPECT_NEAR(step.a, free.a, 1e-15);
  EXPECT_NEAR(step.a_dot, free.a_dot, 1e-14);
}

TEST(Activation, FreeResponseAtRestIsRestBits) {
  // ActivationFreeResponse's shortcut at rest (w, a, ȧ all +0, Ωt ≥ 0) returns what eq. (6)'s
  // closed form gives there, bit for bit; a −0 or a non-zero input takes the formula.
  const auto formula = [](double om, double w, ActivationState s0, double t) {
    const double e0 = s0.a - w;
    const double c = s0.a_dot + om * e0;
    const double decay = std::exp(-om * t);
    return ActivationState{w + (e0 + c * t) * decay, (s0.a_dot - om * c * t) * decay};
  };
  const auto same = [](const ActivationState& x, const ActivationState& y) {
    return std::memcmp(&x.a, &y.a, sizeof(double)) == 0 &&
           std::memcmp(&x.a_dot, &y.a_dot, sizeof(double)) == 0;
  };
  for (double om : {0.0, 3.0, 25.0, -2.0}) {
    for (double t : {0.0, 0.01, 2.0, 700.0, -0.5}) {
      for (const ActivationState s0 : {ActivationState{0.0, 0.0}, ActivationState{-0.0, 0.0},
                                       ActivationState{0.0, -0.0}, ActivationState{0.0, 1e-300}}) {
        for (double w : {0.0, -0.0, 0.2}) {
          EXPECT_TRUE(same(ActivationFreeResponse(om, w, s0, t), formula(om, w, s0, t)))
              << "om " << om << " t " << t << " a " << s0.a << " a_dot " << s0.a_dot << " w " << w;
        }
      }
    }
  }
  const auto rest = ActivationFreeResponse(25.0, 0.0, {}, 0.3);
  EXPECT_EQ(rest.a, 0.0);
  EXPECT_FALSE(std::signbit(rest.a) || std::signbit(rest.a_dot));
}

TEST(Activation, CriticallyDampedNoOvershootUnitGain) {
  const double omega = 5.0, w = 0.5;
  double prev = 0.0;
  for (double t = 0.01; t < 5.0; t += 0.01) {
    const double a = ActivationStepResponse(omega, w, t).a;
    EXPECT_GE(a, prev);
    EXPECT_LT(a, w);
    prev = a;
  }
  EXPECT_NEAR(ActivationStepResponse(omega, w, 20.0).a, w, 1e-12);
}

TEST(Activation, IntervalOmegaSlowsOnlyFallingRecruitment) {
  const double omega = 6.0, ratio = 0.4;
  const ActivationState at{0.5, 0.2};
  EXPECT_EQ(IntervalOmega(omega, ratio, 0.7, at), omega);          // rising
  EXPECT_EQ(IntervalOmega(omega, ratio, 0.5, at), omega);          // held
  EXPECT_EQ(IntervalOmega(omega, ratio, 0.1, at), omega * ratio);  // falling
  EXPECT_EQ(IntervalOmega(omega, 1.0, 0.1, at), omega);            // symmetric
  // Released from a steady activation, a(t) = a₀ (1 + rΩt) e^{−rΩt}: the time to half is
  // 1.678/(rΩ), 1/r times the symmetric one.
  const ActivationState steady{0.8, 0.0};
  const double w_omega = IntervalOmega(omega, ratio, 0.0, steady);
  const double t_half = 1.6783469900166605 / (ratio * omega);
  EXPECT_NEAR(ActivationFreeResponse(w_omega, 0.0, steady, t_half).a, 0.4, 1e-12);
}

}  // namespace
}  // namespace fesim::muscles
