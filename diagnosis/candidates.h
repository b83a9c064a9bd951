// The library of candidate mechanisms of `fesim diagnose` (PRODUCT.md "Diagnosis" step 3,
// issue 7): for each id, the model extension (parameters that switch the mechanism on in the
// full model, sim/mechanisms.h, sim/passive_joint.h, sim/sensors.h) and the probe directions of
// its residual signature (score test, diagnose.h). The subject parameters recalibrated with every
// extension are here too.
//
//   id                          extension parameters (start = mechanism off / nominal)
//   fatigue                     fatigue.rate_per_s = 1/T_fat (Riener 1996, mechanisms.h), 1/s
//   potentiation                potentiation.gain g, potentiation.rise_time_s
//   delay                       delay.s, electromechanical delay δ, s
//   tremor@<joint>              tremor.amplitude_nm A, tremor.phase_rad φ, tremor.frequency_hz f
//                               (start f from the residual spectrum peak, papers/001_* §2)
//   crosstalk                   crosstalk.fraction c (second spread σ_x = 0.03 m)
//   moment_arm_posture@<joint>  momentarm.posture_ratio ρ: every crossing of the joint gets
//                               d̃ += ρ d in eq. (10) of papers/000_* (constant arms become
//                               Landsmeer arms), l_MT at the rest posture kept
//   force_length_velocity       hill.vmax_scale: v_max of the forearm muscles × s (eq. 7)
//   unequal_muscle_dynamics     omega.ext_flex_ratio s: Ω_i × s for wrist extensors, × 1/s for
//                               wrist flexors (eq. 6; Assumption 6 of paper 000 broken)
//   passive_stiffness_nonlinear@<joint>  passive.limit_scale (K_L × s), passive.sharpness_per_rad
//                               κ (eq. 14 range limits, passive_joint.h); probes: a broad
//                               nonlinearity (K_L × 5, κ = 5/rad) and the nominal κ × 0.7
//   arm_support                 support.weight_compensation_n F_w, N: the vertical
//                               weight-compensation force on the forearm cuff (sim/arm_support.h;
//                               the rig's forearm entry, or a cuff at the forearm's centre of mass
//                               with start 0 when the rig has none), and, when the rig has elastic
//                               bands, support.band_stiffness_scale (k of every band × s).
//                               Applicable only when an output is the elbow or a shoulder
//                               coordinate (the support moves nothing distal to the forearm).
//   stiction@<joint>            friction.coulomb_nm F_c, friction.static_excess_nm F_s − F_c
//   spasticity@<joint>          reflex.gain_nms_per_rad G, reflex.threshold_rad_s v_th
//   sensor_drift                drift.<output>, rad/s (one per output: value · t added)
// Joint-level mechanisms get one candidate per free output joint; their torque parameters scale
// with the joint's nominal stiffness T_j = k_j · 1 rad (N·m), so fingers and wrist share one
// definition.
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <string>
#include <vector>

#include "diagnosis/extended_model.h"
#include "sim/model_params.h"

