// Integration of an UpperLimbModel's state through a trial.
//
// Default: SUNDIALS CVODES, variable-order BDF with a dense direct linear solver (difference-
// quotient Jacobian), over the whole Simbody state y = [q, u, z] (z: activation states). Simbody
// supplies ẏ through realize(Acceleration). Stimulation is piecewise constant (the 40 Hz pulse
// width held between pulses); every change is a breakpoint at which CVODES stops exactly
// (CVodeSetStopTime), so no step straddles a discontinuity; the muscle activations are solved in
// closed form per interval, which keeps the right-hand side seen by CVODES continuous there.
// Cross-check: Simbody's Runge–Kutta–Merson integrator over the same segments.
#pragma once

#include <Simbody.h>

#include <functional>
#include <string>
#include <vector>

#include "sim/model_params.h"
#include "sim/upper_limb_model.h"

namespace fesim::sim {

/// Piecewise-constant stimulation: values[k] (µs per channel) holds from times[k] (s) until
/// times[k + 1]; before times[0] the stimulation is zero. times strictly increasing.
struct StimulationSchedule {
  std::vector<double> times;
  std::vector<std::vector<double>> values;
  /// Value at t (zero-order hold).
  std::vector<double> At(double t, int channels) const;
};

struct IntegrationStats {
  long steps = 0;            ///< internal integrator steps.
  long rhs_evaluations = 0;  ///< ẏ evaluations (Simbody realize(Acceleration) calls).
  long jacobian_evaluations = 0;
  long breakpoints = 0;  ///< stimulation changes crossed (exact integrator stops).
};

/// Called at each report time with the state realised to the requested stage.
using Observer = std::function<void(const SimTK::State&)>;

/// Advances `state` (at its current time) through `report_times` (sorted, ≥ state time),
/// applying the schedule's stimulation changes, and calls `observer` at each report time with
/// the state realised to `observe_stage` (Velocity suffices for kinematics; Acceleration is
/// needed for sensor torques; Stage::Instance suffices to read the time and the state variables
/// q, u and the activations, hence UpperLimbModel::ComputeMuscles, and saves realising the time
/// and the kinematics at every report time). Throws std::runtime_error naming the simulated time
/// and the integrator's reason on failure.
IntegrationStats IntegrateTrial(const UpperLimbModel& model, const IntegratorParams& params,
                                const StimulationSchedule& schedule,
                                const std::vector<double>& report_times, SimTK::State* state,
                                const Observer& observer,
                                SimTK::Stage observe_stage = SimTK::Stage::Acceleration);

/// Called at each report time with its time t (s) and the whole Y (NY values in Simbody's
/// layout [q, u, z], the activations in closed form at t): UpperLimbModel::GetQs(layout, y),
/// GetUs and ComputeMuscles read it.
using VariablesObserver = std::function<void(double t, const double* y)>;

/// Which entries of a VariablesObserver's y are current.
enum class VariablesObserved {
  kAll,                ///< q, u and every z (the closed-form activations computed at t).
  kPositionsAndSpeeds  ///< q and u (the activations not computed: stale; ≈ 14 exp per row).
};

/// IntegrateTrial for an observer that reads state variables only: with a CVODES method the
/// solution at a report time is read from CVODES' own vector and never written into `state`
/// (each such write invalidates Simbody's stages, docs/performance.md "Default model real-time
/// factor"), so `observer` sees bitwise the values IntegrateTrial's observer would read from the
/// state (those `observe` names). `state` ends at the last report time, as with IntegrateTrial.
IntegrationStats IntegrateTrialVariables(const UpperLimbModel& model,
                                         const IntegratorParams& params,
                                         const StimulationSchedule& schedule,
                                         const std::vector<double>& report_times,
                                         SimTK::State* state, const VariablesObserver& observer,
                                         VariablesObserved observe = VariablesObserved::kAll);

/// One parameter θ_k of a forward-sensitivity integration: the model with θ_k moved by `step`.
/// The sensitivity right-hand side re-evaluates only what depends on the parameters through
/// pure functions — recruitment and the electrode matrix (RecruitedFractions), the activation
/// rates Ω (eq. 6 in closed form), Hill and passive joint parameters and muscle paths
/// (MuscleAndPassiveTorques), the tremor torque (TremorTorque, a function of t) — and, when a
/// segment's mass, centre of mass or inertia differs, the whole Simbody right-hand side of a model
/// built from `params` at the same (t, y). `params` may differ from the integrated model only
/// there (differences elsewhere, e.g. the arm support or the electromechanical delay, are not
/// seen).
struct ParameterPerturbation {
  ModelParams params;
  double step = 0.0;   ///< θ_k(params) − θ_k(model), in θ_k's unit, ≠ 0 and small.
  double scale = 1.0;  ///< typical |θ_k|, > 0; CVODES scales the sensitivity tolerances by it.
};

/// Called at each report time with its time t (s), the whole Y as a VariablesObserver gets it
/// (UpperLimbModel::GetQs(layout, y) reads it; the activations in closed form at t) and the
/// sensitivities dq[c · P + k] = ∂q_c/∂θ_k (rad per unit of θ_k) of every coordinate c (0 for
/// locked and prescribed ones).
using SensitivityObserver =
    std::function<void(double t, const double* y, const std::vector<double>& dq_dtheta)>;

/// IntegrateTrial (CVODES methods only) with forward sensitivities of the state to P parameters
/// (`parameters`), integrated alongside it: ṡ_k = (∂f/∂y) s_k + ∂f/∂θ_k, s_k(0) = 0 (the initial
/// state does not depend on them), CVODES' staggered corrector, sensitivities kept out of the
/// local error test (the state takes the same steps as without them). ∂f/∂θ_k =
/// [0; M_ff⁻¹ ∂τ_f/∂θ_k], with τ = MuscleAndPassiveTorques (+ TremorTorque) at the activations
/// a(t; θ) whose sensitivities ∂a/∂θ_k follow eq. (6) in closed form (linear in w and the initial
/// state) from ∂w/∂θ_k = difference quotient of RecruitedFractions (plus, for a θ_k that moves
/// Ω, the difference quotient of the free response in Ω), and M_ff the mass matrix of the free
/// coordinates; for a θ_k that moves a segment's inertia, ∂u̇/∂θ_k is instead the difference
/// quotient of the right-hand side of a second Simbody system built from its parameters, realised
/// at the same (t, y) (one realize(Acceleration) per step and such parameter). ∂f/∂y = [0 I; ∂u̇/∂q
/// ∂u̇/∂u] is split in two: M_ff⁻¹ ∂τ/∂y of the muscle and passive torques (stiff and fast-changing
/// with the activations) is formed at every step by difference quotients of the pure
/// MuscleAndPassiveTorques; the rest (gravity, velocity products, ∂M_ff/∂q, support, tremor) is the
/// difference quotient of the Simbody right-hand side (one per CVODES component) less that part,
/// formed with M_ff at every `state_jacobian_every`-th new (t, y) and at each stimulation
/// breakpoint, and reused in between. 1 is exact to the integrator's tolerance; 16 (the default)
/// costs n_y/16 right-hand sides per step and gives sensitivities within 0.07 % of central
/// differences of whole simulations
/// (Integrator.ForwardSensitivitiesMatchCentralDifferencesOfWholeSimulations) and within 0.2 %
/// (whole Jacobian; worst column 1.5 %, relative RMS) of the exact ones on the hand-array step grid
/// at tolerance 1e-3 (bench/fullmodel_bench.cc BM_SensitivityDataSet; forming the whole ∂f/∂y every
/// 4th step instead gave 1.4 % / 5.9 %). A perturbed simulation per parameter costs ≈ 2 right-hand
/// sides per step; this costs ≈ 3 + n_y/state_jacobian_every per step for all P together (CVODES
/// evaluates f once more per step for the staggered corrector) plus 1 + n_y + (parameters that move
/// τ) evaluations of the pure torque function. With fatigue or potentiation (mechanisms.h) their
/// states φ_j, p_j are CVODES components too; their columns of ∂f/∂y are formed exactly at every
/// step and not differenced (∂u̇/∂z_j = M_ff⁻¹ ∂τ/∂g_j ∂g_j/∂z_j through the active-force gain
/// g_j = φ_j (1 + g p_j), ∂ż_j/∂z_j of the bilinear rates), their rows of ∂f/∂θ are
/// ∂ż_j/∂a_j ∂a_j/∂θ_k plus the direct difference quotient of a θ_k that moves their rate
/// parameters, and τ carries the gains
/// (Integrator.SensitivitiesWithFatigueAndPotentiationMatchCentralDifferences). Throws
/// std::invalid_argument when the model has the stretch reflex's states, a perturbed model
/// switches a mechanism with states on or off, or the method is Simbody's RKM, and
/// std::runtime_error like IntegrateTrial on failure.
IntegrationStats IntegrateTrialSensitivities(
    const UpperLimbModel& model, const IntegratorParams& params,
    const StimulationSchedule& schedule, const std::vector<double>& report_times,
    const std::vector<ParameterPerturbation>& parameters, SimTK::State* state,
    const SensitivityObserver& observer, int state_jacobian_every = 16);

}  // namespace fesim::sim
