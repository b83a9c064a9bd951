#include "sim/integrator.h"

#include <cvodes/cvodes.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunmatrix/sunmatrix_dense.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "muscles/activation.h"
#include "sim/chain_dynamics.h"
#include "sim/compiled_size.h"
#include "sim/dense_linear_solver.h"
#include "sim/sensitivity_taylor.h"
#include "sim/serial_vector.h"
#include "sim/upper_limb_model.h"
#include "tendons/tendon_network.h"

namespace fesim::sim {

std::vector<double> StimulationSchedule::At(double t, int channels) const {
  const auto it = std::upper_bound(times.begin(), times.end(), t);
  // Not `return {channels, 0.0};`: braces pick the initializer_list constructor (2 elements).
  // NOLINTNEXTLINE(modernize-return-braced-init-list): see above.
  if (it == times.begin()) return std::vector<double>(channels, 0.0);
  return values[static_cast<std::size_t>(it - times.begin()) - 1];
}

namespace {

constexpr long kMaxSteps = 1000000;
// Report times or breakpoints closer than this to the current time (s) are treated as reached:
// the state cannot change measurably over 1e-9 s, and CVODES rejects such intervals.
constexpr double kMinInterval = 1e-9;

/// Breakpoints (stimulation changes) strictly after t0.
std::vector<double> Breakpoints(const StimulationSchedule& schedule, double t0) {
  std::vector<double> b;
  for (double t : schedule.times) {
    if (t > t0) b.push_back(t);
  }
  return b;
}

/// Ends every integration failure message, whichever the integrator.
constexpr const char* kFailureHint =
    ". Hint: check stimulation, stiffness and range limits, or tighten integrator.tolerance";

/// A multi-line library message joined on one line.
std::string OneLine(std::string s) {
  for (char& c : s) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

std::string DescribeState(const UpperLimbModel& model, const SimTK::State& s) {
  // Name the coordinate furthest outside its range: the usual culprit of a blow-up.
  const auto q = model.GetQs(s);
  int worst = 0;
  double excess = -INFINITY;
  for (int i = 0; i < kNumCoordinates; ++i) {
    const auto& p = model.params().coordinates[i].passive;
    const double e = std::max(p.min_angle_rad - q[i], q[i] - p.max_angle_rad);
    if (!std::isfinite(q[i])) {
      worst = i;
      excess = INFINITY;
      break;
    }
    if (e > excess) {
      excess = e;
      worst = i;
    }
  }
  return "coordinate " + CoordinateNames()[worst] + " at " + std::to_string(q[worst]) +
         " rad (range " + std::to_string(model.params().coordinates[worst].passive.min_angle_rad) +
         ".." + std::to_string(model.params().coordinates[worst].passive.max_angle_rad) + ")";
}

struct SensitivityData;
void BeginSensitivityInterval(SensitivityData* d, const SimTK::State& state, double t);
void ReachedMuscles(SensitivityData* d);

/// CVODES integrates y = the Simbody state Y without the muscle activation states: between
/// breakpoints the stimulation, hence w, is constant and eq. (6) is solved in closed form
/// (muscles::ActivationFreeResponse), exactly and at no cost to the implicit solver. The q and u
/// of locked coordinates are left out too: they are constant (zero derivative, zero local error),
/// yet each costs one right-hand side per difference-quotient Jacobian column (the hand rig locks
/// 5 of 10 coordinates: 20 → 10 components). Because CVODES' error norm is a root mean square
/// over the components, the tolerance is scaled by √(n_with_locked / n) so that every error and
/// Newton test sees the same norm as with the locked components included.
struct CvodesContext {
  const UpperLimbModel* model;
  SimTK::State* state;
  bool prescribe;
  long rhs = 0;
  double tolerance_scale = 1.0;              // √(components with locked ones / without)
  std::vector<int> y_index;                  // Y index of each CVODES component
  int activation_index = 0;                  // Y index of muscle 0's a
  std::vector<double> omega;                 // Ω_j of the current interval, rad/s (IntervalOmega)
  std::vector<double> omega_rising;          // Ω_j, rad/s (MuscleParams::activation_omega_rad_s)
  std::vector<double> deactivation_ratio;    // MuscleParams::deactivation_ratio
  std::vector<char> falling;                 // muscle j deactivating in the current interval
  std::vector<double> w;                     // recruited fraction in the current interval
  std::vector<muscles::ActivationState> a0;  // activation state at the interval start
  double t0 = 0.0;                           // interval start, s
  double activations_time = NAN;             // t of the activations in the state (LoadState)
  SensitivityData* sens = nullptr;           // forward sensitivities, when integrated
  // Right-hand sides by UpperLimbModel::CalcYDot instead of Simbody's realisation (no
  // prescribed coordinate): its scratch, the whole Y it reads (LoadVariables) and Ẏ.
  bool fast = false;
  RhsWorkspace rhs_ws;
  std::vector<double> y_all, ydot;
  double y_all_activations_time = NAN;   // t of activations_at_t
  std::vector<double> activations_at_t;  // a, ȧ of every muscle at that t

  /// `simbody_rhs`: IntegratorParams::simbody_right_hand_side.
  CvodesContext(const UpperLimbModel* m, SimTK::State* s, bool p, bool simbody_rhs)
      : model(m), state(s), prescribe(p), fast(!p && !simbody_rhs && m->HasFastDerivatives()) {
    // The activations are eq. (6)'s closed form here (LoadState), never CVODES components.
    m->SetActivationsInClosedForm(*s, true);
    const int ny = s->getNY();
    const int nm = m->num_muscles();
    activation_index = m->ActivationYIndex(*s);
    const std::vector<int> locked = m->LockedYIndices(*s);
    std::vector<int> all;
    for (int i = 0; i < ny; ++i) {
      if (i >= activation_index && i < activation_index + 2 * nm) continue;
      all.push_back(i);
      if (!std::binary_search(locked.begin(), locked.end(), i)) y_index.push_back(i);
    }
    if (y_index.empty()) {
      y_index = all;  // everything locked: CVODES needs at least one component
    } else {
      // A welded coordinate (ModelBuildOptions::weld_locked) counts as the locked q and u it
      // stands for, so that welded and locked models see the same error norm.
      const std::size_t with_locked = all.size() + 2 * static_cast<std::size_t>(m->NumWelded());
      tolerance_scale = std::sqrt(static_cast<double>(with_locked) / y_index.size());
    }
    for (const auto& mu : m->params().muscles) {
      omega_rising.push_back(mu.activation_omega_rad_s);
      deactivation_ratio.push_back(mu.deactivation_ratio);
    }
    omega = omega_rising;
    falling.assign(omega.size(), 0);
  }
  /// Records the activation state and input at the start of an interval.
  void BeginInterval(double t) {
    if (sens != nullptr) BeginSensitivityInterval(sens, *state, t);
    t0 = t;
    activations_time = NAN;  // the state's activations are of the previous interval's input
    y_all_activations_time = NAN;
    w = model->RecruitedFractions(*state);
    const SimTK::Vector& Y = state->getY();
    a0.resize(omega.size());
    for (std::size_t j = 0; j < omega.size(); ++j) {
      a0[j] = {Y[activation_index + 2 * static_cast<int>(j)],
               Y[activation_index + 2 * static_cast<int>(j) + 1]};
      falling[j] = muscles::Deactivating(w[j], a0[j]);
      omega[j] = muscles::IntervalOmega(omega_rising[j], deactivation_ratio[j], w[j], a0[j]);
    }
    if (sens != nullptr) ReachedMuscles(sens);  // with the new interval's Ω
  }
};

/// True when a and b have the same bits (so that −0 differs from 0 and NaN equals itself).
bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

/// Puts (t, y) and the activations at t into the context's state and realises it to `stage`.
/// Only what differs from the state's values is written: Simbody invalidates every stage from
/// the one a variable belongs to (time: Stage::Time; q: Position; u: Velocity; z: Dynamics), so a
/// call that moves only u — the speed columns of the difference-quotient Jacobian — keeps the
/// kinematics and articulated-body inertias of the positions, and one at the time of the last
/// call skips Stage::Time and the closed-form activations. The state realised is the same as when
/// everything is written.
void LoadState(CvodesContext* c, double t, const double* y,
               SimTK::Stage stage = SimTK::Stage::Acceleration) {
  SimTK::State& s = *c->state;
  const int nq = s.getNQ(), nu = s.getNU();
  bool q_differs = false, u_differs = false, z_differs = false;
  {
    const double* Y = s.getY().getContiguousScalarData();
    for (std::size_t i = 0; i < c->y_index.size(); ++i) {
      const int yi = c->y_index[i];
      if (SameBits(Y[yi], y[i])) continue;
      (yi < nq ? q_differs : yi < nq + nu ? u_differs : z_differs) = true;
    }
  }
  const bool new_time = !SameBits(s.getTime(), t);
  const bool new_activations = new_time || !SameBits(c->activations_time, t);
  if (q_differs) {
    double* q = s.updQ().updContiguousScalarData();
    for (std::size_t i = 0; i < c->y_index.size(); ++i) {
      if (c->y_index[i] < nq) q[c->y_index[i]] = y[i];
    }
  }
  if (u_differs) {
    double* u = s.updU().updContiguousScalarData();
    for (std::size_t i = 0; i < c->y_index.size(); ++i) {
      const int yi = c->y_index[i];
      if (yi >= nq && yi < nq + nu) u[yi - nq] = y[i];
    }
  }
  if (z_differs || new_activations) {
    double* z = s.updZ().updContiguousScalarData();
    for (std::size_t i = 0; i < c->y_index.size(); ++i) {
      const int yi = c->y_index[i];
      if (yi >= nq + nu) z[yi - nq - nu] = y[i];
    }
    const int a_index = c->activation_index - nq - nu;
    for (std::size_t j = 0; j < c->omega.size(); ++j) {
      const auto a = muscles::ActivationFreeResponse(c->omega[j], c->w[j], c->a0[j], t - c->t0);
      z[a_index + 2 * static_cast<int>(j)] = a.a;
      z[a_index + 2 * static_cast<int>(j) + 1] = a.a_dot;
    }
    c->activations_time = t;
  }
  if (new_time) s.setTime(t);
  if (c->prescribe && (new_time || q_differs || u_differs)) c->model->system().prescribe(s);
  c->model->system().realize(s, stage);
}

/// The whole Y at (t, y) into c->y_all, as LoadState would put it into the state: the state's
/// Y with y at the CVODES components and the closed-form activations at t (computed again only
/// when t changes; not at all without `activations`: then they are the state's, stale). Writes
/// nothing into the state.
void LoadVariables(CvodesContext* c, double t, const double* y, bool activations = true) {
  const SimTK::Vector& Y = c->state->getY();
  const double* from = Y.getContiguousScalarData();
  c->y_all.assign(from, from + Y.size());
  for (std::size_t i = 0; i < c->y_index.size(); ++i) c->y_all[c->y_index[i]] = y[i];
  if (!activations) return;
  double* act = c->y_all.data() + c->activation_index;
  if (SameBits(c->y_all_activations_time, t)) {
    std::copy(c->activations_at_t.begin(), c->activations_at_t.end(), act);
    return;
  }
  c->activations_at_t.resize(2 * c->omega.size());
  for (std::size_t j = 0; j < c->omega.size(); ++j) {
    const auto a = muscles::ActivationFreeResponse(c->omega[j], c->w[j], c->a0[j], t - c->t0);
    c->activations_at_t[2 * j] = act[2 * j] = a.a;
    c->activations_at_t[2 * j + 1] = act[2 * j + 1] = a.a_dot;
  }
  c->y_all_activations_time = t;
}

/// ẏ at (t, y) into out; 0, or 1 (recoverable: CVODES retries with a smaller step) on failure.
/// Without prescribed coordinates by UpperLimbModel::CalcYDot on the variables LoadVariables
/// gathers (Simbody's Ẏ to round-off, UpperLimbModel.FastDerivativesMatchSimbody), otherwise by
/// Simbody's realize(Acceleration).
int EvaluateRhs(CvodesContext* c, double t, const double* y, double* out) {
  ++c->rhs;
  const double* yd = nullptr;
  try {
    if (c->fast) {
      LoadVariables(c, t, y);
      c->ydot.resize(c->y_all.size());
      c->model->CalcYDot(*c->state, t, c->y_all.data(), &c->rhs_ws, c->ydot.data());
      yd = c->ydot.data();
    } else {
      LoadState(c, t, y);
      yd = &c->state->getYDot()[0];
    }
  } catch (const std::exception&) {
    return 1;
  }
  for (std::size_t i = 0; i < c->y_index.size(); ++i) {
    out[i] = yd[c->y_index[i]];
    if (!std::isfinite(out[i])) return 1;
  }
  return 0;
}

int Rhs(sunrealtype t, N_Vector y, N_Vector ydot, void* user) {
  return EvaluateRhs(static_cast<CvodesContext*>(user), t, N_VGetArrayPointer(y),
                     N_VGetArrayPointer(ydot));
}

/// Forward-sensitivity state of IntegrateTrialSensitivities (see integrator.h).
struct SensitivityData {
  struct Parameter {
    const ModelParams* params;
    muscles::ArrayMatrix array;              // BuildElectrodeMatrix(*params)
    std::vector<tendons::MusclePath> paths;  // params->muscles[j].path
    double step;                             // θ_k change, its unit
    bool moves_torques;         // TorqueParametersMayDiffer from the model: τ is re-evaluated
    bool moves_muscles;         // MuscleParametersMayDiffer (else only the passive part moves)
    bool moves_tremor;          // TremorParametersDiffer from the model: the tremor torque too
    std::vector<double> omega;  // Ω_j of params, rad/s
    std::vector<double> deactivation_ratio;  // of params' muscles
    bool moves_omega;  // some Ω_j or deactivation ratio differs from the model's
    // The fatigue or potentiation rate parameters differ from the model's (their states' ż), or
    // the potentiation gain g (the active-force gain, ActiveForceGain).
    bool moves_state_rates;
    bool moves_gain;
    // The model of *params and a state of it, when params moves a segment's inertia
    // (BodyInertiaDiffers): its whole right-hand side is differenced at the same (t, y).
    std::shared_ptr<const UpperLimbModel> body;
    std::shared_ptr<SimTK::State> body_state;
  };
  CvodesContext* ctx = nullptr;
  std::vector<Parameter> p;
  std::vector<tendons::MusclePath> paths;  // the model's muscle paths
  int n = 0;                               // CVODES components
  std::vector<int> u_component;            // [free coordinate] component of its u
  std::vector<int> free_coordinates;       // kFree coordinates, in order
  std::vector<char> read_coordinates;      // [coordinate] free: the torques the matrices read
  std::vector<int> free_u_slot;            // [free coordinate] index in the Simbody u vector
  std::vector<int> q_component;            // [coordinate] component of its q, −1 if none
  // [muscle] component of its fitness φ / potentiation state p (fatigue, potentiation), −1 if
  // the mechanism is off; their Y indices from UpperLimbModel::FitnessYIndex etc.
  std::vector<int> fitness_component, potentiation_component;
  // [component] muscle whose φ or p it is, −1 for the q and u components.
  std::vector<int> state_muscle;
  // ∂a/∂θ_k, ∂ȧ/∂θ_k of every muscle at the interval start and ∂w/∂θ_k in it: [k][j].
  std::vector<std::vector<muscles::ActivationState>> da0;
  std::vector<std::vector<double>> dw;
  // [k] the muscles whose ∂a/∂θ_k may be non-zero in the interval (ReachedMuscles) or that have
  // a fitness or potentiation state; FormParameterColumns visits only these (a muscle outside
  // contributes exactly 0: θ_k of one channel, Hill or recruitment parameter reaches one or a few
  // muscles of 14). `reached_any`: [j] muscle j is in some list (its ActivationFreeResponse
  // coefficients are needed).
  std::vector<std::vector<std::size_t>> reached;
  std::vector<char> reached_any;
  double t0 = 0.0;
  bool started = false;
  // ∂f/∂y (n × n, column-major) and ∂f/∂θ (n × P, column-major) at (t_cache, y_cache).
  bool cached = false;
  std::vector<double> mass_inv;  // M_ff⁻¹ (nf × nf, column-major), formed with ∂f/∂y
  int jac_age = -1;   // new points since ∂f/∂y and M_ff were formed (−1: at the next one)
  int jac_reuse = 1;  // form them at every jac_reuse-th new point (and after breakpoints)
  double t_cache = 0.0;
  std::vector<double> y_cache, jac, dfdp;
  // The free u rows of ∂f/∂y less M_ff⁻¹ ∂τ/∂y of MuscleAndPassiveTorques, at the last full
  // formation (nf × n, column-major): the slowly varying rigid-body part.
  std::vector<double> jac_rest;
  std::vector<double> f1, y1;  // scratch
  bool any_body = false;       // some parameter has a `body` (BodyRhsDifference)
};

/// False only when `a` and `b` give the same muscle torques R f of MuscleAndPassiveTorques for
/// every state: equal Hill parameters and paths of every muscle (compared bytewise, so −0 vs 0
/// counts as a difference: conservative).
bool MuscleParametersMayDiffer(const ModelParams& a, const ModelParams& b) {
  static_assert(std::is_trivially_copyable_v<muscles::HillParams> &&
                    sizeof(muscles::HillParams) % sizeof(double) == 0,
                "HillParams: doubles only (compared bytewise)");
  static_assert(std::is_trivially_copyable_v<PassiveJointParams> &&
                    sizeof(PassiveJointParams) % sizeof(double) == 0,
                "PassiveJointParams: doubles only (compared bytewise)");
  if (a.muscles.size() != b.muscles.size()) return true;
  for (std::size_t j = 0; j < a.muscles.size(); ++j) {
    const auto& ma = a.muscles[j];
    const auto& mb = b.muscles[j];
    // Bytewise on purpose: a field added later is compared too, and the doubles' non-unique
    // representations (±0, NaN payloads) can only report a difference (one more evaluation).
    // NOLINTNEXTLINE(bugprone-suspicious-memory-comparison): see above.
    if (std::memcmp(&ma.hill, &mb.hill, sizeof(ma.hill)) != 0) return true;
    if (!tendons::SameGeometry(ma.path, mb.path)) return true;
  }
  return false;
}

/// False only when `a` and `b` give the same MuscleAndPassiveTorques for every state: the muscles
/// (MuscleParametersMayDiffer) and the passive parameters of every coordinate equal (bytewise).
bool TorqueParametersMayDiffer(const ModelParams& a, const ModelParams& b) {
  if (MuscleParametersMayDiffer(a, b)) return true;
  for (int c = 0; c < kNumCoordinates; ++c) {
    // NOLINTNEXTLINE(bugprone-suspicious-memory-comparison): bytewise on purpose, as above.
    if (std::memcmp(&a.coordinates[c].passive, &b.coordinates[c].passive,
                    sizeof(PassiveJointParams)) != 0) {
      return true;
    }
  }
  return false;
}

/// True when `a` and `b` give different tremor torques (mechanisms.h TremorTorque) at some t.
/// Whether some segment's mass, centre of mass or inertia differs between `a` and `b` (what the
/// Simbody system computes and the pure torque functions do not see).
bool BodyInertiaDiffers(const ModelParams& a, const ModelParams& b) {
  for (std::size_t i = 0; i < a.segments.size(); ++i) {
    const SegmentParams &x = a.segments[i], &y = b.segments[i];
    if (x.mass_kg != y.mass_kg || x.com_in_body_m != y.com_in_body_m ||
        x.inertia_about_com_kg_m2 != y.inertia_about_com_kg_m2) {
      return true;
    }
  }
  return false;
}

/// True when `a` and `b` give different fatigue or potentiation rates (FitnessDerivative,
/// PotentiationDerivative) at some activation and state.
bool StateRatesDiffer(const MechanismParams& a, const MechanismParams& b) {
  const FatigueParams &fa = a.fatigue, &fb = b.fatigue;
  const PotentiationParams &pa = a.potentiation, &pb = b.potentiation;
  return (fa.enabled &&
          (fa.fatigue_time_s != fb.fatigue_time_s || fa.recovery_time_s != fb.recovery_time_s ||
           fa.min_fitness != fb.min_fitness)) ||
         (pa.enabled && (pa.rise_time_s != pb.rise_time_s || pa.decay_time_s != pb.decay_time_s));
}

bool TremorParametersDiffer(const TremorParams& a, const TremorParams& b) {
  if (!a.enabled && !b.enabled) return false;
  return a.enabled != b.enabled || a.coordinate != b.coordinate ||
         a.frequency_hz != b.frequency_hz || a.amplitude_nm != b.amplitude_nm ||
         a.amplitude_modulation != b.amplitude_modulation || a.modulation_hz != b.modulation_hz ||
         a.frequency_drift_hz_per_s != b.frequency_drift_hz_per_s || a.phase_rad != b.phase_rad;
}

/// Whether θ_k moves muscle j's Ω of the current interval (the interval's branch of
/// IntervalOmega is the model's: a discrete choice, not differentiated); `*omega` its Ω.
bool MovesIntervalOmega(const CvodesContext& c, const SensitivityData::Parameter& pk, std::size_t j,
                        double* omega) {
  if (!pk.moves_omega) return false;
  *omega = c.falling[j] ? pk.omega[j] * pk.deactivation_ratio[j] : pk.omega[j];
  return *omega != c.omega[j];
}

/// The direct part of ∂(a, ȧ)_j/∂θ_k after dt in an interval of input w_j from (a, ȧ)_j(t₀) (the
/// interval's, CvodesContext::w and a0): the difference quotient of eq. (6)'s free response in
/// Ω_j (zero unless θ_k moves Ω_j). The rest — through ∂w/∂θ and ∂(a, ȧ)(t₀)/∂θ — is linear.
muscles::ActivationState DirectOmegaSensitivity(const CvodesContext& c,
                                                const SensitivityData::Parameter& pk, std::size_t j,
                                                double dt) {
  double omega = 0.0;
  if (!MovesIntervalOmega(c, pk, j, &omega)) return {};
  const auto moved = muscles::ActivationFreeResponse(omega, c.w[j], c.a0[j], dt);
  const auto base = muscles::ActivationFreeResponse(c.omega[j], c.w[j], c.a0[j], dt);
  return {(moved.a - base.a) / pk.step, (moved.a_dot - base.a_dot) / pk.step};
}

/// Sets d->reached and d->reached_any for the interval that begins (d->da0 and d->dw of it): a
/// muscle j enters θ_k's list unless ∂w_j/∂θ_k, ∂a_j/∂θ_k and ∂ȧ_j/∂θ_k at the interval start
/// are all ±0 and θ_k leaves its Ω_j as it is (DirectOmegaSensitivity 0) — then ∂a_j/∂θ_k is a
/// sum of ±0 in the whole interval — or when it has a fitness or potentiation state.
void ReachedMuscles(SensitivityData* d) {
  const CvodesContext& c = *d->ctx;
  const std::size_t nm = c.omega.size();
  d->reached.resize(d->p.size());
  d->reached_any.assign(nm, 0);
  for (std::size_t k = 0; k < d->p.size(); ++k) {
    const auto& pk = d->p[k];
    d->reached[k].clear();
    for (std::size_t j = 0; j < nm; ++j) {
      double omega_k = 0.0;
      const bool reached = d->dw[k][j] != 0.0 || d->da0[k][j].a != 0.0 ||
                           d->da0[k][j].a_dot != 0.0 || MovesIntervalOmega(c, pk, j, &omega_k) ||
                           d->fitness_component[j] >= 0 || d->potentiation_component[j] >= 0;
      if (!reached) continue;
      d->reached[k].push_back(j);
      d->reached_any[j] = 1;
    }
  }
}

/// At a stimulation breakpoint (or the start): ∂a/∂θ carried over in closed form (eq. 6 is linear
/// in w and the initial state, so the sensitivities obey it with input ∂w/∂θ; plus the direct
/// part of a θ that moves Ω, DirectOmegaSensitivity, over the interval that ends), then ∂w/∂θ of
/// the new interval by difference quotients of RecruitedFractions.
void BeginSensitivityInterval(SensitivityData* d, const SimTK::State& state, double t) {
  const CvodesContext& c = *d->ctx;  // c.w, c.a0: still the interval that ends at t
  const std::size_t nm = c.omega.size();
  for (std::size_t k = 0; k < d->p.size(); ++k) {
    for (std::size_t j = 0; j < nm; ++j) {
      if (!d->started) {
        d->da0[k][j] = muscles::ActivationState{};
        continue;
      }
      const double dt = t - d->t0;
      auto next = muscles::ActivationFreeResponse(c.omega[j], d->dw[k][j], d->da0[k][j], dt);
      const auto direct = DirectOmegaSensitivity(c, d->p[k], j, dt);
      next.a += direct.a;
      next.a_dot += direct.a_dot;
      d->da0[k][j] = next;
    }
  }
  const std::vector<double> u = c.model->GetStimulation(state);
  const std::vector<double> w =
      RecruitedFractions(c.model->params(), c.model->electrode_matrix(), u);
  for (std::size_t k = 0; k < d->p.size(); ++k) {
    const auto& pk = d->p[k];
    if (pk.body) pk.body->SetStimulation(*pk.body_state, u);
    const std::vector<double> wk = RecruitedFractions(*pk.params, pk.array, u);
    for (std::size_t j = 0; j < nm; ++j) d->dw[k][j] = (wk[j] - w[j]) / pk.step;
  }
  d->t0 = t;
  d->started = true;
  d->cached = false;
  d->jac_age = -1;
}

/// M_ff⁻¹ of the free coordinates at the state `s` (realised to Stage::Position) into
/// d->mass_inv (nf × nf, column-major).
void FormMassInverse(SensitivityData* d, const SimTK::State& s) {
  const int nf = static_cast<int>(d->free_coordinates.size());
  SimTK::Matrix M;
  d->ctx->model->matter().calcM(s, M);
  SimTK::Matrix Mff(nf, nf);
  for (int r = 0; r < nf; ++r) {
    for (int col = 0; col < nf; ++col) Mff(r, col) = M(d->free_u_slot[r], d->free_u_slot[col]);
  }
  const SimTK::FactorLU lu(Mff);
  SimTK::Vector e(nf, 0.0), col(nf);
  for (int k = 0; k < nf; ++k) {
    e[k] = 1.0;
    lu.solve(e, col);
    e[k] = 0.0;
    for (int r = 0; r < nf; ++r) d->mass_inv[static_cast<std::size_t>(k) * nf + r] = col[r];
  }
}

/// The torques of the model with θ_k moved (pk) at (t, q, q̇, a) = `point`, where they may differ
/// from the model's: MuscleAndPassiveTorques of pk's model when pk moves them, the muscles pk
/// leaves as they are kept (TorquePoint::WithMusclesOf; only the passive part when pk leaves
/// every muscle and active-force gain as it is; `gains` are pk's at the point's fatigue and
/// potentiation states), plus the change of the tremor torque (a known
/// function of t, TremorTorque) when pk moves the tremor.
std::vector<double> PerturbedTorques(const SensitivityData::Parameter& pk, const ModelParams& base,
                                     double t, const std::vector<double>& gains,
                                     const TorquePoint& point) {
  std::vector<double> tau = !pk.moves_torques && !pk.moves_gain ? point.torques()
                            : !pk.moves_muscles && !pk.moves_gain
                                ? point.WithPassiveOf(*pk.params)
                                : point.WithMusclesOf(*pk.params, pk.paths, gains);
  if (pk.moves_tremor) {
    const TremorParams& tk = pk.params->mechanisms.tremor;
    const TremorParams& tb = base.mechanisms.tremor;
    if (tk.enabled) tau[tk.coordinate] += TremorTorque(tk, t);
    if (tb.enabled) tau[tb.coordinate] -= TremorTorque(tb, t);
  }
  return tau;
}

/// M_ff⁻¹-free direct term of a parameter that moves a segment's inertia: the free u rows of
/// (f_k(t, y) − f(t, y)) / step into `udot`, with f_k the right-hand side of the model of
/// pk.params (the same kind as EvaluateRhs's) at the state the context loaded (same q, u,
/// activations), `ydot` = f(t, y). Returns 0, or 1 (recoverable) when that evaluation fails.
int BodyRhsDifference(const SensitivityData& d, const SensitivityData::Parameter& pk, double t,
                      const double* ydot, std::vector<double>* udot) {
  const CvodesContext& c = *d.ctx;
  SimTK::State& s = *pk.body_state;
  s.updY() = c.state->getY();
  s.setTime(t);
  std::vector<double> fast_ydot;
  const double* yd = nullptr;
  try {
    if (c.fast) {  // the same right-hand side as f(t, y): CalcYDot
      RhsWorkspace ws;
      fast_ydot.resize(static_cast<std::size_t>(s.getNY()));
      pk.body->CalcYDot(s, &ws, fast_ydot.data());
      yd = fast_ydot.data();
    } else {
      if (c.prescribe) pk.body->system().prescribe(s);
      pk.body->system().realize(s, SimTK::Stage::Acceleration);
      yd = &s.getYDot()[0];
    }
  } catch (const std::exception&) {
    return 1;
  }
  for (std::size_t f = 0; f < d.u_component.size(); ++f) {
    const int i = d.u_component[f];
    (*udot)[f] = (yd[c.y_index[i]] - ydot[i]) / pk.step;
  }
  return 0;
}

/// udot = M_ff⁻¹ v over the free coordinates (d.mass_inv, formed with ∂f/∂y).
void MassSolve(const SensitivityData& d, const std::vector<double>& v, std::vector<double>* udot) {
  const int nf = static_cast<int>(d.free_coordinates.size());
  for (int r = 0; r < nf; ++r) {
    double sum = 0.0;
    for (int k = 0; k < nf; ++k) sum += d.mass_inv[static_cast<std::size_t>(k) * nf + r] * v[k];
    (*udot)[r] = sum;
  }
}

/// udot = M_ff⁻¹ (τ − τ0)_free / h: a difference quotient of the torques through the masses.
void MassSolveDifference(const SensitivityData& d, const std::vector<double>& tau,
                         const std::vector<double>& tau0, double h, std::vector<double>* udot) {
  std::vector<double> v(d.free_coordinates.size());
  for (std::size_t f = 0; f < v.size(); ++f) {
    const int cf = d.free_coordinates[f];
    v[f] = (tau[cf] - tau0[cf]) / h;
  }
  MassSolve(d, v, udot);
}

/// The full forward-difference ∂f/∂y of the right-hand side into d->jac (`ydot` = f(t, y)),
/// except the fitness and potentiation columns (FormMuscleStateColumns forms them exactly).
/// Returns 0, or 1 (recoverable) when a right-hand side fails.
int DifferenceStateJacobian(SensitivityData* d, double t, const double* y, const double* ydot) {
  const int n = d->n;
  std::copy(y, y + n, d->y1.begin());
  for (int i = 0; i < n; ++i) {
    if (d->state_muscle[i] >= 0) continue;
    const double h = 1e-7 * std::max(std::abs(y[i]), 1.0);
    d->y1[i] = y[i] + h;
    const int flag = EvaluateRhs(d->ctx, t, d->y1.data(), d->f1.data());
    d->y1[i] = y[i];
    if (flag != 0) return flag;
    for (int r = 0; r < n; ++r)
      d->jac[static_cast<std::size_t>(i) * n + r] = (d->f1[r] - ydot[r]) / h;
  }
  return 0;
}

/// What the muscle and passive torques see at one (t, y): q, q̇, the closed-form activations,
/// the fatigue and potentiation states (φ 1, p 0 when off), the active-force gains
/// (UpperLimbModel::ActiveForceGains; empty: 1) and the activation fatigue and potentiation see
/// (the model's ZDot clamps it to [0, 1]; `a_inside`: their rates move with a there).
struct TorqueInputs {
  std::vector<double> q, qd, a, fitness, potentiation, gains, a_seen;
  std::vector<char> a_inside;
};

TorqueInputs GatherTorqueInputs(const SensitivityData& d, const SimTK::State& s, const double* Y,
                                const double* y) {
  const CvodesContext& c = *d.ctx;
  const std::size_t nm = c.omega.size();
  TorqueInputs in;
  in.q = c.model->GetQs(s, Y);
  in.qd = c.model->GetUs(s, Y);
  in.a.resize(nm);
  in.fitness.assign(nm, 1.0);
  in.potentiation.assign(nm, 0.0);
  in.a_seen.resize(nm);
  in.a_inside.resize(nm);
  for (std::size_t j = 0; j < nm; ++j) {
    in.a[j] = Y[c.activation_index + 2 * static_cast<int>(j)];
    if (d.fitness_component[j] >= 0) in.fitness[j] = y[d.fitness_component[j]];
    if (d.potentiation_component[j] >= 0) in.potentiation[j] = y[d.potentiation_component[j]];
    in.a_seen[j] = std::clamp(in.a[j], 0.0, 1.0);
    in.a_inside[j] = in.a[j] >= 0.0 && in.a[j] <= 1.0;
  }
  in.gains = c.model->ActiveForceGains(s, Y);
  return in;
}

/// The column of muscle j's fitness or potentiation state (component i), exact at every point:
/// its torques move the free u rows (M_ff⁻¹ ∂τ/∂g_j ∂g_j/∂y_i, the gain affine in either state),
/// its own rate its row (∂ż/∂z at the activation of t); nothing else depends on it. `dtau_dg` =
/// TorquePerActiveGain at the point (TorquePoint::PerMuscleInput).
void FormMuscleStateColumn(SensitivityData* d, int i, const TorqueInputs& in,
                           const std::vector<double>& dtau_dg) {
  const MechanismParams& mech = d->ctx->model->params().mechanisms;
  const std::size_t nm = in.a.size();
  const std::size_t nf = d->free_coordinates.size();
  const auto j = static_cast<std::size_t>(d->state_muscle[i]);
  const bool is_fitness = d->fitness_component[j] == i;
  const double dgain = is_fitness ? ActiveForceGain(mech, 1.0, in.potentiation[j])
                                  : ActiveForceGain(mech, in.fitness[j], 1.0) -
                                        ActiveForceGain(mech, in.fitness[j], 0.0);
  std::vector<double> v(nf), udot(nf);
  for (std::size_t f = 0; f < nf; ++f) v[f] = dtau_dg[d->free_coordinates[f] * nm + j] * dgain;
  MassSolve(*d, v, &udot);
  double* col = &d->jac[static_cast<std::size_t>(i) * d->n];
  std::fill(col, col + d->n, 0.0);
  for (std::size_t f = 0; f < nf; ++f) col[d->u_component[f]] = udot[f];
  col[i] = is_fitness
               ? FitnessDerivativePartials(mech.fatigue, in.a_seen[j], in.fitness[j]).state
               : PotentiationDerivativePartials(mech.potentiation, in.a_seen[j], in.potentiation[j])
                     .state;
}

/// M_ff⁻¹ ∂τ/∂y_i of the muscle and passive torques (zero for components that are neither a free
/// q nor a free u) into the free u rows of ∂f/∂y: added to the rest of the last full formation,
/// or, at a full formation (`refresh`), subtracted from it to give the new rest. The fitness and
/// potentiation columns are formed whole (FormMuscleStateColumn).
void FormMuscleColumns(SensitivityData* d, const double* y, const TorqueInputs& in,
                       const TorquePoint& point, bool refresh) {
  const int n = d->n;
  const int nf = static_cast<int>(d->free_coordinates.size());
  const std::vector<double> dtau_dg =
      in.gains.empty() ? std::vector<double>{} : point.PerMuscleInput(true);
  std::vector<double> udot(nf);
  for (int i = 0; i < n; ++i) {
    if (d->state_muscle[i] >= 0) {
      FormMuscleStateColumn(d, i, in, dtau_dg);
      continue;
    }
    int coord = -1;
    bool is_q = false;
    for (int f = 0; f < nf && coord < 0; ++f) {
      const int cf = d->free_coordinates[f];
      if (d->q_component[cf] == i) {
        coord = cf;
        is_q = true;
      } else if (d->u_component[f] == i) {
        coord = cf;
      }
    }
    std::fill(udot.begin(), udot.end(), 0.0);
    if (coord >= 0) {
      const double x0 = is_q ? in.q[coord] : in.qd[coord];
      const double h = 1e-7 * std::max(std::abs(y[i]), 1.0);
      MassSolveDifference(*d, point.WithCoordinate(coord, !is_q, x0 + h), point.torques(), h,
                          &udot);
    }
    for (int f = 0; f < nf; ++f) {
      const std::size_t at = static_cast<std::size_t>(i) * nf + f;
      double& entry = d->jac[static_cast<std::size_t>(i) * n + d->u_component[f]];
      if (refresh) {
        d->jac_rest[at] = entry - udot[f];
      } else {
        entry = d->jac_rest[at] + udot[f];
      }
    }
  }
}

/// ∂f/∂θ at (t, y) into d->dfdp (`ydot` = f(t, y)). The q rows are 0 (q̇ = u); the free u rows are
/// M_ff⁻¹ ∂τ_f/∂θ, where ∂τ/∂θ_k = ∂τ/∂a · ∂a/∂θ_k (+ the direct change of τ for parameters that
/// move it or the active-force gains); the fitness and potentiation rows are ∂ż/∂a · ∂a/∂θ_k (+
/// the direct change of the rate for parameters that move it). Returns 0, or 1 (recoverable)
/// when a right-hand side fails.
int FormParameterColumns(SensitivityData* d, double t, const double* ydot, const TorqueInputs& in,
                         const TorquePoint& point) {
  const CvodesContext& c = *d->ctx;
  const ModelParams& base = c.model->params();
  const MechanismParams& mech = base.mechanisms;
  const int n = d->n;
  const int nf = static_cast<int>(d->free_coordinates.size());
  const std::size_t nm = in.a.size();
  // M_ff⁻¹ ∂τ_f/∂a_j for every muscle (nf × nm, column-major); TorquePerActivation's bits.
  const std::vector<double> dtau_da = point.PerMuscleInput(false);
  std::vector<double> v(nf), udot(nf);
  std::vector<double> x_da(static_cast<std::size_t>(nf) * nm);
  for (std::size_t j = 0; j < nm; ++j) {
    for (int f = 0; f < nf; ++f) v[f] = dtau_da[d->free_coordinates[f] * nm + j];
    MassSolve(*d, v, &udot);
    std::copy(udot.begin(), udot.end(), x_da.begin() + static_cast<std::ptrdiff_t>(j * nf));
  }
  // a(t) of eq. (6) is linear in the interval's w and initial (a, ȧ): its coefficients per muscle.
  const double dt = t - d->t0;
  std::vector<double> c_w(nm), c_a(nm), c_ad(nm);
  for (std::size_t j = 0; j < nm; ++j) {
    if (!d->reached_any[j]) continue;
    c_w[j] = muscles::ActivationFreeResponse(c.omega[j], 1.0, {0.0, 0.0}, dt).a;
    c_a[j] = muscles::ActivationFreeResponse(c.omega[j], 0.0, {1.0, 0.0}, dt).a;
    c_ad[j] = muscles::ActivationFreeResponse(c.omega[j], 0.0, {0.0, 1.0}, dt).a;
  }
  std::fill(d->dfdp.begin(), d->dfdp.end(), 0.0);
  std::vector<double> gains_k;
  for (std::size_t k = 0; k < d->p.size(); ++k) {
    const auto& pk = d->p[k];
    const MechanismParams& mk = pk.params->mechanisms;
    double* dfdp_k = &d->dfdp[k * n];
    std::fill(udot.begin(), udot.end(), 0.0);
    if (pk.body) {  // the whole right-hand side differenced: torques and tremor included
      if (BodyRhsDifference(*d, pk, t, ydot, &udot) != 0) return 1;
    } else if (pk.moves_torques || pk.moves_tremor || pk.moves_gain) {
      gains_k = in.gains;
      for (std::size_t j = 0; j < gains_k.size() && pk.moves_gain; ++j) {
        gains_k[j] = ActiveForceGain(mk, in.fitness[j], in.potentiation[j]);
      }
      MassSolveDifference(*d, PerturbedTorques(pk, base, t, gains_k, point), point.torques(),
                          pk.step, &udot);
    }
    for (const std::size_t j : d->reached[k]) {
      // ∂a_j/∂θ_k at t (±0 for the muscles θ_k does not reach, which the list leaves out).
      const auto& a0 = d->da0[k][j];
      const double da = c_w[j] * d->dw[k][j] + c_a[j] * a0.a + c_ad[j] * a0.a_dot +
                        DirectOmegaSensitivity(c, pk, j, dt).a;
      for (int f = 0; f < nf && da != 0.0; ++f) udot[f] += x_da[j * nf + f] * da;
      const double da_seen = in.a_inside[j] ? da : 0.0;
      const double aj = in.a_seen[j], phi = in.fitness[j], pj = in.potentiation[j];
      if (const int i = d->fitness_component[j]; i >= 0) {
        dfdp_k[i] = FitnessDerivativePartials(mech.fatigue, aj, phi).activation * da_seen;
        if (pk.moves_state_rates) {
          dfdp_k[i] +=
              (FitnessDerivative(mk.fatigue, aj, phi) - FitnessDerivative(mech.fatigue, aj, phi)) /
              pk.step;
        }
      }
      if (const int i = d->potentiation_component[j]; i >= 0) {
        dfdp_k[i] = PotentiationDerivativePartials(mech.potentiation, aj, pj).activation * da_seen;
        if (pk.moves_state_rates) {
          dfdp_k[i] += (PotentiationDerivative(mk.potentiation, aj, pj) -
                        PotentiationDerivative(mech.potentiation, aj, pj)) /
                       pk.step;
        }
      }
    }
    for (int f = 0; f < nf; ++f) dfdp_k[d->u_component[f]] = udot[f];
  }
  return 0;
}

/// ∂f/∂y and ∂f/∂θ at (t, y) into d's cache (see IntegrateTrialSensitivities). Returns 0, or 1
/// (recoverable) when a right-hand side fails.
///
/// The free u rows of ∂f/∂y are M_ff⁻¹ ∂τ/∂y plus the rigid-body and other-force terms (gravity,
/// velocity products, ∂M_ff/∂q, support). The first, with the stiff, fast-changing muscle forces,
/// is formed at every point by difference quotients of the pure MuscleAndPassiveTorques (cheap);
/// the rest only every `jac_reuse`-th point, as the full difference quotient of the Simbody
/// right-hand side less the first (one right-hand side per component).
int FormSensitivityMatrices(SensitivityData* d, double t, const double* y, const double* ydot) {
  CvodesContext* c = d->ctx;
  const bool refresh = d->jac_age >= d->jac_reuse || d->jac_age < 0;
  d->jac_age = refresh ? 1 : d->jac_age + 1;
  // `ydot` is f(t, y) (CVODES evaluates it before the sensitivity right-hand side).
  if (refresh && DifferenceStateJacobian(d, t, y, ydot) != 0) {
    d->jac_age = -1;  // ∂f/∂y partly overwritten: form it again at the next point
    return 1;
  }
  // q, q̇ and the activations at (t, y). With the articulated-body right-hand side they are read
  // from the variables LoadVariables gathers — the values LoadState would write, bit for bit — and
  // the state is loaded (positions realised) only where M_ff is formed; Simbody's right-hand side,
  // and a parameter that differences a second system at the state (BodyRhsDifference), need the
  // state loaded at every point.
  const bool load_state = !c->fast || refresh || d->any_body;
  try {
    if (load_state) {
      LoadState(c, t, y, refresh ? SimTK::Stage::Position : SimTK::Stage::Time);
    } else {
      LoadVariables(c, t, y);
    }
  } catch (const std::exception&) {
    d->jac_age = -1;  // M_ff not formed
    return 1;
  }
  const SimTK::State& s = *c->state;
  const double* Y = load_state ? s.getY().getContiguousScalarData() : c->y_all.data();
  const TorqueInputs in = GatherTorqueInputs(*d, s, Y, y);
  // Torques at the free coordinates only: the muscles that cross none are not evaluated.
  const TorquePoint point(c->model->params(), d->paths, in.q, in.qd, in.a, in.gains,
                          d->read_coordinates);
  if (refresh) FormMassInverse(d, s);
  FormMuscleColumns(d, y, in, point, refresh);
  if (FormParameterColumns(d, t, ydot, in, point) != 0) return 1;
  d->t_cache = t;
  d->y_cache.assign(y, y + d->n);
  d->cached = true;
  return 0;
}

/// ṡ_k = (∂f/∂y) s_k + ∂f/∂θ_k for k < ns, column by column of ∂f/∂y (`jac`, n × n) from ∂f/∂θ_k
/// (`dfdp`, n × ns), both column-major; compiled for each small n (RunForSize).
struct SensitivityProductKernel {
  template <std::size_t N>
  static void Run(std::size_t n_runtime, const double* jac, const double* dfdp, int ns,
                  N_Vector* yS, N_Vector* ySdot) {
    const std::size_t n = N > 0 ? N : n_runtime;
    for (int k = 0; k < ns; ++k) {
      const double* __restrict__ sk = NV_DATA_S(yS[k]);
      double* __restrict__ out = NV_DATA_S(ySdot[k]);
      const double* __restrict__ dfdp_k = dfdp + static_cast<std::size_t>(k) * n;
      for (std::size_t r = 0; r < n; ++r) out[r] = dfdp_k[r];
      for (std::size_t i = 0; i < n; ++i) {
        const double si = sk[i];
        if (si == 0.0) continue;
        const double* __restrict__ col = jac + i * n;
        for (std::size_t r = 0; r < n; ++r) out[r] += col[r] * si;
      }
    }
  }
};

/// CVODES' sensitivity right-hand side (CVSensRhsFn): ṡ_k = (∂f/∂y) s_k + ∂f/∂θ_k for all k.
int SensitivityRhs(int ns, sunrealtype t, N_Vector y, N_Vector ydot, N_Vector* yS, N_Vector* ySdot,
                   void* user, N_Vector /*tmp1*/, N_Vector /*tmp2*/) {
  auto* c = static_cast<CvodesContext*>(user);
  SensitivityData* d = c->sens;
  const double* yp = N_VGetArrayPointer(y);
  const bool hit =
      d->cached && d->t_cache == t && std::equal(d->y_cache.begin(), d->y_cache.end(), yp);
  if (!hit && FormSensitivityMatrices(d, t, yp, N_VGetArrayPointer(ydot)) != 0) return 1;
  RunForSize<SensitivityProductKernel>(static_cast<std::size_t>(d->n), d->jac.data(),
                                       d->dfdp.data(), ns, yS, ySdot);
  return 0;
}

/// `params` with its tolerance set: trial generation's for `model` when unset
/// (TrialGenerationTolerance).
IntegratorParams WithTolerance(IntegratorParams params, const ModelParams& model) {
  if (!params.tolerance) params.tolerance = TrialGenerationTolerance(model);
  return params;
}

/// CVODES' absolute tolerance per component: params.tolerance (scaled like the relative one,
/// see CvodesContext::tolerance_scale), divided by params.speed_time_scale_s for the
/// generalized speeds u when that is > 0 (IntegratorParams).
std::vector<double> AbsoluteTolerances(const CvodesContext& ctx, const IntegratorParams& params) {
  if (!(params.speed_time_scale_s >= 0.0) || !std::isfinite(params.speed_time_scale_s)) {
    throw std::invalid_argument("integrator: speed_time_scale_s must be finite and >= 0");
  }
  const double tol = *params.tolerance * ctx.tolerance_scale;
  const int nq = ctx.state->getNQ(), nu = ctx.state->getNU();
  std::vector<double> abs_tol(ctx.y_index.size(), tol);
  if (params.speed_time_scale_s > 0.0) {
    for (std::size_t i = 0; i < ctx.y_index.size(); ++i) {
      if (ctx.y_index[i] >= nq && ctx.y_index[i] < nq + nu) {
        abs_tol[i] = tol / params.speed_time_scale_s;
      }
    }
  }
  return abs_tol;
}

/// Owns the SUNDIALS objects (RAII).
class Cvodes {
 public:
  /// `abs_tol`: the absolute tolerance of each component; `tol` the relative one.
  Cvodes(int n, double tol, std::vector<double> abs_tol, bool adams, CvodesContext* ctx) {
    if (SUNContext_Create(nullptr, &sunctx_) != 0) throw std::runtime_error("SUNContext_Create");
    y_ = N_VNew_Serial(n, sunctx_);
    UseCompiledSerialOps(y_);  // and so every vector CVODES clones from it
    mem_ = CVodeCreate(adams ? CV_ADAMS : CV_BDF, sunctx_);
    // CVODES prints its failures to stderr by default; keep the last message instead, for the
    // exception that reports the failure (a fit's rejected trial point is not the user's error).
    CVodeSetErrHandlerFn(mem_, KeepMessage, &last_error_);
    a_ = SUNDenseMatrix(n, n, sunctx_);
    UseCompiledDenseMatrixOps(a_);
    ls_ = NewDenseLinearSolver(y_, a_, sunctx_);
    tol_ = tol;
    abs_tol_ = std::move(abs_tol);
    if (static_cast<int>(abs_tol_.size()) != n) {
      throw std::invalid_argument("Cvodes: one absolute tolerance per component");
    }
    ctx_ = ctx;
  }
  ~Cvodes() {
    if (mem_ != nullptr) CVodeFree(&mem_);
    if (yS_ != nullptr) N_VDestroyVectorArray(yS_, ns_);
    if (ls_ != nullptr) SUNLinSolFree(ls_);
    if (a_ != nullptr) SUNMatDestroy(a_);
    if (y_ != nullptr) N_VDestroy(y_);
    if (sunctx_ != nullptr) SUNContext_Free(&sunctx_);
  }
  Cvodes(const Cvodes&) = delete;
  Cvodes& operator=(const Cvodes&) = delete;

  /// Starts, or continues after a stimulation breakpoint. Only the closed-form activation
  /// changes its input there; a and ȧ, hence the right-hand side of q, u (and of any other z), are
  /// continuous, so CVODES continues with its history (step stopped exactly at the breakpoint by
  /// CVodeSetStopTime) instead of restarting at first order.
  void Start(double t0) {
    ctx_->BeginInterval(t0);
    if (initialised_) return;
    const SimTK::Vector& y0 = ctx_->state->getY();
    double* y = N_VGetArrayPointer(y_);
    for (std::size_t i = 0; i < ctx_->y_index.size(); ++i) y[i] = y0[ctx_->y_index[i]];
    if (!initialised_) {
      Check(CVodeInit(mem_, Rhs, t0, y_), "CVodeInit", t0);
      N_Vector abs_tol = N_VNew_Serial(static_cast<sunindextype>(abs_tol_.size()), sunctx_);
      std::copy(abs_tol_.begin(), abs_tol_.end(), N_VGetArrayPointer(abs_tol));
      const int flag = CVodeSVtolerances(mem_, tol_, abs_tol);  // copies abs_tol
      N_VDestroy(abs_tol);
      Check(flag, "CVodeSVtolerances", t0);
      Check(CVodeSetUserData(mem_, ctx_), "CVodeSetUserData", t0);
      Check(CVodeSetLinearSolver(mem_, ls_, a_), "CVodeSetLinearSolver", t0);
      Check(CVodeSetMaxNumSteps(mem_, kMaxSteps), "CVodeSetMaxNumSteps", t0);
      if (ns_ > 0) {
        yS_ = N_VCloneVectorArray(ns_, y_);
        for (int k = 0; k < ns_; ++k) N_VConst(0.0, yS_[k]);
        Check(CVodeSensInit(mem_, ns_, CV_STAGGERED, SensitivityRhs, yS_), "CVodeSensInit", t0);
        Check(CVodeSetSensParams(mem_, nullptr, pbar_.data(), nullptr), "CVodeSetSensParams", t0);
        Check(CVodeSensEEtolerances(mem_), "CVodeSensEEtolerances", t0);
        Check(CVodeSetSensErrCon(mem_, SUNFALSE), "CVodeSetSensErrCon", t0);
      }
      initialised_ = true;
    }
  }
  /// At most `max_steps` internal steps in all (0: no limit; IntegratorParams::max_steps).
  void SetStepBudget(long max_steps) { step_budget_ = max_steps; }
  /// Advances to exactly t_out (≤ stop) and leaves the solution in the context's state,
  /// realised to Stage::Instance only (its variables set; Drive realises the observer's stage) —
  /// or, with `load_state` false, only in CVODES' y (Solution; SyncState puts it into the state).
  void AdvanceTo(double t_out, double stop, bool load_state = true) {
    Check(CVodeSetStopTime(mem_, stop), "CVodeSetStopTime", t_out);
    long left = kMaxSteps;
    if (step_budget_ > 0) {
      long taken = 0;
      CVodeGetNumSteps(mem_, &taken);
      left = std::min(kMaxSteps, step_budget_ - taken);
      if (left <= 0) left = 1;  // CVODES takes ≤ 0 as its default; one step, then the check
      Check(CVodeSetMaxNumSteps(mem_, left), "CVodeSetMaxNumSteps", t_out);
    }
    double t_reached = 0.0;
    last_error_.clear();
    const int flag = CVode(mem_, t_out, y_, &t_reached, CV_NORMAL);
    if (flag < 0) {
      LoadState(ctx_, t_reached, N_VGetArrayPointer(y_));
      const std::string why =
          flag == CV_TOO_MUCH_WORK && step_budget_ > 0 && left < kMaxSteps
              ? "the step budget (IntegratorParams::max_steps = " + std::to_string(step_budget_) +
                    ") is used up"
              : std::string("CVODES ") + CVodeGetReturnFlagName(flag) +
                    (last_error_.empty() ? std::string() : ": " + last_error_);
      throw std::runtime_error("integration failed at t = " + std::to_string(t_reached) + " s (" +
                               why + "); " + DescribeState(*ctx_->model, *ctx_->state) +
                               kFailureHint);
    }
    if (ns_ > 0 && taylor_) {
      Check(taylor_->Evaluate(mem_, y_, t_out, &sens_), "CVodeGetSensDky1", t_out);
    } else if (ns_ > 0) {
      Check(CVodeGetSens(mem_, &t_reached, yS_), "CVodeGetSens", t_out);
      for (int k = 0; k < ns_; ++k) {
        const double* sk = N_VGetArrayPointer(yS_[k]);
        for (std::size_t m = 0; m < reported_; ++m) sens_[k * reported_ + m] = sk[components_[m]];
      }
    }
    // No stage realised here: Drive realises the stage its observer asked for right after, so an
    // observer that reads state variables alone (the trial records, the full-model fit) pays
    // neither for kinematics (≈ 1/3 of a 140 s, 40 Hz hand-rig simulation) nor for Stage::Time
    // (≈ 5 % of the 60 s default trial at tolerance 3e-3) at every report time.
    solution_t_ = t_out;
    state_current_ = load_state;
    if (load_state) LoadState(ctx_, t_out, N_VGetArrayPointer(y_), SimTK::Stage::Instance);
  }
  /// Whether the context's state holds the last solution (AdvanceTo with load_state).
  bool state_current() const { return state_current_; }
  /// The time and CVODES components of the last AdvanceTo's solution.
  double solution_time() const { return solution_t_; }
  const double* Solution() const { return N_VGetArrayPointer(y_); }
  /// Loads the last solution into the context's state (realised to Stage::Instance) unless it
  /// is there: before the stimulation changes at a breakpoint and at the end.
  void SyncState() {
    if (state_current_) return;
    LoadState(ctx_, solution_t_, N_VGetArrayPointer(y_), SimTK::Stage::Instance);
    state_current_ = true;
  }
  /// Integrate forward sensitivities of `scales.size()` parameters (typical magnitudes |θ_k|)
  /// from the start, reporting those of the CVODES components `components`; call before the
  /// first Start.
  /// With `per_step`, from one Taylor polynomial per step (IntegratorParams::
  /// sensitivities_per_step), else by CVodeGetSens at each report time.
  void EnableSensitivities(std::vector<double> scales, std::vector<int> components, bool per_step) {
    pbar_ = std::move(scales);
    ns_ = static_cast<int>(pbar_.size());
    reported_ = components.size();
    sens_.assign(static_cast<std::size_t>(ns_) * reported_, 0.0);
    if (per_step) {
      taylor_.emplace(std::move(components), ns_);
    } else {
      components_ = std::move(components);
    }
  }
  /// ∂y_c/∂θ_k of component c = components[m] at the last AdvanceTo's time (zero before the
  /// first).
  double Sensitivity(int k, std::size_t m) const { return sens_[k * reported_ + m]; }
  void AddStats(IntegrationStats* s) const {
    if (!initialised_) return;
    long v = 0;
    CVodeGetNumSteps(mem_, &v);
    s->steps += v;
    CVodeGetNumJacEvals(mem_, &v);
    s->jacobian_evaluations += v;
  }

 private:
  void Check(int flag, const char* what, double t) {
    if (flag < 0) {
      throw std::runtime_error(std::string(what) + " failed at t = " + std::to_string(t) + " s" +
                               (last_error_.empty() ? std::string() : " (" + last_error_ + ")"));
    }
  }
  /// CVErrHandlerFn: stores CVODES' message (warnings included) in *(std::string*)data.
  static void KeepMessage(int /*error_code*/, const char* /*module*/, const char* /*function*/,
                          char* msg, void* data) {
    *static_cast<std::string*>(data) = msg != nullptr ? msg : "";
  }
  std::string last_error_;  // CVODES' last error or warning message
  SUNContext sunctx_ = nullptr;
  N_Vector y_ = nullptr;
  void* mem_ = nullptr;
  SUNMatrix a_ = nullptr;
  SUNLinearSolver ls_ = nullptr;
  double tol_ = 1e-6;
  std::vector<double> abs_tol_;
  long step_budget_ = 0;      // internal steps in all, 0 = no limit
  int ns_ = 0;                // sensitivities integrated
  std::vector<double> pbar_;  // their parameters' scales
  N_Vector* yS_ = nullptr;
  std::size_t reported_ = 0;                 // components whose sensitivities are reported
  std::vector<double> sens_;                 // theirs at the last report, [k · reported + m]
  std::vector<int> components_;              // their CVODES components (CVodeGetSens path)
  std::optional<SensitivityTaylor> taylor_;  // CVodeGetSens' polynomial for them (per step)
  bool initialised_ = false;
  bool state_current_ = true;  // the context's state holds the last solution
  double solution_t_ = 0.0;    // time of the last AdvanceTo
  CvodesContext* ctx_ = nullptr;
};

bool HasPrescribed(const ModelParams& p) {
  return std::any_of(p.coordinates.begin(), p.coordinates.end(), [](const CoordinateParams& c) {
    return c.mode == CoordinateMode::kPrescribed;
  });
}

/// Walks the report times: advance(t, stop) integrates to t without passing the next
/// breakpoint `stop`; at each breakpoint the stimulation changes and restart(t) reinitialises
/// the integrator; observe() sees each report time's solution; now() is the time of the latest
/// solution (the state's, unless the integrator keeps it elsewhere). Shared by both integrators.
template <typename Advance, typename Restart, typename Observe, typename Now>
void Drive(const UpperLimbModel& model, const StimulationSchedule& schedule,
           const std::vector<double>& report_times, SimTK::State* state, Advance advance,
           Restart restart, Observe observe, Now now, IntegrationStats* stats) {
  const int nc = model.num_channels();
  const double t0 = state->getTime();
  model.SetStimulation(*state, schedule.At(t0, nc));
  const std::vector<double> breaks = Breakpoints(schedule, t0);
  std::size_t next_break = 0;
  restart(t0);
  const double kInf = std::numeric_limits<double>::infinity();
  for (double t_r : report_times) {
    if (t_r < now() - 1e-12) throw std::invalid_argument("report times not sorted");
    while (next_break < breaks.size() && breaks[next_break] <= t_r) {
      const double tb = breaks[next_break];
      if (tb > now() + kMinInterval) advance(tb, tb);
      model.SetStimulation(*state, schedule.At(tb, nc));
      restart(tb);
      ++stats->breakpoints;
      ++next_break;
    }
    const double stop = next_break < breaks.size() ? breaks[next_break] : kInf;
    if (t_r > now() + kMinInterval) advance(t_r, stop);
    observe();
  }
}

/// IntegrateTrial's and IntegrateTrialVariables' CVODES path: Drive over CVODES. With
/// `observe_variables` (and no prescribed coordinate, whose q and u only LoadState sets) a report
/// advance leaves the solution in CVODES' y and observe(t, y) gets the whole Y from
/// LoadVariables (its activations only with `observe_activations`) — or the state's, when the
/// state holds the latest solution (a report at a breakpoint); otherwise every solution goes into
/// the state and observe's y is the state's.
template <typename Observe>
IntegrationStats RunCvodes(const UpperLimbModel& model, const IntegratorParams& params,
                           const StimulationSchedule& schedule,
                           const std::vector<double>& report_times, SimTK::State* state,
                           bool observe_variables, bool observe_activations, Observe observe) {
  IntegrationStats stats;
  CvodesContext ctx(&model, state, HasPrescribed(model.params()), params.simbody_right_hand_side);
  Cvodes cv(static_cast<int>(ctx.y_index.size()), *params.tolerance * ctx.tolerance_scale,
            AbsoluteTolerances(ctx, params),
            params.method == IntegratorParams::Method::kCvodesAdams, &ctx);
  cv.SetStepBudget(params.max_steps);
  const bool in_y = observe_variables && !ctx.prescribe;
  Drive(
      model, schedule, report_times, state,
      [&](double t, double stop) { cv.AdvanceTo(t, stop, !in_y); },
      [&](double t) {
        cv.SyncState();  // the breakpoint's activations start the new interval (BeginInterval)
        state->setTime(t);
        cv.Start(t);
      },
      [&] {
        if (cv.state_current()) {
          observe(state->getTime(), state->getY().getContiguousScalarData());
        } else {
          LoadVariables(&ctx, cv.solution_time(), cv.Solution(), observe_activations);
          observe(cv.solution_time(), ctx.y_all.data());
        }
      },
      [&] { return cv.state_current() ? state->getTime() : cv.solution_time(); }, &stats);
  cv.SyncState();  // the state ends at the last solution
  cv.AddStats(&stats);
  stats.rhs_evaluations = ctx.rhs;
  return stats;
}

}  // namespace

IntegrationStats IntegrateTrial(const UpperLimbModel& model, const IntegratorParams& integrator,
                                const StimulationSchedule& schedule,
                                const std::vector<double>& report_times, SimTK::State* state,
                                const Observer& observer, SimTK::Stage observe_stage) {
  const IntegratorParams params = WithTolerance(integrator, model.params());
  if (params.method != IntegratorParams::Method::kSimbodyRkMerson) {
    return RunCvodes(model, params, schedule, report_times, state, false, true,
                     [&](double, const double*) {
                       model.system().realize(*state, observe_stage);
                       observer(*state);
                     });
  }
  // Simbody's Runge–Kutta–Merson, restarted at each breakpoint like CVODES; it integrates the
  // activations' ż.
  IntegrationStats stats;
  model.SetActivationsInClosedForm(*state, false);
  std::unique_ptr<SimTK::RungeKuttaMersonIntegrator> integ;
  // Simbody's exception text (multi-line, no coordinate) becomes one line with the time, the
  // coordinate furthest out of range at the last accepted step and the hint of the CVODES path.
  const auto failure = [&](const std::exception& e, const SimTK::State& at) {
    if (&at != state) *state = at;
    return std::runtime_error("integration failed at t = " + std::to_string(at.getTime()) +
                              " s (Simbody RKM: " + OneLine(e.what()) + "); " +
                              DescribeState(model, *state) + kFailureHint +
                              " (or integrator.method cvodes for a stiff rig)");
  };
  Drive(
      model, schedule, report_times, state,
      [&](double t, double stop) {
        try {
          while (integ->getTime() < t) integ->stepTo(t, stop);
        } catch (const std::exception& e) {
          throw failure(e, integ->getState());
        }
        *state = integ->getState();
        if (std::abs(state->getTime() - t) > 1e-9) {
          throw std::runtime_error(
              "Simbody integrator stopped at t = " + std::to_string(state->getTime()) +
              " s before " + std::to_string(t) + " s");
        }
      },
      [&](double t) {
        if (integ) stats.steps += integ->getNumStepsTaken();
        state->setTime(t);
        integ = std::make_unique<SimTK::RungeKuttaMersonIntegrator>(model.system());
        integ->setAccuracy(*params.tolerance);
        integ->setReturnEveryInternalStep(false);
        try {
          integ->initialize(*state);
        } catch (const std::exception& e) {
          throw failure(e, *state);
        }
      },
      [&] {
        model.system().realize(*state, observe_stage);
        observer(*state);
      },
      [&] { return state->getTime(); }, &stats);
  if (integ) stats.steps += integ->getNumStepsTaken();
  return stats;
}

IntegrationStats IntegrateTrialVariables(const UpperLimbModel& model,
                                         const IntegratorParams& integrator,
                                         const StimulationSchedule& schedule,
                                         const std::vector<double>& report_times,
                                         SimTK::State* state, const VariablesObserver& observer,
                                         VariablesObserved observe) {
  const IntegratorParams params = WithTolerance(integrator, model.params());
  if (params.method == IntegratorParams::Method::kSimbodyRkMerson) {
    return IntegrateTrial(
        model, params, schedule, report_times, state,
        [&](const SimTK::State& s) { observer(s.getTime(), s.getY().getContiguousScalarData()); },
        SimTK::Stage::Instance);
  }
  return RunCvodes(model, params, schedule, report_times, state, true,
                   observe == VariablesObserved::kAll, observer);
}

/// The CVODES components of `d` (d->ctx set): each coordinate's q and u, each muscle's fitness
/// and potentiation state (CVODES components too: not locked, not activations) and the free
/// coordinates' u. Throws std::invalid_argument when a free coordinate is not integrated.
void MapComponents(const UpperLimbModel& model, const SimTK::State& state, SensitivityData* d) {
  const ModelParams& base = model.params();
  d->n = static_cast<int>(d->ctx->y_index.size());
  const int nq = state.getNQ();
  d->q_component.assign(kNumCoordinates, -1);
  std::vector<int> u_component_of(kNumCoordinates, -1);
  for (int i = 0; i < d->n; ++i) {
    const int yi = d->ctx->y_index[i];
    for (int c = 0; c < kNumCoordinates; ++c) {
      if (model.Welded(c)) continue;
      if (yi == model.QIndex(c)) d->q_component[c] = i;
      if (yi == nq + model.UIndex(c)) u_component_of[c] = i;
    }
  }
  // The fatigue and potentiation states are CVODES components (not locked, not activations).
  const std::size_t n_muscles = base.muscles.size();
  d->fitness_component.assign(n_muscles, -1);
  d->potentiation_component.assign(n_muscles, -1);
  d->state_muscle.assign(d->n, -1);
  const int fitness_y = model.FitnessYIndex(state),
            potentiation_y = model.PotentiationYIndex(state);
  for (int i = 0; i < d->n; ++i) {
    const int yi = d->ctx->y_index[i];
    for (std::size_t j = 0; j < n_muscles; ++j) {
      const int m = static_cast<int>(j);
      const bool is_fitness = fitness_y >= 0 && yi == fitness_y + m;
      const bool is_potentiation = potentiation_y >= 0 && yi == potentiation_y + m;
      if (is_fitness) d->fitness_component[j] = i;
      if (is_potentiation) d->potentiation_component[j] = i;
      if (is_fitness || is_potentiation) d->state_muscle[i] = m;
    }
  }
  d->read_coordinates.assign(kNumCoordinates, 0);
  for (int c = 0; c < kNumCoordinates; ++c) {
    if (base.coordinates[c].mode != CoordinateMode::kFree) continue;
    if (d->q_component[c] < 0 || u_component_of[c] < 0) {
      throw std::invalid_argument("sensitivities: free coordinate " + CoordinateNames()[c] +
                                  " is not integrated");
    }
    d->free_coordinates.push_back(c);
    d->read_coordinates[c] = 1;
    d->free_u_slot.push_back(model.UIndex(c));
    d->u_component.push_back(u_component_of[c]);
  }
}

/// The sensitivity parameter of `pp` against `model`: what it moves, and for a parameter that
/// moves a segment's inertia its own Simbody system (*any_body set). Throws std::invalid_argument
/// when the perturbed model has other muscles or channels, switches a mechanism with states or
/// has another state layout.
SensitivityData::Parameter MakeSensitivityParameter(const UpperLimbModel& model,
                                                    const ParameterPerturbation& pp,
                                                    const SimTK::State& state, bool* any_body) {
  const ModelParams& base = model.params();
  if (pp.params.muscles.size() != base.muscles.size() ||
      pp.params.channels.size() != base.channels.size()) {
    throw std::invalid_argument("sensitivities: perturbed model has other muscles or channels");
  }
  if (pp.params.mechanisms.stretch_reflex.enabled() ||
      pp.params.mechanisms.fatigue.enabled != base.mechanisms.fatigue.enabled ||
      pp.params.mechanisms.potentiation.enabled != base.mechanisms.potentiation.enabled) {
    throw std::invalid_argument(
        "sensitivities: perturbed model switches fatigue, potentiation or the stretch reflex");
  }
  SensitivityData::Parameter q{
      &pp.params,
      BuildElectrodeMatrix(pp.params),
      {},
      pp.step,
      TorqueParametersMayDiffer(pp.params, base),
      MuscleParametersMayDiffer(pp.params, base),
      TremorParametersDiffer(pp.params.mechanisms.tremor, base.mechanisms.tremor),
      {},
      {},
      false,
      StateRatesDiffer(pp.params.mechanisms, base.mechanisms),
      base.mechanisms.potentiation.enabled &&
          pp.params.mechanisms.potentiation.gain != base.mechanisms.potentiation.gain,
      nullptr,
      nullptr};
  for (std::size_t j = 0; j < pp.params.muscles.size(); ++j) {
    const auto& m = pp.params.muscles[j];
    q.paths.push_back(m.path);
    q.omega.push_back(m.activation_omega_rad_s);
    q.deactivation_ratio.push_back(m.deactivation_ratio);
    q.moves_omega = q.moves_omega ||
                    m.activation_omega_rad_s != base.muscles[j].activation_omega_rad_s ||
                    m.deactivation_ratio != base.muscles[j].deactivation_ratio;
  }
  if (BodyInertiaDiffers(pp.params, base)) {
    q.body = std::make_shared<const UpperLimbModel>(pp.params, model.build_options());
    q.body_state = std::make_shared<SimTK::State>(q.body->MakeInitialState());
    *any_body = true;
    if (q.body_state->getNY() != state.getNY()) {
      throw std::invalid_argument("sensitivities: perturbed model has another state layout");
    }
  }
  return q;
}

IntegrationStats IntegrateTrialSensitivities(
    const UpperLimbModel& model, const IntegratorParams& integrator,
    const StimulationSchedule& schedule, const std::vector<double>& report_times,
    const std::vector<ParameterPerturbation>& parameters, SimTK::State* state,
    const SensitivityObserver& observer, int state_jacobian_every) {
  const IntegratorParams params = WithTolerance(integrator, model.params());
  if (params.method == IntegratorParams::Method::kSimbodyRkMerson) {
    throw std::invalid_argument("sensitivities need a CVODES integrator method");
  }
  const ModelParams& base = model.params();
  if (base.mechanisms.stretch_reflex.enabled()) {
    throw std::invalid_argument("sensitivities: stretch-reflex states are not supported");
  }
  CvodesContext ctx(&model, state, HasPrescribed(base), params.simbody_right_hand_side);
  SensitivityData d;
  d.ctx = &ctx;
  MapComponents(model, *state, &d);
  for (const auto& m : base.muscles) d.paths.push_back(m.path);
  std::vector<double> scales;
  for (const auto& pp : parameters) {
    if (!(pp.step != 0.0) || !std::isfinite(pp.step) || !(pp.scale > 0.0)) {
      throw std::invalid_argument(
          "sensitivities: parameter step must be finite and nonzero, "
          "scale > 0");
    }
    d.p.push_back(MakeSensitivityParameter(model, pp, *state, &d.any_body));
    scales.push_back(pp.scale);
  }
  const std::size_t nm = base.muscles.size();
  d.da0.assign(parameters.size(), std::vector<muscles::ActivationState>(nm));
  d.dw.assign(parameters.size(), std::vector<double>(nm, 0.0));
  d.jac.assign(static_cast<std::size_t>(d.n) * d.n, 0.0);
  d.dfdp.assign(static_cast<std::size_t>(d.n) * parameters.size(), 0.0);
  d.mass_inv.assign(d.free_coordinates.size() * d.free_coordinates.size(), 0.0);
  d.jac_rest.assign(d.free_coordinates.size() * static_cast<std::size_t>(d.n), 0.0);
  d.f1.assign(d.n, 0.0);
  d.y1.assign(d.n, 0.0);
  ctx.sens = &d;
  if (state_jacobian_every < 1) {
    throw std::invalid_argument("sensitivities: state_jacobian_every must be >= 1");
  }
  d.jac_reuse = state_jacobian_every;

  IntegrationStats stats;
  Cvodes cv(d.n, *params.tolerance * ctx.tolerance_scale, AbsoluteTolerances(ctx, params),
            params.method == IntegratorParams::Method::kCvodesAdams, &ctx);
  cv.SetStepBudget(params.max_steps);
  const int np = static_cast<int>(parameters.size());
  // The reported sensitivities: q of each free coordinate (the others' dq stay 0).
  std::vector<int> reported, reported_coordinate;
  for (int c = 0; c < kNumCoordinates; ++c) {
    if (d.q_component[c] >= 0 && base.coordinates[c].mode == CoordinateMode::kFree) {
      reported.push_back(d.q_component[c]);
      reported_coordinate.push_back(c);
    }
  }
  if (np > 0) cv.EnableSensitivities(scales, reported, params.sensitivities_per_step);
  std::vector<double> dq(static_cast<std::size_t>(kNumCoordinates) * np, 0.0);
  // As RunCvodes with observe_variables: a report leaves the solution in CVODES' y (the state is
  // loaded only at breakpoints, where the new interval starts from it, and at the end).
  const bool in_y = !ctx.prescribe;
  Drive(
      model, schedule, report_times, state,
      [&](double t, double stop) {
        cv.AdvanceTo(t, stop, !in_y);
        for (int k = 0; k < np; ++k) {
          for (std::size_t m = 0; m < reported.size(); ++m) {
            dq[static_cast<std::size_t>(reported_coordinate[m]) * np + k] = cv.Sensitivity(k, m);
          }
        }
      },
      [&](double t) {
        cv.SyncState();  // the breakpoint's activations start the new interval (BeginInterval)
        state->setTime(t);
        cv.Start(t);
      },
      [&] {
        if (cv.state_current()) {
          observer(state->getTime(), state->getY().getContiguousScalarData(), dq);
        } else {
          LoadVariables(&ctx, cv.solution_time(), cv.Solution());
          observer(cv.solution_time(), ctx.y_all.data(), dq);
        }
      },
      [&] { return cv.state_current() ? state->getTime() : cv.solution_time(); }, &stats);
  cv.SyncState();  // the state ends at the last solution
  cv.AddStats(&stats);
  stats.rhs_evaluations = ctx.rhs;
  return stats;
}

}  // namespace fesim::sim
