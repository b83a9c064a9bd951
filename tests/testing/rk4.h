// One classical fourth-order Runge–Kutta step, for tests that integrate a small ODE themselves as
// an independent reference for the simulator's own integration.
#pragma once

#include <array>
#include <cstddef>

namespace fesim::test_util {

/// x(t + h) from x(t) for ẋ = f(t, x), f returning std::array<double, N>.
template <std::size_t N, typename F>
std::array<double, N> Rk4Step(const F& f, double t, const std::array<double, N>& x, double h) {
  auto along = [&](const std::array<double, N>& k, double s) {
    std::array<double, N> y;
    for (std::size_t i = 0; i < N; ++i) y[i] = x[i] + s * k[i];
    return y;
  };
  const auto k1 = f(t, x);
  const auto k2 = f(t + 0.5 * h, along(k1, 0.5 * h));
  const auto k3 = f(t + 0.5 * h, along(k2, 0.5 * h));
  const auto k4 = f(t + h, along(k3, h));
  std::array<double, N> out;
  for (std::size_t i = 0; i < N; ++i)
    out[i] = x[i] + h / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
  return out;
}

}  // namespace fesim::test_util
