// A virtual person of the foreign simulator: every property of the hand model in one immutable
// record (anthropometry, gravity of the rig, passive joints, muscles, electrode placement), the
// nominal person and a seeded draw of persons around it.
#pragma once

#include <array>
#include <cstdint>

#include "foreign/body.h"
#include "foreign/joint.h"
#include "foreign/muscle.h"

namespace fesim::foreign {

/// Generalised coordinates, in order; trial columns are q.<name>.
constexpr std::array<const char*, kNumJoints> kJointNames = {"wrist_flexion", "mcp_flexion",
                                                             "pip_flexion"};
constexpr int kNumChannels = 2;
/// Stimulation channels, in order; trial columns are u.<name>.
constexpr std::array<const char*, kNumChannels> kChannelNames = {"ext", "flex"};
enum ChannelId { kExtChannel = 0, kFlexChannel = 1 };

using PlacementMatrix = std::array<std::array<double, kNumChannels>, kNumMuscles>;

struct Person {
  double height_m = 1.75;  ///< m, in [1.0, 2.5].
  double mass_kg = 75.0;   ///< kg, in [20, 250].
  BodyParams body;         ///< from HandBody(height, mass), masses possibly spread.
  GravityParams gravity;   ///< the rig's in-plane gravity.
  std::array<JointParams, kNumJoints> joints;     ///< wrist, MCP, PIP.
  std::array<MuscleParams, kNumMuscles> muscles;  ///< order of MuscleId.
  /// W: the pulse width muscle m sees is Σ_c W[m][c]·u_c, dimensionless, each in [0, 2]; ext
  /// drives ECR, ECU, EDC and flex drives FCR, FCU, FDS, FDP (the other entries are crosstalk).
  PlacementMatrix placement{};
  std::uint64_t seed = 0;  ///< DrawPerson seed, 0 for NominalPerson (metadata only).
};

/// Throws std::invalid_argument naming the first field out of range.
void ValidatePerson(const Person& person);

/// The nominal person scaled to height H and mass m_b: lengths and moment arms ∝ H/1.75 m,
/// muscle strengths ∝ (m_b/75 kg)^(2/3) (geometric similarity, assumed). Nominal values and
/// their sources are in person.cc.
Person ScaledPerson(double height_m, double mass_kg);

/// ScaledPerson(1.75, 75).
Person NominalPerson();

/// A uniform range [lo, hi].
struct UniformRange {
  double lo = 1.0;
  double hi = 1.0;
};

/// How DrawPerson spreads persons around the nominal one. Factors multiply the nominal value;
/// each is drawn uniform in its range, independently per muscle / crossing / joint unless said.
struct PersonSpread {
  UniformRange height_m{1.5, 1.95};           ///< m.
  UniformRange mass_kg{50.0, 100.0};          ///< kg.
  UniformRange max_force{0.5, 2.0};           ///< F_max factor per muscle.
  UniformRange recruitment_points{0.5, 2.0};  ///< u_th and u_sat factors, each per muscle.
  UniformRange activation_common{0.7, 1.3};   ///< one factor for all activation time constants.
  double activation_per_muscle = 0.05;  ///< then each muscle's × U[1 − x, 1 + x], in [0, 0.5].
  UniformRange moment_arm{0.75, 1.25};  ///< whole polynomial factor per crossing.
  UniformRange segment_mass{0.8, 1.2};  ///< mass (and inertia) factor per body.
  double rest_angle_half_width_rad = 0.17453292519943295;  ///< rest angle ± this (10°), rad.
  UniformRange joint_stiffness{0.5, 2.0};                  ///< k_f and k_e factor per joint.
  UniformRange joint_damping{0.5, 2.0};                    ///< b factor per joint.
  UniformRange placement_on{0.5, 1.5};                     ///< on-group W entries.
  UniformRange placement_crosstalk{0.0, 0.02};             ///< off-group W entries (absolute).
};

/// A person drawn from `spread` with std::mt19937_64(seed) (foreign/random.h transforms): the
/// same seed gives the same person everywhere. Drawn saturations are kept ≥ threshold + 10 µs.
/// Throws std::invalid_argument on a spread whose ranges are reversed or out of bounds.
Person DrawPerson(const PersonSpread& spread, std::uint64_t seed);

}  // namespace fesim::foreign
