// Linear activation dynamics H_LAD ([Hand Hammerstein] eq. 5–6): a critically damped
// second-order system per muscle,
//
//   H_LAD,i(s) = Ω_i² / (s² + 2Ω_i s + Ω_i²)   ⇔   ä = Ω²(w − a) − 2Ω ȧ.
//
// Each muscle has its own natural frequency Ω_i ([Hand Hammerstein] Assumption 6, equal Ω, is a
// reduced-model assumption that the ground truth deliberately does not make).
#pragma once

namespace fesim::muscles {

/// State of one muscle's activation dynamics.
struct ActivationState {
  double a = 0.0;      ///< activation a, dimensionless (0–1 in normal use).
  double a_dot = 0.0;  ///< da/dt, 1/s.
};

/// Time derivative of the state for recruited input w (dimensionless) and natural frequency
/// omega_rad_s (rad/s, > 0), eq. (6) in state-space form. Returns {ȧ, ä}.
ActivationState ActivationDerivative(double omega_rad_s, double w, const ActivationState& s);

/// Analytic response from rest to a step of height w applied at t = 0:
///   a(t) = w (1 − (1 + Ωt) e^{−Ωt}),  ȧ(t) = w Ω² t e^{−Ωt}.   t in s (≥ 0).
ActivationState ActivationStepResponse(double omega_rad_s, double w, double t_s);

/// Exact state after t_s seconds of constant input w from the state `initial` (the general
/// solution of eq. (6)): with e = a − w,
///   e(t) = (e₀ + (ė₀ + Ω e₀) t) e^{−Ωt},   ė(t) = (ė₀ − Ω (ė₀ + Ω e₀) t) e^{−Ωt}.
/// Stimulation is piecewise constant, so the integrator uses this instead of integrating
/// the activation states numerically (an exponential integrator for this linear block).
ActivationState ActivationFreeResponse(double omega_rad_s, double w, const ActivationState& initial,
                                       double t_s);

/// Ω of eq. (6) for one interval of constant recruited input w that starts at the state `start`:
/// omega_rad_s when w ≥ start.a (recruitment rising or held), omega_rad_s × deactivation_ratio when
/// w < start.a (falling). Muscles deactivate more slowly than they activate (first-order
/// activation with τ_deact ≈ 2–4 τ_act: Zajac 1989, Crit Rev Biomed Eng 17(4) 359–411; Thelen 2003,
/// J Biomech Eng 125(1) 70–77); eq. (6) is symmetric, and a ratio of 1 keeps it so. Ω is constant
/// within the interval, so ActivationFreeResponse stays its exact solution; (a, ȧ) stay continuous
/// where Ω switches.
double IntervalOmega(double omega_rad_s, double deactivation_ratio, double w,
                     const ActivationState& start);

/// True when IntervalOmega takes the falling Ω: the input w is below the activation at the start.
inline bool Deactivating(double w, const ActivationState& start) { return w < start.a; }

}  // namespace fesim::muscles
