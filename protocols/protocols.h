// Input protocols of the papers as pure, seeded generators (PRODUCT.md "Protocols", issue 3).
//
// Every stimulation generator returns a StimulationProgram: piecewise-constant pulse widths, the
// values in values_us[k] (one per channel, µs) held from times_s[k] until times_s[k+1] (the last
// until duration_s). Where the papers' signal is continuous (ramp, filtered noise, multisine) the
// value is updated at every stimulation pulse (pulse_rate_hz, 40 Hz in [Hand Hammerstein],
// [Copur 2016] and [Le 2010]) and equals the continuous signal at that pulse's instant. Every
// generator passes its output through ClipToLimits (issue 3: each pulse width in [0, 300] µs and
// Σ_k u_k ≤ u_max), so no program exceeds the limits whatever its parameters.
//
// Random generators draw from std::mt19937_64 seeded with `seed`, transformed by this file's own
// uniform/normal maps (std distributions are implementation-defined), so a seed gives the same
// program on every platform; a different seed gives a different program.
//
// Sources (cited by file in /work/shared/papers):
//   [Hand Hammerstein] §5.1, eq. (46), Fig. 6 — step grid over U, 5 s steps, 50 µs spacing,
//     steady state at each step's end, four data sets, both traversal orders.
//   [Le 2010] §5 and §6.1 — triangular ramp, staircase (τ = T_s/4, widths τ/2τ/3τ
//     each for 1/3 of the test, randomised), filtered random noise, PRMS; 30 s tests whose first
//     and last 5 s are zero stimulation; isometric elbow at ≈ π/2 (the rig is the scenario's job).
//   [Copur 2016] §3.2 eq. (5)–(7), §4.1 — multisine 0.2–4 Hz on one virtual input u
//     mapped to agonist/antagonist pulse widths with co-activation.
//   [Spagnol 2013] §II–III.A — pseudo-random steps of two antagonists (anterior and
//     posterior deltoid), never both stimulated at once.
//   [Schearer 2014] §II.A — robot-driven reaching: straight lines, fifth-order polynomial
//     timing, two homes × 3×3 targets × 3 repetitions, 1 s hold at the target, return.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace fesim::protocols {

/// Largest pulse width any stimulator channel may deliver, µs (000 eq. (46), 002 §6.1).
constexpr double kMaxPulseWidthUs = 300.0;
/// Stimulation pulse rate of [Hand Hammerstein], [Copur 2016] and [Le 2010], Hz.
constexpr double kDefaultPulseRateHz = 40.0;

/// Piecewise-constant multi-channel stimulation (see the file comment).
struct StimulationProgram {
  std::vector<std::string> channels;           ///< channel names (sim/default_model.cc names).
  std::vector<double> times_s;                 ///< switching instants, s, from 0, increasing.
  std::vector<std::vector<double>> values_us;  ///< values_us[k][c]: pulse width of channel c held
                                               ///< from times_s[k], µs, in [0, 300].
  double duration_s = 0.0;                     ///< end of the program, s, > times_s.back().
  std::vector<double> steady_state_times_s;    ///< step grid only: instants, s, at which each
                                               ///< step's steady state is sampled.
};

/// The value held at time t (s): values_us[k] with times_s[k] ≤ t < times_s[k+1]; before the first
/// time the first value, at or after duration_s the last value.
std::vector<double> ValueAt(const StimulationProgram& program, double t_s);

/// Stimulation limit of issue 3 / [Hand Hammerstein] eq. (46).
struct StimulationLimit {
  /// u_max: bound on Σ_k u_k over all channels at every instant, µs, > 0 (may be +∞).
  double sum_max_us = std::numeric_limits<double>::infinity();
};

/// Clips one sample: each u_k to [0, 300] µs, then, when Σ u_k > sum_max_us, all u_k scaled by the
/// same factor sum_max_us / Σ u_k (ratios kept). Throws std::invalid_argument on a non-finite value
/// or sum_max_us ≤ 0.
std::vector<double> ClipToLimits(std::vector<double> values_us, const StimulationLimit& limit);

