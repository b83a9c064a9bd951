// Planted-effect data sets from fesim's own model, for testing `fesim diagnose`: virtual trials
// from the ground-truth simulator with a person that differs from the rig's nominal one, a
// stimulation protocol, sensor noise, and zero, one or two mechanisms switched on — which the
// diagnosis is not told. (Data from an independent simulator with its own physics: foreign/.)
//
// Persons (PersonSpread):
//   narrow  joint stiffness × one factor and every F_max × another, each log-uniform in
//           [0.8, 1.25] — the participants the diagnosis was first built on;
//   wide    independent variation of recruitment (β, γ of each muscle × log-U[0.5, 2]), activation
//           rates (Ω of every muscle × one factor U[0.7, 1.3]: unequal rates of the muscle groups
//           are the mechanism unequal_muscle_dynamics), moment arms (each crossing × U[0.75,
//           1.25]), segment masses and inertias (each × U[0.8, 1.2]), rest angles of the free
//           joints (± 10°, the person starting at rest), k and b of every joint (× log-U[0.5, 2]),
//           F_max of each muscle (× log-U[0.67, 1.5]) and electrode placement (the array shifted
//           by U[−1, 1] cm along and around the forearm).
// Protocols (two channels, by default the ext/flex array channels of the hand rig): "steps" —
// pseudo-random levels {0, 1, …, 5} · u_max / 6 per channel held U(1, 3) s (step times on the
// record's sample grid), Σu ≤ u_max; "grid" — paper 000's step grid (u_max / 6 spacing,
// Σu ≤ u_max) with 2 s steps, order alternating between trials.
// Mechanisms are planted by their own `plant` (mechanisms/, scale s: s = 1 gives an effect RMS of
// the order of the 1° sensor noise RMS on the hand rig; the generator reports the measured
// ratio). Out of the library ("outside"): a 0.1 Hz sinusoidal baseline wander of 1.5° s on every
// angle channel (a breathing / strap-movement artefact).
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "diagnosis/diagnose.h"
#include "scenarios/scenario.h"

namespace fesim::diagnosis {

/// How far a planted person departs from the rig's nominal one (see above).
enum class PersonSpread { kNarrow, kWide };

struct PlantedSpec {
  std::vector<std::string> mechanisms;  ///< MechanismIds() entries or "outside"; empty = clean.
  PersonSpread person = PersonSpread::kNarrow;
  double effect_scale = 1.0;                            ///< s above, > 0.
  std::string protocol = "steps";                       ///< "steps" or "grid".
  std::vector<std::string> channels = {"ext", "flex"};  ///< the two stimulated rig channels.
  double max_us = 300.0;     ///< u_max: levels (and grid spacing) max_us / 6, Σu ≤ max_us, µs.
  int trials = 3;            ///< ≥ 1.
  double duration_s = 60.0;  ///< per trial, s ("grid": 56 s, the grid's length).
  std::uint64_t seed = 1;    ///< participant, protocol, tremor phase and noise.
};

struct PlantedDataset {
  std::vector<Trial> trials;  ///< measured records (what diagnose sees).
  /// Noiseless reads of the outputs (the q.* columns of `trials`), per trial, on the measured
  /// records' grids: the truth record of the simulation with the effects plus the sensor-level
  /// ones (drift, wander) at the angle sensor's samples, NaN between them — what the outputs of
  /// `trials` would be without noise and dropouts (the clean twin of bench/diagnosis_suite.cc
  /// --twin).
  std::vector<Trial> truth;
  std::vector<NamedValue> planted;  ///< planted values, named like the fitted parameters.
  double effect_rms_rad = 0.0;      ///< RMS of truth(with) − truth(without) over outputs.
  double noise_rms_rad = 0.0;       ///< sensor noise standard deviation, rad.
  double stiffness_scale = 1.0, strength_scale = 1.0;  ///< narrow persons' draws.
  sim::ModelParams person;  ///< the clean person's model (the rig with the person's draws).
};

/// Simulates the data set on the scenario's rig (its sensors, coordinates and channels; its
/// stimulation is replaced by the protocol). Throws std::invalid_argument on an unknown id.
PlantedDataset MakePlantedDataset(const Scenario& rig, const PlantedSpec& spec);

/// The protocols on which mechanism `id`'s planted effect can reach the noise RMS
/// (Mechanism::planted_protocols; "outside": both).
std::vector<std::string> PlantedProtocols(const std::string& id);

/// The rig's model with a person drawn from `spread` by `rng` (see above); `stiffness_scale` and
/// `strength_scale` receive the narrow draws (1 for wide persons).
sim::ModelParams DrawPerson(const sim::ModelParams& rig, PersonSpread spread, std::mt19937_64* rng,
                            double* stiffness_scale, double* strength_scale);

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
