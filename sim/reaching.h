// Robot-driven reaching ([Schearer 2014] §II.A–B), end to end in the simulator:
// hand path (protocols/protocols.h ReachingProgram) → inverse kinematics of the four arm joints →
// the arm prescribed along those joint trajectories, muscles relaxed → the robot's wrench at the
// handle → joint torques back from that wrench through the arm Jacobian (004 §II.A, eq. (1)–(2)).
//
// Frames and points (Drake monogram notation): G ground = thorax (X anterior, Y up, Z right), H
// the hand segment's body frame, P the robot's handle point fixed in the hand, p_HP its position
// in H (ReachingOptions::handle_in_hand_m), p_GP(t) = the hand path of ReachingProgram.
//
// Joints: q = [shoulder_elv_plane, shoulder_elevation, shoulder_rotation, elbow_flexion] (004
// §II.A, Y-X-Y shoulder). The robot holds the hand in a cast, so pro/supination, the wrist and the
// index finger are locked at their ModelParams::coordinates[i].initial_rad.
//
// Redundancy (4 joints, a 3-D point): swivel rule. Shoulder rotation is an affine function of the
// handle position, q_rot = rotation_at_reference_rad + g·(p_GP − p_ref) (g =
// rotation_gradient_rad_per_m), so it varies along reaches (internal rotation as the hand moves
// medially) and is a smooth, path-independent function of p_GP; plane, elevation and elbow then
// follow by Newton's method on p_GP(q) = p (a square 3×3 problem, warm-started from the previous
// sample). Rates are exact differentials of the same maps, with J the 3×4 station Jacobian of P:
//   q̇_rot = g·ṗ,  J₃ q̇₃ = ṗ − j_rot q̇_rot;   q̈_rot = g·p̈,  J₃ q̈₃ = p̈ − J̇q̇ − j_rot q̈_rot,
// so the hand's velocity and acceleration vanish wherever the path's do (segment ends).
// Between samples the joints follow the C² quintic Hermite spline of (q, q̇, q̈)
// (sim/prescribed_motion.h), so the handle matches the path exactly at samples and to O(h⁶) in
// between.
//
// Measurement (004 §II.A): the torques the rig must apply to the four prescribed coordinates are
// τ_r = −(Simbody's motion forces) = −UpperLimbModel::SensorTorques (that is what the limb
// exerts on the rig), which by the equations of motion equal
// B(q)q̈ + C(q,q̇)q̇ + g(q) − τ_applied(q,q̇) (004 eq. (1)–(2) with the paper's τ(q,q̇) = −τ_applied:
// τ_applied = passive joint moments, relaxed-muscle passive forces through R(q), arm support
// bands if any, so 004's τ_s is part of it). The robot applies a wrench W = [f; m] to the arm at
// P (force N, moment N·m, in G) with τ_r = J₆ᵀ W, J₆ = [∂v_GP/∂q̇; ∂ω_GH/∂q̇] (6×4, linear rows
// first, as protocols::JointTorquesFromEndEffectorForce). The recorded W is the least-norm one, W =
// J₆ (J₆ᵀJ₆)⁻¹ τ_r, and tau.<joint> is J₆ᵀ W computed from the recorded wrench (the paper's
// conversion of the sensor reading to joint torques).
// Measurement (SensorSuite, optional; the default suite is noiseless and unfiltered): additive
// zero-mean Gaussian noise on the recorded joint angles (sensors.angles.noise_std, rad: 004's
// Optotrak tracking through the RTS smoother, and marker movement, §IV) and on each axis of the
// robot's force sensor (sensors.force.noise_std, N), seeded per reach (DeriveSeed). The rig's
// processing then low-pass filters, zero-phase (second-order Butterworth run forward and backward,
// protocols::FilterZeroPhase), the noisy angles (sensors.angles.lowpass_hz) and the joint torques
// J₆ᵀ W of the noisy wrench (sensors.force.lowpass_hz) — 004 Fig. 4's "filtered joint angles and
// joint torques" — and differentiates the filtered angles by central differences (one-sided at
// the ends) for qd.<joint> and qdd.<joint>. Without angle noise and filter, q, qd and qdd are the
// exact kinematics; without force noise and filter, tau is J₆ᵀ W of the exact wrench.
// Departure: 004 estimated q, q̇, q̈ with an extended RTS smoother (§II.A); here a low-pass and
// differences. The moment columns m.robot_* carry no noise (004's sensor has no moment axes).
//
// Departures from 004: the paper's HapticMaster measures a 3-D force through a ball-and-socket
// joint (wrench [f_m; r_wb × f_m]); a pure force cannot hold the arm's swivel, which the paper's
// subjects kept by their own passive tissues. Here the swivel is prescribed, so the cast is
// modelled as rigid and the sensor reports a 6-D wrench (moment columns m.robot_*). Every
// coordinate being prescribed or locked and stimulation zero (activations stay 0), the state at
// each instant is fully determined by time: the simulator is evaluated at the sample instants
// (system.prescribe + realize to Acceleration) rather than integrated.
#pragma once