/// ClipToLimits applied to every sample of a program.
StimulationProgram ClipToLimits(StimulationProgram program, const StimulationLimit& limit);

// ---------------------------------------------------------------------------------------------
// [Hand Hammerstein] §5.1: step grid over U.

/// Traversal order of the grid (000 Fig. 6 and its caption "data was also collected applying
/// input u_1 as in c) and u_2 as in b)").
enum class GridOrder {
  kFirstChannelFastest,  ///< channels[0] is swept up and down (boustrophedon) most often.
  kLastChannelFastest,   ///< the roles reversed: channels[n−1] is swept most often.
};

struct StepGridParams {
  std::vector<std::string> channels = {"ext", "flex"};  ///< n ≥ 1 channels (1–6).
  /// u_max of eq. (46): Σ_k u_k ≤ u_max, µs, in (0, 300·n]; per participant in 000 Table 1.
  double u_max_us = 300.0;
  double spacing_us = 50.0;      ///< grid spacing, µs, in [1, 300].
  double step_duration_s = 5.0;  ///< each grid point held this long, s, in (0, 600].
  /// The steady-state sample of a step is taken this long before the step ends, s, in
  /// [0, step_duration_s) (0 = at the switching instant itself).
  double steady_state_lead_s = 0.1;
  GridOrder order = GridOrder::kFirstChannelFastest;
};

/// All grid points u = spacing·m (m ∈ ℕⁿ) with u_k ≤ 300 and Σ u_k ≤ u_max (tolerance 1e-9 µs),
/// in traversal order: a reflected (boustrophedon) sweep in which the fastest channel goes up, then
/// down, as the next-slower channel steps up one spacing, and so on recursively — each slower level
/// also reverses after each of its own sweeps, so consecutive points differ in one channel
/// wherever the triangle of U allows. Starts at u = 0. Fig. 6 itself is an image not in the text;
/// this sweep is our reading of "stepped to each point in turn" with the traversal arrows of its
/// caption (departure: the exact path of the figure is not reproduced).
std::vector<std::vector<double>> StepGridPoints(const StepGridParams& params);

/// One step-grid data set: StepGridPoints each held step_duration_s, from t = 0; one steady-state
/// sample per step at its end minus steady_state_lead_s. Throws std::invalid_argument on bad
/// params (message names the parameter and range).
StimulationProgram StepGrid(const StepGridParams& params);

/// The "four sets of data" of 000 §5.1: num_data_sets programs over the same grid, traversal
/// alternating between params.order and the reversed order (A, B, A, B). num_data_sets in [1, 100].
std::vector<StimulationProgram> StepGridDataSets(const StepGridParams& params,
                                                 int num_data_sets = 4);

// ---------------------------------------------------------------------------------------------
// [Le 2010] §5 / §6.1: single-channel isometric elbow tests.

/// Timing shared by the paper-002 tests: a duration_s test whose first and last rest_s are zero
/// stimulation (baseline torque offset is estimated from those rests, 002 §6.1). Switching instants
/// inside the active window lie on the pulse grid rest_s + k/pulse_rate_hz (a stimulator changes
/// the pulse width only at a pulse). The rig — elbow locked at ≈ π/2 with a torque sensor, offset
/// removal — is the scenario's and the identification's business, not the generator's.
struct IsometricTestTiming {
  double duration_s = 30.0;                    ///< whole test, s, > 2·rest_s, ≤ 36000.
  double rest_s = 5.0;                         ///< zero stimulation at both ends, s, ≥ 0.
  double pulse_rate_hz = kDefaultPulseRateHz;  ///< stimulation update rate, Hz, in [1, 1000].
};

