// Isometric recruitment curve H_IRC ([Hand Hammerstein] eq. 2–3).
//
//   w = α (e^{βv} − 1) / (e^{βv} + γ)
//
// v is the effective stimulation a muscle experiences (µs of pulse width after the electrode
// array A, eq. 1); w is the recruited fraction 0 ≤ w < α ≤ 1. Departures from the paper: v < 0
// (not physical) is treated as 0, and the expression is evaluated as (1 − e^{−βv})/(1 + γe^{−βv})
// for βv > 0 so that it never overflows.
#pragma once

namespace fesim::muscles {

/// Parameters of eq. (3) for one muscle.
struct RecruitmentParams {
  double alpha = 1.0;         ///< saturation level α, dimensionless, (0, 1].
  double beta_per_us = 0.03;  ///< steepness β, 1/µs, > 0.
  double gamma = 50.0;        ///< shape γ, dimensionless, > 0 (larger: later, steeper onset).
};

/// Recruited fraction w (dimensionless, 0 ≤ w < α) at effective stimulation v_us (µs), eq. (3).
double Recruitment(const RecruitmentParams& p, double v_us);

/// ∂w/∂v, 1/µs (used by tests and gradient-based fits).
double RecruitmentSlope(const RecruitmentParams& p, double v_us);

}  // namespace fesim::muscles
