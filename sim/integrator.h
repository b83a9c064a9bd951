// Integration of an UpperLimbModel's state through a trial.
//
// Default: SUNDIALS CVODES, variable-order BDF with a dense direct linear solver (difference-
// quotient Jacobian), over the whole Simbody state y = [q, u, z] (z: activation states). Simbody
// supplies ẏ through realize(Acceleration). Stimulation is piecewise constant (the 40 Hz pulse
// width held between pulses); every change is a breakpoint at which CVODES stops exactly
// (CVodeSetStopTime), so no step straddles a discontinuity; the muscle activations are solved in
// closed form per interval, which keeps the right-hand side seen by CVODES continuous there.
// Cross-check: Simbody's Runge–Kutta–Merson integrator over the same segments.
#pragma once

#include <Simbody.h>

#include <functional>
#include <string>
#include <vector>

#include "sim/model_params.h"
#include "sim/upper_limb_model.h"

namespace fesim::sim {

/// Piecewise-constant stimulation: values[k] (µs per channel) holds from times[k] (s) until
/// times[k + 1]; before times[0] the stimulation is zero. times strictly increasing.
struct StimulationSchedule {
  std::vector<double> times;
  std::vector<std::vector<double>> values;
  /// Value at t (zero-order hold).
  std::vector<double> At(double t, int channels) const;
};

struct IntegrationStats {
  long steps = 0;            ///< internal integrator steps.
  long rhs_evaluations = 0;  ///< ẏ evaluations (Simbody realize(Acceleration) calls).
  long jacobian_evaluations = 0;
  long breakpoints = 0;  ///< stimulation changes crossed (exact integrator stops).
};

/// Called at each report time with the state realised to the requested stage.
using Observer = std::function<void(const SimTK::State&)>;

/// Advances `state` (at its current time) through `report_times` (sorted, ≥ state time),
/// applying the schedule's stimulation changes, and calls `observer` at each report time with
/// the state realised to `observe_stage` (Velocity suffices for kinematics and muscle forces;
/// Acceleration is needed for sensor torques; Stage::Time suffices to read q and u, and saves the
/// kinematics at every report time). Throws std::runtime_error naming the simulated
/// time and the integrator's reason on failure.
IntegrationStats IntegrateTrial(const UpperLimbModel& model, const IntegratorParams& params,
                                const StimulationSchedule& schedule,
                                const std::vector<double>& report_times, SimTK::State* state,
                                const Observer& observer,
                                SimTK::Stage observe_stage = SimTK::Stage::Acceleration);

}  // namespace fesim::sim
