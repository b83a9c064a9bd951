// Planted-effect data sets for testing `fesim diagnose` (issue 7, "Tests that hide an effect and
// require finding it"): virtual trials from the ground-truth simulator with a participant that
// differs from the rig's nominal one, a stimulation protocol, sensor noise, and zero, one or two
// mechanisms switched on — which the diagnosis is not told.
//
// Participant: the rig's model with ApplyParticipant (scenarios/study.h) stiffness_scale and
// strength_scale drawn uniformly in [0.8, 1.25] (other draws at 1).
// Protocols (two channels, by default the ext/flex array channels of the hand rig): "steps" —
// pseudo-random levels {0, 1, …, 5} · u_max / 6 per channel held U(1, 3) s (step times on the
// record's sample grid), Σu ≤ u_max (300 µs: levels 0, 50, …, 250 µs); "grid" — paper 000's step
// grid (u_max / 6 spacing, Σu ≤ u_max) with 2 s steps, order alternating between trials.
// Planted strengths at effect_scale s (chosen so that s = 1 gives an effect RMS of the order of the
// 1° sensor noise RMS on the hand rig; the generator reports the measured ratio):
//   fatigue        T_fat = 5 s / s                   potentiation  g = 2.0 s
//   delay          δ = 0.07 s · s                    tremor        A = 0.08 s N·m on the wrist,
//                                                                  f ∈ [5, 8] Hz, φ seeded
//   crosstalk      c = 0.06 s (at 0.015 s the effect RMS is ≈ the noise RMS, but 95 % of it is
//                  absorbed by the subject calibration: strength and input scales)
//                                                    moment_arm_posture  ρ = 2.0 s (wrist)
//   force_length_velocity  v_max × 1/(1 + 2 s)       unequal_muscle_dynamics  ratio 1 + 0.4 s
//   passive_stiffness_nonlinear (wrist)  K_L × (1 + 20 s), κ = 5/rad (effect 1.3–4.7 × noise at
//                  s = 1 over 16 datasets; the earlier K_L × (1 + 30 s), κ = 8/rad gave 0.14–0.57
//                  on steps — the wrist stays below ~50°, far from the 80° limit — and nothing in
//                  the training part of a one-trial grid, whose first 70 % stays within ±27°)
//   stiction (wrist)  F_c = F_s − F_c = 0.04 s T_j
//   spasticity (wrist)  G = 0.4 s T_j, v_th 0.5 rad/s (steps: 0.95–2.1 × noise at s = 1–2; the
//                  grid moves the wrist slowly, |q̇| > 0.5 rad/s in 1–2 % of the samples, and
//                  stays at 0.2–0.25 × noise whatever G: below the floor, see
//                  docs/diagnosis.md)
//   sensor_drift   0.0005 s rad/s on every angle channel
//   arm_support    (rigs with an elbow / shoulder output, e.g. scenarios/elbow_support_rig.yaml
//                  with channels bic, tri) the forearm weight-compensation force raised by
//                  0.25 s × the forearm weight (candidates.h; u_max 240 µs in the suite). At
//                  0.05 s the effect left after fitting the subject parameters from the
//                  participant's true values was below the noise on 9 of the 10 default datasets
//                  (a lifting force is statically a stronger, stiffer subject); at 0.25 s it is
//                  1.2–4.8 × noise (docs/diagnosis.md, sessions 11–12)
//   outside        (not in the library) a 0.1 Hz sinusoidal baseline wander of 1.5° s on every
//                  angle channel (a breathing / strap-movement artefact)
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "diagnosis/diagnose.h"
#include "scenarios/scenario.h"

namespace fesim::diagnosis {

struct PlantedSpec {
  std::vector<std::string> mechanisms;  ///< MechanismIds() entries or "outside"; empty = clean.
  double effect_scale = 1.0;            ///< s above, > 0.
  std::string protocol = "steps";       ///< "steps" or "grid".
  std::vector<std::string> channels = {"ext", "flex"};  ///< the two stimulated rig channels.
  double max_us = 300.0;     ///< u_max: levels (and grid spacing) max_us / 6, Σu ≤ max_us, µs.
  int trials = 3;            ///< ≥ 1.
  double duration_s = 60.0;  ///< per trial, s ("grid": 56 s, the grid's length).
  std::uint64_t seed = 1;    ///< participant, protocol, tremor phase and noise.
};

struct PlantedDataset {
  std::vector<Trial> trials;        ///< measured records (what diagnose sees).
  std::vector<NamedValue> planted;  ///< planted values, named like the fitted parameters.
  double effect_rms_rad = 0.0;      ///< RMS of truth(with) − truth(without) over outputs.
  double noise_rms_rad = 0.0;       ///< sensor noise standard deviation, rad.
  double stiffness_scale = 1.0, strength_scale = 1.0;  ///< the participant's draws.
};

/// Simulates the data set on the scenario's rig (its sensors, coordinates and channels; its
/// stimulation is replaced by the protocol). Throws std::invalid_argument on an unknown id.
PlantedDataset MakePlantedDataset(const Scenario& rig, const PlantedSpec& spec);

/// The protocols on which mechanism `id`'s planted effect can reach the noise RMS: "steps" and
/// "grid", except spasticity — "steps" only (on the grid the wrist exceeds the 0.5 rad/s reflex
/// threshold in 1–2 % of the samples and the effect stays at 0.2–0.25 × noise whatever the gain,
/// docs/diagnosis.md session 10).
std::vector<std::string> PlantedProtocols(const std::string& id);

/// MakePlantedDataset with spec->effect_scale raised until the effect RMS is at least
/// `min_ratio` × the noise RMS (the floor "effect RMS equals noise RMS" at 1): while
/// below, s ← s · 1.05 · min_ratio / ratio (the effect grows about linearly with s for small
/// effects) and the data set is simulated again with the same seed — the same participant,
/// protocol and noise — at most `max_regenerations` times and never above `max_scale`. A data
/// set at or above the floor is returned as generated. On return spec->effect_scale is the
/// returned data set's scale; the caller checks its ratio (a mechanism whose effect saturates
/// can stay below). min_ratio ≤ 0: MakePlantedDataset.
PlantedDataset MakePlantedDatasetAtLeast(const Scenario& rig, PlantedSpec* spec, double min_ratio,
                                         double max_scale = 8.0, int max_regenerations = 5);

}  // namespace fesim::diagnosis
