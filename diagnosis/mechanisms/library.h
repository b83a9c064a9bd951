// Helpers the mechanism files of this folder share: parameter and probe construction, the rig's
// muscle groups and joint scales, the forearm support cuff, and planting through a candidate's
// own parameter setter (so planted and fitted parameters mean the same thing).
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <string>
#include <vector>

#include "diagnosis/mechanisms/mechanism.h"
#include "sim/model_params.h"

namespace fesim::diagnosis {

/// A kModel parameter with its setter.
ModelParameter Param(const std::string& name, const std::string& unit, double start, double lower,
                     double upper, double scale,
                     std::function<void(double, sim::ModelParams*)> set);

/// `p` with its Jacobian column from forward sensitivities (ModelParameter::sensitivity): for a
/// parameter whose setter moves only recruitment, the electrode matrix, activation rates Ω, Hill
/// or passive joint parameters, muscle paths or the tremor torque (MechanismParameters.
/// SensedColumnsMatchCentralDifferencesOfWholeSimulations checks each). A candidate fit then
/// costs one sensitivity integration per trial for all such columns instead of a simulation
/// per column and trial.
ModelParameter Sensed(ModelParameter p);

/// The start values of `params` as a vector.
Eigen::VectorXd Starts(const std::vector<ModelParameter>& params);

/// Probe = start with parameter k moved to `value`.
Eigen::VectorXd ProbeAt(const std::vector<ModelParameter>& params, int k, double value);

/// The default start_from_step: start + Σ θ_k (probe_k − start), clamped to the bounds.
void SetLinearStart(Candidate* c);

/// Coordinate indices of the output joints (q.<joint> columns of ctx.outputs).
std::vector<int> OutputJoints(const LibraryContext& ctx);

/// Indices of the muscles whose wrist_flexion moment arm is negative (extensors) or positive
/// (flexors).
std::vector<int> WristGroup(const sim::ModelParams& m, bool extensors);

/// The rest angles q₀ of every coordinate, rad.
std::vector<double> RestPosture(const sim::ModelParams& m);

/// Nominal torque scale of a joint, T_j = max(k_j, 0.05) · 1 rad, N·m.
double JointTorqueScale(const sim::ModelParams& rig, int coordinate);

/// Torque scale of a joint for a periodic torque at f_hz (a tremor): the magnitudes of the nominal
/// joint's stiffness, inertia and damping terms at ω = 2π f, (k + I ω² + b ω) · 1 rad, N·m —
/// at least |k − I ω² + i b ω|, the torque that moves the joint by 1 rad at f (I: the mass
/// matrix's diagonal entry of the coordinate at the rig's initial posture, everything distal to
/// the joint moving with it). Above a few hertz the inertia dominates (wrist, 6 Hz: I ω² ≈ 5 k).
double PeriodicTorqueScale(const sim::ModelParams& rig, int coordinate, double f_hz);

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

/// Plants candidate parameter `name` of mechanism `id` (at the wrist for joint-level ones) at
/// `value` through the candidate's own setter, and records it as "<label>:<name>". Throws
/// std::invalid_argument when the library has no such parameter on this rig.
void PlantViaCandidate(const std::string& id, const std::string& name, double value,
                       const LibraryContext& ctx, sim::ModelParams* truth,
                       std::vector<NamedValue>* planted);

/// Evidence text helper: printf-style with up to three numbers.
std::string Fmt(const char* format, double a, double b = 0.0, double c = 0.0);

// The evidence lines the mechanisms share (Mechanism::evidence).
/// The strongest input–residual cross-correlation and its lag (input-side timing and gain).
std::string InputLagEvidence(const OutputSignature& s);
/// Correlation of the residual with the predicted posture (static, posture-dependent effects).
std::string PostureEvidence(const OutputSignature& s);
/// Correlations with velocity and its sign (friction, reflexes).
std::string VelocityEvidence(const OutputSignature& s);
/// Correlations with cumulative stimulation and time (use-dependent force).
std::string UseEvidence(const OutputSignature& s);

// The table's entries, one per file of this folder.
Mechanism FatigueMechanism();
Mechanism PotentiationMechanism();
Mechanism DelayMechanism();
Mechanism TremorMechanism();
Mechanism CrosstalkMechanism();
Mechanism MomentArmPostureMechanism();
Mechanism ForceLengthVelocityMechanism();
Mechanism UnequalMuscleDynamicsMechanism();
Mechanism PassiveStiffnessNonlinearMechanism();
Mechanism ArmSupportMechanism();
Mechanism StictionMechanism();
Mechanism SpasticityMechanism();
Mechanism SensorDriftMechanism();
Mechanism PassiveAsymmetryControl();  // a control (Mechanism::control)

}  // namespace fesim::diagnosis
