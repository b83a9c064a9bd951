// Scenario files (YAML) → validated parameter structs (PRODUCT.md "Scenario and trial files").
//
// A scenario describes one virtual participant on one rig and the trial to run. Every key is
// optional unless marked; unknown keys, wrong types and out-of-range values are errors whose
// one-line message names the file, the key path and the allowed range, e.g.
//   scenarios/x.yaml: coordinates.elbow_flexion.initial_deg: 200 is outside [0, 150]
// Angles are written in degrees at this edge (keys ending in _deg) and stored in rad.
//
//   name: text                                   (required)
//   participant: {height_m: 1.2–2.2, mass_kg: 30–150}
//   gravity_m_s2: [x, y, z]
//   coordinates:
//     <coordinate>: {mode: free|locked|prescribed, initial_deg, initial_speed_deg_s,
//                    rest_deg, min_deg, max_deg, stiffness_nm_per_rad, damping_nms_per_rad,
//                    limit_stiffness_nm_per_rad, limit_sharpness_per_rad, coulomb_friction_nm,
//                    static_friction_nm, stribeck_velocity_rad_s (stiction),
//                    reflex_gain_nms_per_rad, reflex_threshold_deg_s, reflex_direction_bias
//                    (spasticity), prescription: {offset_deg, amplitude_deg, frequency_hz,
//                    phase_deg}}
//   muscles:
//     <muscle>: {max_isometric_force_n, optimal_fibre_length_m, tendon_slack_length_m,
//                pennation_deg, omega_rad_s, alpha, beta_per_us, gamma}
//   electrodes:
//     array: {rows, cols, pitch_m, origin_m: [along, around], spread_m,
//             motor_points: {<muscle>: [along_m, around_m]}}
//     channels: [{name, pads: [int…], muscles: {<muscle>: weight}}]   (replaces the default)
//   support:
//     bands: [{segment, cuff_m: [x,y,z], anchor_m: [x,y,z], stiffness_n_per_m, slack_length_m}]
//     weight_compensation: [{segment, cuff_m: [x,y,z], force_n}]
//   mechanisms:                                  (each block present = switched on;
//   sim/mechanisms.h)
//     fatigue: {fatigue_time_s, recovery_time_s, min_fitness}
//     potentiation: {gain, rise_time_s, decay_time_s}
//     electromechanical_delay_s: 0–1
//     tremor: {coordinate, frequency_hz: 3–12, amplitude_nm, amplitude_modulation,
//              modulation_hz, frequency_drift_hz_per_s, phase_deg}
//     crosstalk: {fraction: 0–1, spread_m}
//     stretch_reflex: {gain: 0–10, threshold_per_s: 0–10, loop_delay_s: 0.001–1,
//                      muscles: [<muscle>…]}
//   stimulation:
//     duration_s: > 0                            (required)
//     type: constant | steps | csv | protocol | reaching   (required)
//     values_us: {<channel>: 0–300}              (constant)
//     steps: [{time_s, values_us: {<channel>: µs}}]   (steps; channels not named are 0)
//     file: path relative to the scenario, u.<channel> columns held until the next row (csv)
//     protocol: {name: step_grid|ramp|staircase|filtered_noise|prms|multisine|shoulder_steps,
//                channel(s), u_min_us, u_max_us, u_sum_max_us, seed, …} (protocols/protocols.h)
//     reaching: {repetitions, reach_duration_s, hold_s, pause_s, transfer_duration_s,
//                sample_rate_hz, homes_m: [[x, y, z]…], targets_m: [[x, y, z]…],
//                paths: [{home: index, target: index}…]}  ([Schearer 2014]; paths: the
//                home–target pairs run, in order, each at most once; default every pair)
//   sensors:
//     angles:     {rate_hz, noise_std_deg, coordinates: [<coordinate>…], offset_drift_deg_per_s,
//                  dropout_probability, dropout_mean_samples, outlier_probability, outlier_std_deg}
//     velocities: {rate_hz, noise_std_deg_s, coordinates: […], … the same with _deg_s}
//     torques:    {rate_hz, noise_std_nm, coordinates: […], … with _nm}  (locked/prescribed)
//     any sensor: baseline_window_s (subtract the mean of [0, window) — [Le 2010]'s offset
//                 removal from the rest period)
//     truth_rate_hz
//     With stimulation type reaching the block is instead (sim/reaching.h "Measurement"; without
//     it the reaches are noiseless):
//     angles: {noise_std_deg, lowpass_hz}   joint angles; lowpass_hz: zero-phase Butterworth
//                                           cutoff before differentiation, [0, rate/2), 0 = none
//     force:  {noise_std_n, lowpass_hz}     the robot's force sensor, N per axis; the low-pass
//                                           filters the joint torques
//   integrator: {method: cvodes|cvodes-adams|simbody-rkm, tolerance: 1e-12–1e-2}
//               (defaults: cvodes, and the rig's trial-generation tolerance,
//               sim::TrialGenerationTolerance: 3e-4; 1e-6 with a tremor or friction)
#pragma once

#include <optional>
#include <string>

#include "protocols/protocols.h"
#include "sim/model_params.h"
#include "sim/trial_runner.h"

namespace fesim {

struct Scenario {
  std::string name;
  std::string path;         ///< file it was loaded from.
  std::string source_text;  ///< the file's bytes (hashed into the manifest).
  sim::ModelParams model;   ///< the participant and rig.
  sim::TrialRequest trial;  ///< stimulation, duration, sensors, integrator.
  /// Robot-driven reaching (stimulation type `reaching`, [Schearer 2014]): the arm is moved along
  /// the hand path with muscles relaxed; `fesim simulate` writes one trial per reach.
  std::optional<protocols::ReachingParams> reaching;
};

/// Loads and validates a scenario. Throws std::runtime_error with the one-line message above.
Scenario LoadScenario(const std::string& path);

/// Parses scenario text; `path` names it in messages and anchors relative file names.
Scenario ParseScenario(const std::string& text, const std::string& path);

}  // namespace fesim