/// 002 §5 "Triangular ramp (TR) test": the pulse width rises linearly from u_min to u_peak and
/// returns to u_min, num_triangles times over the active window, sampled at each pulse.
struct TriangularRampParams {
  std::string channel = "tri";
  double u_min_us = 0.0;     ///< start/end value of each triangle, µs, in [0, u_peak_us).
  double u_peak_us = 300.0;  ///< apex, µs, in (u_min_us, 300].
  int num_triangles = 1;     ///< triangles in the active window, 1–1000.
  IsometricTestTiming timing;
  StimulationLimit limit;
};
StimulationProgram TriangularRamp(const TriangularRampParams& params);

/// 002 §5 "Staircase test": with τ = T_s/4 (T_s the 98 % settling time), step widths τ, 2τ and 3τ
/// each fill 1/3 of the active window; the counts n_w = max(1, round(active/(3·w·τ))), w = 1, 2, 3,
/// are shuffled into a random order, and all widths then scaled by one common factor (≈ 1) so the
/// steps fill the active window exactly (so the 1/3 shares hold up to that rounding of counts and
/// the snapping of step boundaries to the pulse grid). Levels are independent, uniform in
/// [u_min_us, u_max_us].
struct StaircaseParams {
  std::string channel = "tri";
  double u_min_us = 0.0;    ///< lowest level, µs, in [0, u_max_us).
  double u_max_us = 300.0;  ///< highest level, µs, in (u_min_us, 300].
  /// T_s, 98 % settling time of the muscle's response, s, in [8/pulse_rate_hz, active window/1.5]
  /// (τ ≥ 2 pulse periods; one step of each width fits). [Le 2010] gives no value; 1 s gives
  /// τ = 0.25 s.
  double settling_time_s = 1.0;
  IsometricTestTiming timing;
  StimulationLimit limit;
  std::uint64_t seed = 1;
};
StimulationProgram Staircase(const StaircaseParams& params);

/// 002 §5 "FRN test": Gaussian white noise at the pulse rate through a Butterworth low-pass
/// (protocols/filters.h), then an offset and gain so that the active window spans exactly
/// [u_min_us, u_max_us] (its minimum maps to u_min, its maximum to u_max). The filter runs
/// warm_up_s on noise first so the window is stationary (no start-up transient).
struct FilteredRandomNoiseParams {
  std::string channel = "tri";
  double u_min_us = 0.0;    ///< µs, in [0, u_max_us).
  double u_max_us = 300.0;  ///< µs, in (u_min_us, 300].
  double cutoff_hz = 1.0;   ///< −3 dB frequency, Hz, in (0, pulse_rate_hz/2). 002 gives none.
  int filter_order = 4;     ///< Butterworth order, 1–10.
  double warm_up_s = 20.0;  ///< filter run-in before the window, s, ≥ 0.
  IsometricTestTiming timing;
  StimulationLimit limit;
  std::uint64_t seed = 1;
};
StimulationProgram FilteredRandomNoise(const FilteredRandomNoiseParams& params);

/// 002 §5 "PRMS test": a maximum-length sequence over the Galois field GF(q), q prime — the
/// periodic, deterministic signal with white-noise-like autocorrelation in which every nonzero
/// symbol appears q^(n−1) times and 0 appears q^(n−1) − 1 times per period q^n − 1, i.e. the
/// levels are uniform. Recurrence s_{k+n} = −Σ_{i<n} c_i s_{k+i} (mod q) with a primitive
/// polynomial x^n + c_{n−1}x^{n−1} + … + c_0 drawn at random (seed) among those found by a
/// period test, started from a random nonzero state (seed). Symbol s maps to level
/// u_min + s·(u_max − u_min)/(q − 1), each held symbol_duration_s over the active window.
struct PrmsParams {
  std::string channel = "tri";
  double u_min_us = 0.0;           ///< level of symbol 0, µs, in [0, u_max_us).
  double u_max_us = 300.0;         ///< level of symbol q−1, µs, in (u_min_us, 300].
  int num_levels = 5;              ///< q, a prime in [2, 31].
  int register_length = 2;         ///< n ≥ 1 with q^n − 1 ≤ 2^20; period q^n − 1 symbols.
  double symbol_duration_s = 0.4;  ///< clock period, s, in [1/pulse_rate_hz, active window].
  IsometricTestTiming timing;
  StimulationLimit limit;
  std::uint64_t seed = 1;
};
StimulationProgram Prms(const PrmsParams& params);

