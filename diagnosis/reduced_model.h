// `fesim diagnose --model NAME` (issue 7): a reduced model of the identification library (the
// Hammerstein family: papers/000_0a6c0de9fc69df7c.txt eq. 16–24, papers/002_78a57b74c57ee464.txt
// eq. 1–2), identified on the training part, as the simulation the diagnosis calibrates and
// extends instead of the full model (12).
//
// A reduced model maps pulse widths u.* to joint angles q.*; it has no muscles, joints or support,
// so only the mechanisms that act on its input or on its output can extend it. They read the same
// sim::ModelParams fields the full model's extensions set (mechanisms/), in these forms:
//   delay          u_c(t − δ), linear interpolation, u_c(t₀) before t₀ + δ (as the full model:
//                  recruitment sees the delayed input)
//   crosstalk      u_c + c Σ_{c'≠c} w_cc' u_c',  w_cc' = exp(−d²_cc' / (2 σ_x²)), d_cc' the
//   distance
//                  of the two channels' pad centroids on the array (channels without pads: w = 0)
//   fatigue        u_c φ_c(t), dφ/dt of sim/mechanisms.h (Riener 1996) driven by ā_c = u_c /
//   u_ref,c potentiation   u_c (1 + g p_c(t)), dp/dt of sim/mechanisms.h driven by ā_c tremor q_j +
//   τ(t) / T_j: the tremor torque of sim/mechanisms.h through the joint's
//                  nominal static compliance 1 / T_j (JointTorqueScale)
//   sensor_drift   value · t on q.* (ModelParameter::kOutputDrift, as for the full model)
// u_ref,c is the channel's largest training pulse width (the reduced model knows no recruitment
// curve, so ā stands in for activation: fitted rates are per unit of ā). Fatigue and potentiation
// scale the pulse width, not the force; their fitted parameters are those of this input-side form
// and are not comparable one to one with the full model's. The other mechanisms (moment arms,
// force–length–velocity, muscle dynamics, passive joint, support, friction, reflex) act inside the
// musculoskeletal model and are not applicable.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "base/trial.h"
#include "diagnosis/extended_model.h"
#include "identification/method.h"
#include "sim/model_params.h"

namespace fesim::diagnosis {

/// The mechanism ids a reduced model can be extended with (the forms above; Mechanism::
/// reduced_model_form).
const std::vector<std::string>& ReducedModelMechanisms();

/// The reduced models `--model` accepts: the identification methods with a fit_simulator.
std::vector<identification::MethodEntry> ReducedModelMethods();

/// Exact step of a state x with affine dynamics dx/dt = f0 + (f1 − f0) x (f0 = dx/dt at x = 0,
/// f1 at x = 1) over h seconds with the drive held: x∞ + (x − x∞) e^{−αh}, α = f0 − f1 > 0,
/// x∞ = f0 / α. Both the fitness and the potentiation state of sim/mechanisms.h are affine in
/// their state for a held activation.
double AffineStateStep(double f0, double f1, double x, double h_s);

/// The input-side mechanisms of `m` (delay, crosstalk, fatigue, potentiation, in that order)
/// applied to the u.* columns `inputs` of `trial`; `u_ref` holds u_ref,c per input column (µs).
Trial ApplyInputMechanisms(const sim::ModelParams& m, const Trial& trial,
                           const std::vector<std::string>& inputs,
                           const std::map<std::string, double>& u_ref);

/// The output-side tremor of `m` added to its joint's q.* column of `outputs` (when present).
void AddOutputTremor(const sim::ModelParams& m, Trial* outputs);

/// A fitted reduced model as the diagnosis' simulator: inputs through ApplyInputMechanisms, the
/// reduced model, then AddOutputTremor. `u_ref` as above.
TrialSimulator ReducedSimulator(const identification::FittedSimulator& fitted,
                                const std::map<std::string, double>& u_ref);

/// The training trials a reduced model is identified on: each training trial cut after its last
/// counted sample, with the view's outputs and the given u.* channels only, NaN output gaps filled
/// by linear interpolation between the finite neighbours (held at the ends), and the time column
/// made exactly uniform (its mean step; the view's records are uniform to within 1 %). Sets `u_ref`
/// to each channel's largest training pulse width. Throws std::runtime_error when an output has no
/// finite sample.
std::vector<Trial> ReducedTrainingTrials(const DataView& train,
                                         const std::vector<std::string>& channels,
                                         std::map<std::string, double>* u_ref);

}  // namespace fesim::diagnosis
