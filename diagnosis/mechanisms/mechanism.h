// The candidate mechanisms of `fesim diagnose` (PRODUCT.md "Diagnosis" step 3): one file per
// mechanism in this folder, each a `Mechanism` — what it means, the model extension (parameters
// that switch it on in the full model (12): sim/mechanisms.h, sim/passive_joint.h, sim/sensors.h,
// sim/arm_support.h), the probe directions of its score test (diagnosis/tests.h), how a start of
// its fit follows from the test, refit hints, the effect the planted-data generator
// (diagnosis/planted.h) puts into fesim's own model, and the evidence line of the report —
// registered in one table (registry.cc, PRODUCT.md's order). Nothing outside this folder branches
// on a mechanism id: the pipeline reads these fields.
//
// Units: every ModelParameter states its own (SI). Joint-level mechanisms get one candidate per
// free output joint; their torque parameters scale with the joint's nominal stiffness
// T_j = k_j · 1 rad (N·m, JointTorqueScale), so fingers and wrist share one definition.
#pragma once

#include <Eigen/Dense>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "diagnosis/extended_model.h"
#include "diagnosis/signatures.h"
#include "sim/model_params.h"

namespace fesim::diagnosis {

/// One named value with its 95 % half-width (NaN: not estimable).
struct NamedValue {
  std::string name, unit;
  double value = 0.0, ci95 = NAN;
};

/// Everything the library needs to know about the rig's data.
struct LibraryContext {
  std::vector<std::string> outputs;   ///< q.<joint> columns.
  std::vector<std::string> channels;  ///< stimulated channel names (u.<channel> without "u.").
  /// Residual spectrum peak frequency per output (Hz), for the tremor start; same order.
  std::vector<double> tremor_frequency_hz;
  /// Training trials (Candidate::phase_per_trial), ≥ 1.
  int training_trials = 1;
  /// The held-out data are recordings of their own, not the tail of a training trial
  /// (Candidate::drift_per_trial).
  bool heldout_recordings_apart = false;
  /// The reduced model diagnosed instead of the full model (`--model NAME`, reduced_model.h);
  /// empty: the full model.
  std::string reduced_model;
};

/// One candidate: a mechanism at one output joint (joint-level) or on the whole model.
struct Candidate {
  std::string id;                      ///< a Mechanisms() id.
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
  /// Further difference steps (FitOptions::fd_step, each in (0, 1)) of the final refit when the
  /// mechanism is accepted (extension.h, last refit): for a mechanism whose outputs are not smooth
  /// in its parameters at the default step (stiction's stick–slip switch), where LM stalls.
  std::vector<double> refit_fd_steps;
  /// Further starts of that refit: parameter `refit_scan_param` (index into `params`; −1: none)
  /// at its fitted value × each of `refit_scan_factors` (clamped to its bounds), the lowest
  /// training Σr² of them a start whatever its Σr² against the fit's. For a parameter that acts
  /// through a threshold (stiction's static excess), whose Σr² has steps a local fit does not see
  /// across.
  int refit_scan_param = -1;
  std::vector<double> refit_scan_factors;
  /// Profile starts of the screening (full vectors over `params`; empty: none): with the
  /// candidate held at each, the person parameters are fitted, then everything together from the
  /// lowest — when the calibrated model predicts an output worse than the black box
  /// (extension.h, DiagnoseSettings::profile_gate). For a mechanism the
  /// person parameters mimic along a curved valley (arm_support: a lifting force f·W at the
  /// forearm's centre of mass is statically a stronger, stiffer person by 1/(1 − f)).
  std::vector<Eigen::VectorXd> profile_starts;
  /// Index into `params` of a phase that no trial shares with another (a physiological tremor is
  /// not phase-locked to the start of a recording); −1: none. The extended model's held-out
  /// prediction takes, per held-out trial, the phase that fits it best (extension.h), the other
  /// parameters as fitted.
  int free_phase_param = -1;
  /// With several training trials, the free phase of each (filled by CandidateLibrary): index
  /// t (into `params`) is trial t's (ModelParameter::trial = t; index 0 is free_phase_param, the
  /// others appended after the mechanism's own parameters), so that a tremor restarting at its
  /// own phase in each recording is fitted as such. Empty: one phase for every trial.
  std::vector<int> phase_per_trial;
  /// Output drifts (ModelParameter::kOutputDrift) of one rate per recording
  /// (ModelParameter::trial with several training trials): a sensor zeroed at the start of each
  /// recording drifts at that recording's own rate. The score directions are split per training
  /// trial; the extended model's held-out prediction estimates each held-out recording's rates
  /// from the first half of it and predicts the whole of it (extension.h). False when the held-out
  /// data are the tail of the one training recording, whose fitted rate they share.
  bool drift_per_trial = false;
  /// A control (Mechanism::control): fitted and judged like a mechanism, never a cause.
  bool control = false;
  bool joint_by_fit = false;  ///< Mechanism::joint_by_fit.
  bool applicable = true;
  std::string not_applicable_reason;
};

/// What the planted-data generator hands a mechanism's `plant`.
struct PlantContext {
  const LibraryContext& library;     ///< outputs and the two stimulated channels.
  double scale = 1.0;                ///< effect scale s > 0 (planted.h: s = 1 ≈ the noise RMS).
  double tremor_frequency_hz = 6.0;  ///< drawn per data set, Hz.
  double tremor_phase_rad = 0.0;     ///< drawn per data set, rad.
};

/// The effect a mechanism plants into fesim's own model: model changes on `truth`, sensor
/// changes on `sensors`, and the planted values named like the fitted parameters
/// ("<label>:<parameter>").
using PlantFn = std::function<void(const PlantContext& ctx, sim::ModelParams* truth,
                                   sim::SensorSuite* sensors, std::vector<NamedValue>* planted)>;

struct Mechanism {
  std::string id;           ///< PRODUCT.md id (a control's own id).
  std::string description;  ///< what it is, for the verdict sentence ("muscle fatigue (…)").
  /// It acts on the stimulation or on the measured output only, so it can extend a reduced model
  /// (diagnosis/reduced_model.h implements those forms).
  bool reduced_model_form = false;
  /// Planted-data protocols on which its effect can reach the noise RMS (planted.h).
  std::vector<std::string> planted_protocols = {"steps", "grid"};
  /// Its candidates for a rig and data (one per free output joint for joint-level mechanisms).
  std::function<std::vector<Candidate>(const sim::ModelParams& rig, const LibraryContext& ctx)>
      candidates;
  PlantFn plant;
  /// The descriptive signature figures quoted as its evidence, from the residual summary of the
  /// output it acts on (or the largest).
  std::function<std::string(const OutputSignature& s)> evidence;
  /// The shape its signature must have in the residual it is to explain (per training trial and
  /// output: the residual of the candidate's fit with its own output terms, kOutputDrift, added
  /// back), checked before a fitted candidate passes: the reason that residual contradicts it, or
  /// "" (sensor_drift: a trend, not a step). Null: none. Only output-level terms are added back,
  /// so a mechanism acting through the dynamics would need its ablated fit's simulation.
  std::function<std::string(const std::vector<ResidualSeries>& residual)> shape_contradiction;
  /// Its extension is a smooth function of its joint's angle — a passive torque or a moment arm —
  /// which the person's parameters of that joint (ModelParameter::joint: passive k, k₃, rest
  /// angle, the groups' moment-arm scales) approximate to first order. When one of those ended at
  /// a bound of its range in the model the candidate extends, the person lies outside the model's
  /// range at that joint, the candidate may stand in for it, and it is not accepted (extension.h).
  /// Not for signatures the person cannot produce: a spectral line, a velocity threshold.
  bool mimics_joint_person = false;
  /// Its joint is chosen by the fit, not by the score statistic: its effect reaches the coupled
  /// joints — a wrist torque moves the fingers through the extrinsic finger muscles — and the
  /// largest statistic can be at a joint it does not act on (foreign 1004: a wrist tremor's
  /// statistic 614 at the MCP, 607 at the wrist). Every joint whose test is significant is fitted
  /// and the fit of lowest training Σr² is judged (extension.h, Screening).
  bool joint_by_fit = false;
  /// A control, not a mechanism: a way a normal person differs from the calibrated one that the
  /// person parameters (person.h) do not express. It competes with the mechanisms in the
  /// extension (extension.h) so that a mechanism is named only for what it explains beyond normal
  /// variation; a misfit a control explains as well is `none` (verdict.h). No plant.
  bool control = false;
};

/// The 13 mechanisms of PRODUCT.md, in its order (registry.cc).
const std::vector<Mechanism>& Mechanisms();
/// The controls (Mechanism::control), registered after the mechanisms (registry.cc).
const std::vector<Mechanism>& Controls();
/// The mechanisms' ids, in that order.
const std::vector<std::string>& MechanismIds();
/// The mechanism or control with this id; std::invalid_argument naming the id and the allowed
/// ones.
const Mechanism& FindMechanism(const std::string& id);

/// The candidate list for a rig (free joints, channels, array) and data, every mechanism's in
/// table order, then every control's. With a reduced model, the mechanisms without
/// reduced_model_form are listed as not applicable.
std::vector<Candidate> CandidateLibrary(const sim::ModelParams& rig, const LibraryContext& ctx);

}  // namespace fesim::diagnosis