/// The GF(q) m-sequence of PrmsParams (symbols 0 … q−1), `length` symbols long; exposed for tests.
std::vector<int> PrmsSymbols(const PrmsParams& params, std::size_t length);

// ---------------------------------------------------------------------------------------------
// [Copur 2016] §3.2, §4.1: multisine through the co-activation mapping (horizontal-plane wrist).

/// Agonist/antagonist pulse widths for one virtual input (001 eq. (5)–(6)).
struct CoactivatedPair {
  double agonist_us = 0.0;     ///< u_fcr: u + u_coact,fcr for u ≥ 0, else u_coact,fcr.
  double antagonist_us = 0.0;  ///< u_ecr: u_coact,ecr for u ≥ 0, else u_coact,ecr − u.
};

/// 001 eq. (5)–(6): maps the virtual input u (µs, signed; u ≥ 0 drives the agonist) to the pair.
/// The co-activation levels should satisfy h_fcr(u_coact,fcr) = h_ecr(u_coact,ecr) (001 after
/// eq. (7)) so that u = 0 gives zero steady-state torque; that is the caller's choice of levels.
CoactivatedPair CoactivationMap(double u_us, double coact_agonist_us, double coact_antagonist_us);

/// 001 §4.1: u(t) = a · Σ_j sin(2π f_j t + φ_j) over the harmonics f_j = j·frequency_step_hz inside
/// [f_min_hz, f_max_hz], phases φ_j uniform in [0, 2π) (seed), scaled so max |u| over the
/// sampled record equals amplitude_us; sampled at the pulse rate and mapped by CoactivationMap.
/// With duration_s a multiple of 1/frequency_step_hz the record holds whole periods and all of its
/// power lies in the band. Channels: {agonist (u ≥ 0), antagonist (u < 0)}.
struct MultisineParams {
  std::vector<std::string> channels = {"flex", "ext"};  ///< exactly 2: agonist, antagonist.
  double f_min_hz = 0.2;                                ///< lowest tone, Hz, > 0.
  double f_max_hz = 4.0;              ///< highest tone, Hz, in [f_min_hz, pulse_rate_hz/2).
  double frequency_step_hz = 0.2;     ///< tone spacing = 1/period, Hz, in (0, f_max_hz].
  double amplitude_us = 100.0;        ///< max |u|, µs, in (0, 300].
  double coact_agonist_us = 50.0;     ///< u_coact,fcr, µs, in [0, 300].
  double coact_antagonist_us = 50.0;  ///< u_coact,ecr, µs, in [0, 300].
  double duration_s = 180.0;          ///< s, in (0, 36000]; 001 §4.1: trials of ≈ 3 min.
  double pulse_rate_hz = kDefaultPulseRateHz;  ///< Hz, in [1, 1000].
  StimulationLimit limit;
  std::uint64_t seed = 1;
};

/// The virtual input u at the pulse instants k/pulse_rate_hz, k = 0 … ⌈duration·rate⌉−1, µs.
std::vector<double> MultisineVirtualInput(const MultisineParams& params);

StimulationProgram Multisine(const MultisineParams& params);

// ---------------------------------------------------------------------------------------------
// [Spagnol 2013] §III.A: pseudo-random steps of two antagonists, never both at once.