namespace fesim::diagnosis {

/// The 13 mechanism ids of PRODUCT.md, in its order.
const std::vector<std::string>& MechanismIds();

struct Candidate {
  std::string id;                      ///< one of MechanismIds().
  std::string joint;                   ///< output joint name for joint-level mechanisms, else "".
  std::string label;                   ///< id, or id@joint.
  std::vector<ModelParameter> params;  ///< extension parameters; start = mechanism off.
  /// Probe points (full vectors over `params`): the score directions are ŷ(probe) − ŷ(start).
  std::vector<Eigen::VectorXd> probes;
  /// Probe k may only be taken with a positive coefficient (a one-sided mechanism such as a rate
  /// or a friction torque that cannot be negative).
  std::vector<bool> one_sided;
  /// Maps the Gauss–Newton coefficients θ on the probe directions to a start point of the fit.
  std::function<Eigen::VectorXd(const Eigen::VectorXd& theta)> start_from_step;
  /// Further difference steps (FitOptions::fd_step, each in (0, 1)) of the final refit when
  /// the mechanism is accepted: the extended model is refitted from its fit once per step and the
  /// lowest Σr² kept (diagnose.h step 4, last refit). For a mechanism whose outputs are not smooth
  /// in its parameters at the default step (stiction's stick–slip switch), where LM stalls.
  std::vector<double> refit_fd_steps;
  /// Further starts of that refit: parameter `refit_scan_param` (index into `params`; −1: none)
  /// at its fitted value × each of `refit_scan_factors` (clamped to its bounds), the others at
  /// their fit. The training Σr² is simulated at each, and the refit also runs from the lowest
  /// of them, whatever its Σr² against the fit's (default-suite stiction 1104: the start at × 1.5
  /// was 0.8 % above the fit and its refit ended 5.8 % off instead of 40 %). For a parameter that
  /// acts through a threshold (stiction's static excess: whether a joint breaks away at a grid
  /// step), whose Σr² has steps a local fit does not see across.
  int refit_scan_param = -1;
  std::vector<double> refit_scan_factors;
  /// Profile starts of the screening (full vectors over `params`; empty: none). With the
  /// candidate held at each, the subject parameters are fitted (baseline_iterations LM steps)
  /// from every subject start (SubjectStarts) and from the calibration (when the starts differ
  /// in one parameter and the lowest is an inner one, two more profile points at the parabola's
  /// vertex, ParabolaVertex); everything is then fitted
  /// together (screen_iterations LM steps) from the lowest of those, and the screening keeps that
  /// fit when its Σr² is below the profiled screening's (diagnose.h step 4). For a mechanism the
  /// subject parameters mimic along a curved, multimodal valley that the profiled fit's
  /// linearisation at the calibration does not follow (arm_support: a lifting force f · W at the
  /// forearm's centre of mass is statically strength and stiffness × 1/(1 − f);
  /// docs/diagnosis.md, session 12).
  std::vector<Eigen::VectorXd> profile_starts;
  bool applicable = true;
  std::string not_applicable_reason;
};

/// Everything the library needs to know about the data.
struct LibraryContext {
  std::vector<std::string> outputs;   ///< q.<joint> columns.
  std::vector<std::string> channels;  ///< stimulated channel names (u.<channel> without "u.").
  /// Residual spectrum peak frequency per output (Hz), for the tremor start; same order.
  std::vector<double> tremor_frequency_hz;
  /// The reduced model diagnosed instead of the full model (`--model NAME`, reduced_model.h);
  /// empty: the full model.
  std::string reduced_model;
};

/// The candidate list for a rig (free joints, channels, array) and data. With a reduced model,
/// the mechanisms outside ReducedModelMechanisms() are listed as not applicable.
std::vector<Candidate> CandidateLibrary(const sim::ModelParams& rig, const LibraryContext& ctx);

/// Subject parameters recalibrated by the baseline and every extension: k.<joint> of every free
/// output joint (N·m/rad, [0.2, 5] × nominal), strength_scale (F_max of every muscle × s,
/// dimensionless, [0.3, 3]) and u_scale.<channel> of every stimulated channel (dimensionless,
/// [0.3, 3]). A reduced model has no joints or muscles: u_scale.<channel> only.
std::vector<ModelParameter> SubjectParameters(const sim::ModelParams& rig,
                                              const LibraryContext& ctx);

/// Starts of the subject calibration (full vectors over `subject`, SubjectParameters' order):
/// the nominal values first; when an output is the elbow or a shoulder coordinate (the forearm's
/// weight acts on it) also the four corners k.* × {0.8, 1.25}, strength_scale × {0.8, 1.25} (all
/// joints' stiffness together; input scales 1) — the range of the planted suite's participants
/// (planted.h). There the weight trades off against strength and stiffness (statically
/// f · W ≡ both × 1/(1 − f)), and Σr² over them has several valleys: on default elbow-rig
/// datasets the calibration from the nominal values stopped at 3–20 × the Σr² reached from a
/// corner (docs/diagnosis.md, session 12). On the hand rig the nominal start alone.
std::vector<Eigen::VectorXd> SubjectStarts(const std::vector<ModelParameter>& subject,
                                           const LibraryContext& ctx);

/// Nominal torque scale of a joint, T_j = max(k_j, 0.05) · 1 rad, N·m.
double JointTorqueScale(const sim::ModelParams& rig, int coordinate);

/// Weight of the forearm segment m_forearm · |g|, N (the arm_support force scale).
double ForearmWeightN(const sim::ModelParams& rig);

/// Where the arm_support force acts: the rig's forearm weight-compensation entry (index, cuff,
/// force), else index −1, the forearm's centre of mass and force 0.
struct SupportCuff {
  int index = -1;
  sim::Vec3d cuff_in_segment_m{};  ///< in the forearm frame, m.
  double force_n = 0.0;            ///< F_w, N.
};
SupportCuff ForearmSupportCuff(const sim::ModelParams& rig);

/// Sets the forearm weight-compensation force F_w (N, ≥ 0) at `cuff`, adding the entry when the
/// rig had none.
void SetForearmSupportForce(const SupportCuff& cuff, double force_n, sim::ModelParams* m);

}  // namespace fesim::diagnosis
