#include "foreign/integrator.h"

#include <algorithm>
#include <cmath>

#include "foreign/check.h"

namespace fesim::foreign {

Rk4::Rk4(int n) : n_(n) {
  CheckRange(n, 1, 1e6, "Rk4 state dimension");
  for (auto* v : {&k1_, &k2_, &k3_, &k4_, &tmp_}) v->assign(n, 0.0);
}

void Rk4::Step(const OdeFunction& f, double t, double h, double* x) {
  const int n = n_;
  f(t, x, k1_.data());
  for (int i = 0; i < n; ++i) tmp_[i] = x[i] + 0.5 * h * k1_[i];
  f(t + 0.5 * h, tmp_.data(), k2_.data());
  for (int i = 0; i < n; ++i) tmp_[i] = x[i] + 0.5 * h * k2_[i];
  f(t + 0.5 * h, tmp_.data(), k3_.data());
  for (int i = 0; i < n; ++i) tmp_[i] = x[i] + h * k3_[i];
  f(t + h, tmp_.data(), k4_.data());
  for (int i = 0; i < n; ++i) x[i] += h / 6.0 * (k1_[i] + 2.0 * (k2_[i] + k3_[i]) + k4_[i]);
}

int StepCount(double span, double max_step) {
  CheckAbove(max_step, 0.0, 1e9, "max_step");
  return std::max(1, static_cast<int>(std::ceil(span / max_step * (1.0 - 1e-9))));
}

void Rk4::Integrate(const OdeFunction& f, double t0, double t1, double max_step, double* x) {
  const int steps = StepCount(t1 - t0, max_step);
  const double h = (t1 - t0) / steps;
  for (int k = 0; k < steps; ++k) Step(f, t0 + k * h, h, x);
}

}  // namespace fesim::foreign