/// A sequence of steps; for each, one of the two channels is chosen at random (fair coin), its
/// level drawn uniform in [level_min_us, level_max_us] and held for a duration uniform in
/// [step_min_s, step_max_s]; the other channel is 0 throughout. Each step is followed by a rest
/// (both 0) uniform in [gap_min_s, gap_max_s]. Durations are rounded to whole pulse periods
/// (≥ one). Steps continue while they end before duration_s − rest_s; rest_s of zero stimulation
/// opens and closes the program. [Spagnol 2013] commands recruitment λ through an eEMG
/// λ-controller; fesim has no eEMG, so the steps are on pulse width (departure).
struct ShoulderStepsParams {
  std::vector<std::string> channels = {"delt_ant", "delt_post"};  ///< exactly 2 (adduction,
                                                                  ///< abduction in 003).
  double level_min_us = 100.0;                                    ///< µs, in (0, level_max_us].
  double level_max_us = 300.0;                                    ///< µs, in [level_min_us, 300].
  double step_min_s = 2.0;                                        ///< s, in (0, step_max_s].
  double step_max_s = 5.0;                                        ///< s, ≥ step_min_s.
  double gap_min_s = 1.0;       ///< rest between steps, s, in [0, gap_max_s].
  double gap_max_s = 3.0;       ///< s, ≥ gap_min_s.
  double duration_s = 60.0;     ///< whole program, s, > 2·rest_s, ≤ 36000.
  double rest_s = 2.0;          ///< zero stimulation at both ends, s, ≥ 0.
  double pulse_rate_hz = 25.0;  ///< step times are multiples of 1/pulse_rate_hz, Hz, in [1, 1000].
  StimulationLimit limit;
  std::uint64_t seed = 1;
};
StimulationProgram ShoulderPseudoRandomSteps(const ShoulderStepsParams& params);

// ---------------------------------------------------------------------------------------------
// [Schearer 2014] §II.A: robot-driven reaching (hand trajectory, not stimulation; muscles relaxed).

using Vec3 = std::array<double, 3>;

/// Minimum-jerk (quintic) timing s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ on τ ∈ [0, 1] (004 §II.A: "a fifth-order
/// polynomial in time" with zero initial and final velocity and acceleration): s(0) = 0, s(1) = 1,
/// s'(0) = s'(1) = s''(0) = s''(1) = 0. τ outside [0, 1] is clamped (s' = s'' = 0 there).
struct QuinticTiming {
  double s = 0.0;    ///< fraction of the path, 0–1.
  double ds = 0.0;   ///< ds/dτ.
  double dds = 0.0;  ///< d²s/dτ².
};
QuinticTiming MinimumJerk(double tau);

/// What the hand does during one segment of the path.
enum class SegmentKind { kReach, kHold, kReturn, kPause, kTransfer };

/// One straight segment p(t) = from + (to − from)·s((t − start)/duration).
struct HandSegment {
  SegmentKind kind = SegmentKind::kReach;
  double start_s = 0.0;     ///< s.
  double duration_s = 0.0;  ///< s, > 0.
  Vec3 from_m{};            ///< world frame G (Y up, X anterior, Z right), m.
  Vec3 to_m{};              ///< m; equal to from_m for holds and pauses.
  int home_index = -1;      ///< 0/1, or −1 for a transfer between homes.
  int target_index = -1;    ///< 0 … targets−1 for reach/hold/return, else −1.
  int repetition = -1;      ///< 0 … repetitions−1 for reach/hold/return/pause, else −1.
};

/// The hand path: the segments, and their samples at sample_rate_hz from t = 0 to the end.
struct HandPath {
  std::vector<HandSegment> segments;    ///< contiguous, in time order.
  double duration_s = 0.0;              ///< end of the last segment, s.
  std::vector<double> times_s;          ///< k / sample_rate_hz, s, last ≤ duration_s.
  std::vector<Vec3> position_m;         ///< hand position in G, m.
  std::vector<Vec3> velocity_m_s;       ///< m/s.
  std::vector<Vec3> acceleration_m_s2;  ///< m/s².
};

/// The default targets of ReachingParams: TargetGrid3x3 of the corners (0.40, 1.50, 0.05),
/// (0.40, 1.50, 0.35), (0.40, 1.20, 0.05), (0.40, 1.20, 0.35) m.
std::vector<Vec3> DefaultReachingTargets();

