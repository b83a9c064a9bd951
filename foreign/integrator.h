// Fixed-step classical Runge–Kutta (RK4, Kutta 1901) for the foreign simulator: local error
// O(h⁵), global O(h⁴); stable for a real eigenvalue λ < 0 when h|λ| < 2.785 and on the imaginary
// axis when h|λ| < 2√2.
#pragma once

#include <functional>
#include <vector>

namespace fesim::foreign {

/// dx/dt = f(t, x): writes n derivatives to dx.
using OdeFunction = std::function<void(double t, const double* x, double* dx)>;

/// One RK4 integrator with its work arrays (reused, no allocation per step).
class Rk4 {
 public:
  /// n: state dimension, ≥ 1 (throws std::invalid_argument otherwise).
  explicit Rk4(int n);
  /// x(t) → x(t + h) in place.
  void Step(const OdeFunction& f, double t, double h, double* x);
  /// From t0 to t1 in ceil((t1 − t0)/max_step) equal steps (at least one); max_step > 0.
  void Integrate(const OdeFunction& f, double t0, double t1, double max_step, double* x);

 private:
  int n_;
  std::vector<double> k1_, k2_, k3_, k4_, tmp_;
};

/// Number of equal steps of at most max_step that cover span (≥ 1; a tolerance of 1e-9 relative
/// keeps span = k·max_step at k steps).
int StepCount(double span, double max_step);

}  // namespace fesim::foreign
