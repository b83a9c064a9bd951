// Parameters of the ground-truth upper-limb model ([Hand Hammerstein] eq. 12):
//   y = H_RB · R · H_hill · H_IRC · A · u
// Immutable after loading and validation (Pinocchio's Model / MuJoCo's mjModel): per-trial state
// lives in SimTK::State and trial records.
//
// Frames (Simbody/OpenSim convention): ground G is the fixed thorax; X anterior, Y superior,
// Z to the right (lateral for the modelled right arm). Gravity defaults to −9.81 Y.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "muscles/electrode_array.h"
#include "muscles/hill.h"
#include "muscles/recruitment.h"
#include "sim/arm_support.h"
#include "sim/mechanisms.h"
#include "sim/passive_joint.h"
#include "sim/task_tolerances.h"
#include "tendons/tendon_network.h"

namespace fesim::sim {

/// The ten coordinates, in state order. Signs (right arm, at zero of the outer coordinates):
///  shoulder_elv_plane  about G's Y; 0 = frontal (abduction) plane, 90° = sagittal (flexion) plane
///  shoulder_elevation  raises the arm within that plane (Y-X-Y Euler sequence, [Schearer 2014])
///  shoulder_rotation   about the humerus long axis, internal rotation positive
///  elbow_flexion       0 = extended, flexion positive
///  pro_sup             0 = neutral (thumb forward, palm medial), pronation positive
///  wrist_flexion       flexion positive; wrist_deviation radial deviation positive
///  mcp/pip/dip_flexion index finger, flexion positive
enum Coordinate : int {
  kShoulderElvPlane = 0,
  kShoulderElevation,
  kShoulderRotation,
  kElbowFlexion,
  kProSup,
  kWristFlexion,
  kWristDeviation,
  kMcpFlexion,
  kPipFlexion,
  kDipFlexion,
  kNumCoordinates
};

/// Names used in scenario files and trial columns (q.<name>), indexed by Coordinate.
const std::array<std::string, kNumCoordinates>& CoordinateNames();
/// Index of a coordinate name, or −1.
int CoordinateIndex(const std::string& name);

/// Rigid segments with mass, indexed in UpperLimbModel and BandParams::segment.
enum Segment : int {
  kHumerus = 0,
  kForearm,
  kHand,
  kProximalPhalanx,
  kMiddlePhalanx,
  kDistalPhalanx,
  kNumSegments
};
const std::array<std::string, kNumSegments>& SegmentNames();
int SegmentIndex(const std::string& name);

/// Inertial and geometric properties of one segment, in its body frame B whose origin is the
/// proximal joint centre and whose −Y axis runs along the segment to its distal joint.
struct SegmentParams {
  double mass_kg = 1.0;                             ///< > 0.
  double length_m = 0.3;                            ///< proximal to distal joint centre, > 0.
  std::array<double, 3> com_in_body_m{};            ///< centre of mass p_BC, m.
  std::array<double, 3> inertia_about_com_kg_m2{};  ///< principal moments (Ixx, Iyy, Izz), kg·m².
};

/// How a coordinate moves during a trial.
enum class CoordinateMode { kFree, kLocked, kPrescribed };

/// A prescribed coordinate trajectory q(t) = offset + amplitude sin(2π f t + phase).
struct SinePrescription {
  double offset_rad = 0.0;
  double amplitude_rad = 0.0;
  double frequency_hz = 0.0;  ///< ≥ 0.
  double phase_rad = 0.0;
};

/// A prescribed coordinate trajectory from samples (robot-driven reaching, [Schearer 2014]): q, q̇,
/// q̈ at strictly increasing times, interpolated by a C² quintic Hermite spline
/// (sim/prescribed_motion.h). All four vectors have the same length (≥ 2), or all are empty.
struct TablePrescription {
  std::vector<double> times_s;     ///< s, strictly increasing.
  std::vector<double> q_rad;       ///< rad.
  std::vector<double> qd_rad_s;    ///< rad/s.
  std::vector<double> qdd_rad_s2;  ///< rad/s².
};

struct CoordinateParams {
  CoordinateMode mode = CoordinateMode::kFree;
  double initial_rad = 0.0;          ///< q at t = 0 (the lock angle when locked), rad.
  double initial_speed_rad_s = 0.0;  ///< q̇ at t = 0 (free coordinates), rad/s.
  PassiveJointParams passive;
  SinePrescription prescription;  ///< used when mode == kPrescribed and `table` is empty.
  TablePrescription table;        ///< used instead of `prescription` when non-empty.
};

/// One muscle: architecture, recruitment, activation dynamics, path.
struct MuscleParams {
  std::string name;
  muscles::HillParams hill;
  muscles::RecruitmentParams recruitment;
  double activation_omega_rad_s = 6.0;  ///< Ω_i of eq. (6), rad/s, > 0.
  /// Ω of eq. (6) on falling recruitment over Ω_i (muscles::IntervalOmega), > 0; 1: symmetric.
  double deactivation_ratio = 1.0;
  tendons::MusclePath path;  ///< crossings and l_MT at the reference posture.
};

/// One stimulation channel: either a set of pads of the electrode array (weights from the
/// array geometry) or an electrode pair with explicit weights per muscle, or both.
struct ChannelParams {
  std::string name;
  std::vector<int> pads;                                       ///< array pads driven, may be empty.
  std::vector<std::pair<std::string, double>> muscle_weights;  ///< explicit A entries.
};

/// Electrode array geometry: pads (index = row·cols + col) and the motor point of each muscle it
/// can reach (muscles without one are reached only through explicit weights).
struct ElectrodeArrayParams {
  int rows = 4, cols = 6;
  double pitch_m = 0.015;
  muscles::SkinPoint origin;  ///< pad (0, 0).
  std::vector<std::pair<std::string, muscles::SkinPoint>> motor_points;
  double spread_m = 0.012;  ///< σ, m.
};

/// A joint-level sensor: one column per listed coordinate, sampled at rate_hz with additive
/// zero-mean Gaussian noise of standard deviation noise_std.
struct SensorParams {
  double rate_hz = 100.0;        ///< > 0.
  double noise_std = 0.0;        ///< in the measured unit (rad, rad/s or N·m), ≥ 0.
  std::vector<int> coordinates;  ///< Coordinate indices.
  // Artefacts (issue 3): offset drift, tracker dropouts (NaN bursts) and outliers.
  double offset_drift_per_s = 0.0;    ///< measured unit per s, added as drift · t.
  double dropout_probability = 0.0;   ///< long-run fraction of samples lost, [0, 0.9].
  double dropout_mean_samples = 5.0;  ///< mean length of a dropout burst, samples, ≥ 1.
  double outlier_probability = 0.0;   ///< fraction of samples replaced by outliers, [0, 0.5].
  double outlier_std = 0.0;           ///< outlier deviation, measured unit, ≥ 0.
  /// Baseline-offset removal ([Le 2010] §5: the isometric rig's torque offset is taken from
  /// the rest period): when > 0, the mean of this sensor's samples in [0, window) is subtracted
  /// from every sample of the measured record, s, ≥ 0.
  double baseline_window_s = 0.0;
  /// Robot-driven reaching only (sim/reaching.h): cutoff of the zero-phase Butterworth low-pass
  /// the rig's processing applies to this sensor's recorded signal before velocities and
  /// accelerations are differentiated ([Schearer 2014] Fig. 4: "filtered joint angles and joint
  /// torques"), Hz, 0 = none, else below half the sample rate.
  double lowpass_hz = 0.0;
};

struct SensorSuite {
  SensorParams angles;      ///< q.<joint>: camera / hand tracker, rad.
  SensorParams velocities;  ///< qd.<joint>: IMU gyroscope, rad/s.
  SensorParams torques;     ///< tau.<joint>: torque sensor on locked coordinates, N·m.
  /// f.robot_x/y/z: the robot's end-effector force sensor of robot-driven reaching
  /// ([Schearer 2014] §II.A, a three-axis force sensor), N per axis; unused by other rigs.
  SensorParams force;
  double truth_rate_hz = 100.0;  ///< rate of the noiseless truth record, Hz.
};

struct IntegratorParams {
  /// kCvodes: BDF (stiff, default); kCvodesAdams: Adams–Moulton (non-stiff, little numerical
  /// damping, for conservative checks); kSimbodyRkMerson: Simbody's explicit RK cross-check.
  enum class Method { kCvodes, kCvodesAdams, kSimbodyRkMerson };
  Method method = Method::kCvodes;
  /// Relative and absolute accuracy, > 0. Unset (the default): the tolerance trial generation
  /// needs on the integrated rig, TrialGenerationTolerance(model) (sim/task_tolerances.h).
  std::optional<double> tolerance;
  /// CVODES methods: the absolute tolerance of the generalized speeds u is tolerance / t_c
  /// (rad/s) with t_c this time scale, so that a speed error held over t_c moves q by the
  /// tolerance — Simbody's weighting of u errors by a characteristic time (its integrators'
  /// u weights; default time scale 0.1 s). 0: the same number as for q (rad/s = rad). A
  /// lightly damped oscillation (a tremor) is step-limited by its speeds' error: at tolerance
  /// 1e-5, t_c = 0.1 s simulates a 60 s tremor trial 1.9× faster for a 1.6× larger q error
  /// (docs/performance.md "Speed time scale (an option, not the default)"). ≥ 0.
  double speed_time_scale_s = 0.0;
  /// CVODES methods: internal steps over the whole integration at most (0: no limit but CVODES'
  /// 10⁶ per report interval). Used up: std::runtime_error naming the time reached. A fit whose
  /// trial point makes the integration crawl then loses that simulation after a bounded amount of
  /// work (a diagnosis fit once waited 20 minutes on one without it).
  long max_steps = 0;
  /// CVODES methods: evaluate every right-hand side by Simbody's realize(Acceleration) instead
  /// of UpperLimbModel::CalcYDot (the articulated-body algorithm over the same force functions;
  /// the default whenever no coordinate is prescribed). The same dynamics to round-off; for
  /// cross-checks and the benchmarks' side-by-side figures.
  bool simbody_right_hand_side = false;
  /// Forward sensitivities (IntegrateTrialSensitivities): report them from one Taylor polynomial
  /// per CVODES step (sim/sensitivity_taylor.h; the full-model fit's Jacobians) instead of
  /// CVodeGetSens at each report time. The same polynomial to round-off and cheaper when reports
  /// outnumber steps; off by default because round-off alone moves the diagnosis' calibrations
  /// (docs/performance.md "Full-model fit local step").
  bool sensitivities_per_step = false;
};

/// Everything that defines one virtual participant on one rig.
struct ModelParams {
  std::array<SegmentParams, kNumSegments> segments;
  std::array<CoordinateParams, kNumCoordinates> coordinates;
  std::array<double, 3> shoulder_in_ground_m{0.0, 1.43, 0.22};  ///< glenohumeral centre in G, m.
  std::array<double, 3> gravity_m_s2{0.0, -9.81, 0.0};
  double index_mcp_offset_m = 0.02;  ///< index MCP lateral (thumb-side) offset in the hand, m.
  std::vector<MuscleParams> muscles;
  ElectrodeArrayParams array;
  std::vector<ChannelParams> channels;
  std::vector<BandParams> bands;
  std::vector<WeightCompensationParams> weight_compensation;
  MechanismParams mechanisms;  ///< optional mechanisms, all off by default.
};

/// Trial generation's integration tolerance on `model` (sim/task_tolerances.h), the one an
/// IntegratorParams without a tolerance integrates at: TaskTolerances::kTrialGenerationFriction
/// when a free coordinate has Coulomb or static friction, else kTrialGenerationTremor when the
/// tremor is on, else kTrialGeneration.
double TrialGenerationTolerance(const ModelParams& model);

/// The electrode matrix A (muscles × channels) implied by the array geometry and explicit
/// channel weights. Throws std::invalid_argument naming an unknown muscle or pad.
muscles::ArrayMatrix BuildElectrodeMatrix(const ModelParams& model);

}  // namespace fesim::sim