/// Default homes and targets are for the default 1.75 m participant of sim/default_model.cc
/// (shoulder ≈ (0, 1.43, 0.23) m): home 0 in front of the mouth, home 1 in front of and just below
/// the shoulder (004 §II.A), targets a vertical 3×3 grid 0.40 m anterior — scenarios should set
/// them from the participant's reach.
struct ReachingParams {
  std::vector<Vec3> homes_m = {{0.25, 1.50, 0.05}, {0.25, 1.30, 0.23}};  ///< ≥ 1 homes, m.
  /// ≥ 1 targets, m; 004 uses a 3×3 planar grid (TargetGrid3x3).
  std::vector<Vec3> targets_m = DefaultReachingTargets();
  double reach_duration_s = 2.0;  ///< home → target and target → home, s, in (0, 60]. 004: 2 s.
  double hold_s = 1.0;            ///< at the target, s, in [0, 60]. 004: 1 s.
  double pause_s = 1.0;           ///< at home after each return, s, in [0, 60].
  double transfer_duration_s = 2.0;  ///< home → next home, s, in (0, 60].
  int repetitions = 3;               ///< each home–target path, 1–100. 004: three times.
  double sample_rate_hz = 100.0;     ///< HandPath samples, Hz, in (0, 10000].
  /// The home–target pairs run, {home index, target index}, in this order; empty = every home
  /// with every target (004's subject without SCI, 2 × 9 paths). 004's subject with SCI ran 4
  /// of them: mouth → high-left, high-right, low-right and shoulder → low-right (§II.A). Each
  /// pair at most once, indices within homes_m / targets_m.
  std::vector<std::array<int, 2>> paths;
};

/// 3×3 planar grid from its four corners (004 §II.A: "the four extreme targets at the corners"),
/// bilinear, row-major from the high-left corner: index = 3·row + column, row 0 high.
std::vector<Vec3> TargetGrid3x3(const Vec3& high_left_m, const Vec3& high_right_m,
                                const Vec3& low_left_m, const Vec3& low_right_m);

/// 004 §II.A: starting at homes_m[0]; for each home h (a transfer segment moves the hand there
/// when needed), each target, each repetition: reach (reach_duration_s), hold (hold_s), return
/// (reach_duration_s), pause (pause_s); zero-length holds/pauses are omitted. With `paths` set,
/// only those pairs, in their order (a transfer whenever the home changes). Sampled at
/// sample_rate_hz. Throws std::invalid_argument on bad params.
HandPath ReachingProgram(const ReachingParams& params);

/// Hand position, velocity and acceleration at time t (s) on a path (from its segments, exact;
/// before 0 / after duration_s the hand rests at the first / last point).
struct HandState {
  Vec3 position_m{};
  Vec3 velocity_m_s{};
  Vec3 acceleration_m_s2{};
};
HandState EvaluateHandPath(const HandPath& path, double t_s);

/// 004 §II.A, the measurement of the reaching protocol: the force f_m (N, world frame) measured at
/// the robot's end effector, transmitted through the ball-and-socket joint at r_wb (m, world frame,
/// from the wrist to that joint), is the wrist wrench f_r = [f_m; r_wb × f_m]; the equivalent joint
/// torques are τ_r = J_rᵀ(q) f_r (N·m, or N for a prismatic coordinate). J_r is given by columns,
/// one per coordinate: [∂v_wrist/∂q̇_j; ∂ω/∂q̇_j] (linear then angular, world frame), so that
/// τ_j = column_j · f_r and Σ τ_j q̇_j equals the power f_r · [v; ω] delivered at the wrist.
std::vector<double> JointTorquesFromEndEffectorForce(
    const Vec3& force_n, const Vec3& r_wrist_to_joint_m,
    const std::vector<std::array<double, 6>>& jacobian_columns);

}  // namespace fesim::protocols