#include <Simbody.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "base/trial.h"
#include "protocols/protocols.h"
#include "sim/model_params.h"
#include "sim/upper_limb_model.h"

namespace fesim::sim {

/// The four arm coordinates of 004 §II.A, in the order of every 4-vector below.
constexpr std::array<int, 4> kReachingCoordinates = {kShoulderElvPlane, kShoulderElevation,
                                                     kShoulderRotation, kElbowFlexion};

struct ReachingOptions {
  /// p_HP: robot handle point in the hand frame H, m. Default: H's origin, the wrist joint
  /// centre (004 §II.A takes the robot's wrench at the wrist).
  std::array<double, 3> handle_in_hand_m{0.0, 0.0, 0.0};
  /// Swivel rule q_rot = rotation_at_reference_rad + g·(p_GP − p_ref): value at p_ref, rad.
  /// In the Y-X-Y sequence plane and rotation share the vertical axis, so the anatomically
  /// neutral rotation is q_rot ≈ −q_plane; −0.8 rad with the hand in front (plane ≈ 1.2 rad) is
  /// ≈ 0.4 rad of internal rotation, and keeps the default path's elevation ≥ 16° (away from
  /// the sequence's singularity at zero elevation).
  double rotation_at_reference_rad = -0.8;
  /// g, rad/m (negative Z: more internal rotation as the hand moves medially).
  std::array<double, 3> rotation_gradient_rad_per_m{0.0, 0.0, -2.0};
  /// p_ref, m, in G.
  std::array<double, 3> rotation_reference_m{0.30, 1.40, 0.20};
  /// Newton start for the first sample [plane, elevation, rotation (ignored), elbow], rad.
  std::array<double, 4> initial_guess_rad{1.2, 0.6, 0.0, 1.6};
  double ik_tolerance_m = 1e-12;  ///< |p_GP(q) − p|, m, > 0.
  int ik_max_iterations = 100;    ///< Newton iterations per sample, ≥ 1.
};

/// Joint trajectories at the hand path's samples (rad, rad/s, rad/s²), [sample][joint], joints in
/// kReachingCoordinates order.
struct ReachingKinematics {
  std::vector<double> times_s;
  std::vector<std::array<double, 4>> q, qd, qdd;
};

/// Swivel rule value and gradient: q_rot(p_GP), rad.
double SwivelRotation(const ReachingOptions& options, const protocols::Vec3& p_GP_m);

/// p_GP of the handle for the state's q, m (state at Stage::Position or later).
protocols::Vec3 HandlePosition(const UpperLimbModel& model, const SimTK::State& state,
                               const ReachingOptions& options);

/// J₆ of the handle: one column per kReachingCoordinates entry, [∂v_GP/∂q̇_j; ∂ω_GH/∂q̇_j]
/// (m/rad and dimensionless, in G). State at Stage::Position or later.
std::vector<std::array<double, 6>> HandleJacobianColumns(const UpperLimbModel& model,
                                                         const SimTK::State& state,
                                                         const ReachingOptions& options);

/// Inverse kinematics along the path (see the file comment). `model` supplies the kinematics only
/// (its coordinate modes do not matter). Throws std::runtime_error naming the time when Newton
/// fails to converge or the 3×3 Jacobian is singular.
ReachingKinematics SolveReachingKinematics(const UpperLimbModel& model,
                                           const protocols::HandPath& path,
                                           const ReachingOptions& options);

/// `base` with the four arm coordinates prescribed by tables of `kinematics` (kPrescribed), the
/// other coordinates locked at their initial_rad; muscles stay (relaxed: zero stimulation).
ModelParams PrescribedReachingModel(const ModelParams& base, const ReachingKinematics& kinematics);

/// Least-norm wrench W = [f (N); m (N·m)] with J₆ᵀ W = τ (τ in N·m, 4 joints); the Euclidean
/// norm of [f; m] in SI numbers (N and N·m weighted alike).
struct RobotWrench {
  protocols::Vec3 force_n{};
  protocols::Vec3 moment_nm{};
};
RobotWrench WrenchFromJointTorques(const std::vector<std::array<double, 6>>& jacobian_columns,
                                   const std::array<double, 4>& tau_nm);
/// τ = J₆ᵀ W, N·m.
std::array<double, 4> JointTorquesFromWrench(
    const std::vector<std::array<double, 6>>& jacobian_columns, const RobotWrench& wrench);

/// The simulated rig at one instant (4-vectors in kReachingCoordinates order).
struct ReachingSample {
  std::array<double, 4> q{}, qd{}, qdd{};  ///< simulated motion, rad, rad/s, rad/s².
  /// τ_r applied to the arm by the rig, N·m: −UpperLimbModel::SensorTorques (the negated
  /// Simbody motion forces) of the 4 coordinates.
  std::array<double, 4> robot_torque_nm{};
  RobotWrench wrench;                                 ///< robot sensor reading.
  std::array<double, 4> tau_nm{};                     ///< J₆ᵀ W from the sensor reading, N·m.
  protocols::Vec3 p_GP_m{}, v_GP_m_s{}, a_GP_m_s2{};  ///< handle position, velocity, acceleration.
  std::vector<std::array<double, 6>> jacobian_columns;  ///< J₆ (HandleJacobianColumns).
};

/// Sets `state` (from model.MakeInitialState() of a PrescribedReachingModel) to time t, applies
/// the prescribed motion, realises to Stage::Acceleration and reads the rig.
ReachingSample EvaluateReachingSample(const UpperLimbModel& model, SimTK::State* state, double t_s,
                                      const ReachingOptions& options);

/// 004 §II.A protocol end to end: one Trial per reach (home → target, hold, return; pauses and
/// transfers excluded), time from the reach's start at the path's sample rate. Columns
/// q.<joint>, qd.<joint>, qdd.<joint>, tau.<joint> (J₆ᵀ W), f.robot_x/y/z (N), m.robot_x/y/z
/// (N·m), in G. Metadata: protocol = reaching, trajectory = "<home>-<target>" (groups the
/// repetitions of one path, the grouping identification/inverse_dynamics.h's leave-one-trajectory-
/// out CV expects), repetition, home, target, start_time_s. `model` is the participant (its
/// arm coordinate modes are overridden). `sensors`: the measurement of the file comment (only
/// angles.noise_std / lowpass_hz and force.noise_std / lowpass_hz are used); `seed` seeds its
/// noise. Throws std::invalid_argument when a cutoff is not below half the path's sample rate.
std::vector<Trial> SimulateReaching(const ModelParams& model,
                                    const protocols::ReachingParams& reaching,
                                    const ReachingOptions& options,
                                    const SensorSuite& sensors = SensorSuite{},
                                    std::uint64_t seed = 1);

}  // namespace fesim::sim
