// Data sets of the foreign simulator for testing fesim's diagnosis: a drawn person, three trials
// of the hand rig's protocols, and zero or more planted effects raised to an effect floor — what
// `fesim diagnose` sees of a person it has never seen (bench/diagnosis_suite.cc, the foreign
// suite; tests/diagnosis/diagnose_test.cc).
//
// Protocols (channels ext and flex, u_max 300 µs, Σu ≤ u_max):
//   steps      pseudo-random levels {0, 1, …, 5} · 50 µs per channel, held U(1, 3) s on the
//              sample grid, the channels' sum clipped to u_max
//   grid       [Hand Hammerstein]'s step grid (50 µs spacing, [Hand Hammerstein] §5.1) with
//              2 s steps, 56 s
//   multisine  [Copur 2016]'s co-activation multisine ([Copur 2016] §4.1):
//              0.2–4 Hz, ±100 µs around 50 µs on both channels
// The default data set is steps, grid, steps (two pseudo-random sequences of their own seeds): the
// last trial is the one the diagnosis holds out (diagnosis/measured.h), and a held-out trial must
// move the joints well above the noise for its error to judge anything — [Copur 2016]'s multisine
// at its default ±100 µs moved a drawn person's MCP and PIP by about the noise σ (0.01 rad SD),
// where every model's held-out NRMSE is ≈ 1.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "foreign/simulate.h"

namespace fesim::foreign {

struct DatasetSpec {
  std::uint64_t person_seed = 1;       ///< DrawPerson's seed.
  PersonSpread spread;                 ///< the person's spread.
  std::vector<PlantedEffect> effects;  ///< planted; empty = clean.
  /// Each effect's scale is raised (ScaleToFloor on the first trial) until the RMS of all planted
  /// effects together over all trials is ≥ floor × the noise σ; ≤ 0: the scales as given.
  double floor = 1.0;
  std::vector<std::string> protocols = {"steps", "grid", "steps"};
  double duration_s = 60.0;  ///< steps and multisine, s, > 0 (the grid is 56 s).
  SensorSpec sensor;
  std::uint64_t seed = 1;  ///< protocols, noise and the effects' own draws.
};

struct Dataset {
  std::vector<fesim::Trial> trials;    ///< measured, in spec.protocols order.
  std::vector<fesim::Trial> truth;     ///< noiseless, same order.
  Person person;                       ///< the drawn person (before the effects).
  std::vector<PlantedEffect> effects;  ///< as planted (scales raised).
  double effect_rms_rad = 0.0;         ///< RMS of truth(with) − truth(without), all trials.
  double noise_rms_rad = 0.0;          ///< spec.sensor.noise_std_rad.
};

/// The stimulation program of protocol `name` (above), seeded. std::invalid_argument naming the
/// protocol when unknown.
protocols::StimulationProgram DatasetProgram(const std::string& name, double duration_s,
                                             std::uint64_t seed);

/// The stimulation a recorded trial held: its u.<channel> columns (µs) as a zero-order hold
/// between its samples — a switch at every sample whose values differ from the previous one —
/// ending at the last sample time. Replays another simulator's protocol (e.g. `fesim
/// benchmark`'s hand-array study) on a foreign person. Throws std::invalid_argument when the
/// trial has no u.* column or fewer than 2 samples.
protocols::StimulationProgram HeldProgram(const fesim::Trial& record);

/// Draws the person, plants the effects at the floor and simulates every protocol. Throws like
/// SimulateTrial.
Dataset MakeDataset(const DatasetSpec& spec);

}  // namespace fesim::foreign
