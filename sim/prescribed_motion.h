// Prescribed coordinate trajectories from samples (robot-driven reaching,
// [Schearer 2014] §II.A: the robot drives the hand along smooth trajectories, so
// the joints follow smooth trajectories too).
//
// QuinticHermiteSpline interpolates samples (t_k, q_k, q̇_k, q̈_k) by one quintic per interval
// that matches value, first and second derivative at both ends, so q(t) is C² and reproduces the
// samples exactly. With s = (t − t_k)/h, h = t_{k+1} − t_k, and the scaled end data
// V = h q̇, A = h² q̈, Δ = q_{k+1} − q_k:
//   q(s) = c0 + c1 s + c2 s² + c3 s³ + c4 s⁴ + c5 s⁵, c0 = q_k, c1 = V_k, c2 = A_k/2,
//   c3 = 10Δ − 6V_k − 4V_{k+1} − (3A_k − A_{k+1})/2,
//   c4 = −15Δ + 8V_k + 7V_{k+1} + (3A_k − 2A_{k+1})/2,
//   c5 = 6Δ − 3V_k − 3V_{k+1} − (A_k − A_{k+1})/2.
// Outside [t_0, t_N] the end value is held with zero velocity and acceleration (C² there only when
// the end samples are at rest, as reaching paths are).
//
// TableMotion is the thin Simbody adapter (Motion::Custom at Position level) that prescribes one
// pin coordinate along such a spline.
#pragma once

#include <Simbody.h>

#include <array>
#include <vector>

#include "sim/model_params.h"

namespace fesim::sim {

/// q, q̇, q̈ of a prescribed coordinate at one instant.
struct PrescribedSample {
  double q = 0.0;    ///< rad.
  double qd = 0.0;   ///< rad/s.
  double qdd = 0.0;  ///< rad/s².
};

class QuinticHermiteSpline {
 public:
  /// Throws std::invalid_argument when the four vectors differ in length, hold fewer than 2
  /// samples, times are not strictly increasing or a value is not finite.
  explicit QuinticHermiteSpline(const TablePrescription& table);

  PrescribedSample Evaluate(double t_s) const;
  double start_s() const { return t_.front(); }
  double end_s() const { return t_.back(); }

 private:
  std::vector<double> t_;                 // knot times, s
  std::vector<std::array<double, 6>> c_;  // monomial coefficients in s per interval
  PrescribedSample first_, last_;
};

/// Simbody Motion (Position level) prescribing one coordinate along a QuinticHermiteSpline.
class TableMotion : public SimTK::Motion::Custom::Implementation {
 public:
  explicit TableMotion(const TablePrescription& table) : spline_(table) {}
  SimTK::Motion::Level getLevel(const SimTK::State& /*s*/) const override {
    return SimTK::Motion::Position;
  }
  void calcPrescribedPosition(const SimTK::State& s, int /*nq*/, SimTK::Real* q) const override {
    *q = spline_.Evaluate(s.getTime()).q;
  }
  void calcPrescribedPositionDot(const SimTK::State& s, int /*nq*/,
                                 SimTK::Real* qd) const override {
    *qd = spline_.Evaluate(s.getTime()).qd;
  }
  void calcPrescribedPositionDotDot(const SimTK::State& s, int /*nq*/,
                                    SimTK::Real* qdd) const override {
    *qdd = spline_.Evaluate(s.getTime()).qdd;
  }

 private:
  QuinticHermiteSpline spline_;
};

}  // namespace fesim::sim
