// Studies: a virtual cohort × protocols × repetitions on one rig (PRODUCT.md "virtual cohort",
// issue 3). A study YAML names a base scenario (the rig), draws N participants from stated
// distributions with a seed, and lists protocols as scenario `stimulation` blocks:
//
//   study: text                                   (required)
//   scenario: path of the base scenario, absolute or relative to the study file   (required)
//   repetitions: 1–100                            (default 1)
//   cohort:
//     size: 1–1000, seed: integer                 (default 8 participants, seed 1)
//     height_m, mass_kg, strength_scale, recruitment_threshold_scale, omega_scale,
//     stiffness_scale: {mean, sd, min, max}       (truncated normal; scale = multiplies the
//                                                  base value: F_max, 1/β, Ω_i, joint k)
//     electrode_offset_m: {sd, max}               (array origin shift along and around, m)
//   protocols: [{name, stimulation: {…scenario stimulation block…}}]   (required)
//
// Repetition r of a protocol gets protocol seed (its own `seed` or 1) + r, and a step grid
// alternates its traversal order ([Hand Hammerstein] Fig. 6: both orders across the four data
// sets). Participant k's draws come from its own random stream (seed, k), so a participant does not
// change when the cohort grows.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "scenarios/scenario.h"

namespace fesim {

/// A truncated normal distribution; draws outside [min, max] are redrawn.
struct Distribution {
  double mean = 1.0, sd = 0.0, min = 0.0, max = 1e9;
};

struct CohortParams {
  int size = 8;
  std::uint64_t seed = 1;
  Distribution height_m{1.75, 0.0, 1.2, 2.2};
  Distribution mass_kg{75.0, 0.0, 30.0, 150.0};
  Distribution strength_scale{1.0, 0.0, 0.1, 10.0};
  Distribution recruitment_threshold_scale{1.0, 0.0, 0.1, 10.0};
  Distribution omega_scale{1.0, 0.0, 0.1, 10.0};
  Distribution stiffness_scale{1.0, 0.0, 0.1, 10.0};
  double electrode_offset_sd_m = 0.0;
  double electrode_offset_max_m = 0.02;
};

/// One virtual participant's draws.
struct Participant {
  int index = 0;
  double height_m = 1.75, mass_kg = 75.0;
  double strength_scale = 1.0, recruitment_threshold_scale = 1.0, omega_scale = 1.0,
         stiffness_scale = 1.0;
  double electrode_offset_along_m = 0.0, electrode_offset_around_m = 0.0;
};

/// One trial of the study: participant × protocol × repetition, ready to simulate.
struct StudyItem {
  int participant = 0;
  std::string protocol;
  int repetition = 0;
  Scenario scenario;  ///< the rig with this participant's parameters and this stimulation.
  std::uint64_t noise_seed = 1;
  std::string file_stem;  ///< "p<k>/<protocol>_r<r>"
};

struct Study {
  std::string name;
  std::string path;
  std::string source_text;
  std::string scenario_path;  ///< the base scenario (the rig), resolved against `path`.
  CohortParams cohort;
  std::vector<Participant> participants;
  std::vector<StudyItem> items;  ///< participant-major, then protocol, then repetition.
};

/// Draws the cohort (deterministic for a seed; participant k from stream k).
std::vector<Participant> DrawCohort(const CohortParams& cohort);

/// Applies a participant's scale factors and electrode offset to a model (height and mass are
/// applied through the scenario's participant block before).
void ApplyParticipant(const Participant& p, sim::ModelParams* model);

/// True when the YAML text is a study (has a top-level `study:` key).
bool IsStudy(const std::string& text);

/// Loads a study; errors name the file, the key path and the allowed range. `noise_seed` seeds
/// every item's sensor noise (combined with the item's indices).
Study LoadStudy(const std::string& path, std::uint64_t noise_seed);

}  // namespace fesim
