// One virtual trial: integrate the model under a stimulation schedule, sample the sensors with
// their noise, and return the measured trial plus the noiseless truth (PRODUCT.md "Trial files").
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "base/trial.h"
#include "sim/integrator.h"
#include "sim/model_params.h"
#include "sim/upper_limb_model.h"

namespace fesim::sim {

struct TrialRequest {
  std::string name = "trial";
  double duration_s = 5.0;          ///< > 0.
  StimulationSchedule stimulation;  ///< per channel, µs.
  SensorSuite sensors;
  IntegratorParams integrator;
  std::uint64_t seed = 1;  ///< sensor noise seed.
  /// Instants (s) at which the protocol takes steady-state samples (step grid); written to the
  /// trial metadata as `steady_state_times_s` so identifiers can find them.
  std::vector<double> steady_state_times_s;
};

struct TrialResult {
  /// What the rig records: u.<channel> (µs), q.<coordinate> (rad, angle sensor), qd.<coordinate>
  /// (rad/s, velocity sensor), tau.<coordinate> (N·m, torque sensor on locked/prescribed
  /// coordinates); NaN where a sensor did not sample.
  Trial measured;
  /// Noiseless ground truth at SensorSuite::truth_rate_hz: u.*, q.* and qd.* of every
  /// coordinate, a.<muscle>, f.<muscle> (N), tau_muscle.<coordinate> (R f, N·m) and tau.* of the
  /// sensor-equipped coordinates without noise.
  Trial truth;
  IntegrationStats stats;
  bool fibre_clamped = false;  ///< some fibre reached its minimum length during the trial.
};

/// The stimulation as the muscles receive it: `commanded` delayed by the model's
/// electromechanical delay (mechanisms.electromechanical_delay_s). RunTrial integrates this and
/// records `commanded`; a simulation of a recorded trial does the same.
StimulationSchedule MuscleStimulation(const ModelParams& model,
                                      const StimulationSchedule& commanded);

/// Runs one trial from the model's initial state. Throws std::runtime_error on integration
/// failure (message names the time and coordinate).
/// `progress`, when given, is called with the fraction of simulated time done (0–1).
TrialResult RunTrial(const UpperLimbModel& model, const TrialRequest& request,
                     const std::function<void(double)>& progress = nullptr);

}  // namespace fesim::sim
