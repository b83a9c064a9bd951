// The foreign simulator's plant: a person with planted effects, its state layout, the
// right-hand side dx/dt = f(t, x, u), the passive equilibrium and the integration over a
// stimulation schedule. Parameters (Plant, immutable) apart from state (a plain vector).
//
// State x = (q[3] rad, q̇[3] rad/s, e[7], a[7], effect states…). Right-hand side at (t, x, u):
//   v_m = Σ_c W[m][c] u_c                       pulse width muscle m sees, µs
//   w_m = Recruitment(v_m);  drive_m = clip(w_m + effect drives, 0, 1)
//   ė, ȧ from foreign/muscle.h;  F_m = MuscleForce(capacity_m, a_m, l_M, v_M)
//   τ = Σ_m ρ_m F_m + τ_el(q) − b q̇ + effect torques (+ friction effects, which see the rest)
//   q̈ = M(q)⁻¹ (τ − C(q, q̇) q̇ − G(q))
// Integration: RK4 (foreign/integrator.h) between consecutive breakpoints (stimulation switching
// instants shifted by the effect delay, sample instants), in equal steps no longer than
// min(max_step_s, stability_factor/λ̂), where λ̂ = tr(M⁻¹B) + √tr(M⁻¹K) bounds the eigenvalues
// of the linearised mechanics at the interval's start with every muscle at the largest
// activation it can reach during the interval (B: muscle force–velocity, joint and effect damping;
// K: joint, passive fibre, force–length and effect stiffness). The stimulation is constant between
// breakpoints, so the right-hand side is smooth inside every step.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "foreign/body.h"
#include "foreign/effects.h"
#include "foreign/person.h"
#include "protocols/protocols.h"

namespace fesim::foreign {

/// Offsets into the plant state.
constexpr int kStateQ = 0;
constexpr int kStateQd = 3;
constexpr int kStateCoupling = 6;
constexpr int kStateActivation = kStateCoupling + kNumMuscles;
constexpr int kStateEffects = kStateActivation + kNumMuscles;

using ChannelValues = std::array<double, kNumChannels>;  ///< ext, flex pulse widths, µs.

/// A person with its effects, ready to simulate (immutable once made).
struct Plant {
  Person person;  ///< after every effect's ModifyPerson.
  ChainCoefficients chain;
  std::vector<std::shared_ptr<const EffectModel>> effects;
  std::vector<int> effect_offsets;  ///< start of each effect's states in x.
  int state_size = kStateEffects;
  double stimulation_delay_s = 0.0;  ///< Σ of the effects' delays, s.
};

/// Validates the person and builds the plant; effect i is seeded DeriveSeed(seed, id).
Plant MakePlant(const Person& person, const std::vector<PlantedEffect>& effects, double duration_s,
                std::uint64_t seed);

/// The plant at rest at posture q: q̇ = 0, e = a = 0, effect states at their initial values.
Eigen::VectorXd RestState(const Plant& plant, const Eigen::Vector3d& q);

/// Options of the right-hand side.
struct RhsOptions {
  bool friction = true;  ///< false: skip AddFrictionTorque (equilibrium search).
};

/// dx/dt at (t, x) with pulse widths u (µs, ext and flex) reaching the electrodes now.
void PlantDerivatives(const Plant& plant, double t_s, const ChannelValues& u_us, const double* x,
                      double* dx, const RhsOptions& options = {});

/// Passive equilibrium under gravity: the q with q̈ = 0 at rest and no stimulation (Newton with a
/// central-difference Jacobian, friction ignored since it vanishes there). Throws
/// std::runtime_error when it does not converge.
Eigen::Vector3d PassiveEquilibrium(const Plant& plant);

/// λ̂ of the file comment at state x with stimulation u held, 1/s. Each muscle's activation is
/// bounded over the interval by min(1, max(a, e, w(u)) + Σ effect drive bounds): with the drive
/// constant, e and a move monotonically toward it.
double StiffnessEstimate(const Plant& plant, const double* x, const ChannelValues& u_us);

/// Stimulation as the plant uses it: values[k] held from times[k] to times[k+1], in channel order
/// (ext, flex). Undelayed it equals protocols::ValueAt; delayed by d it is zero on [0, d) and the
/// program shifted by d after.
struct StimulationSchedule {
  std::vector<double> times_s;
  std::vector<ChannelValues> values_us;
  double duration_s = 0.0;
  /// The value held at t.
  ChannelValues At(double t_s) const;
};

/// Maps a program with channels named exactly "ext" and "flex" (either order) to a schedule
/// delayed by delay_s. Throws std::invalid_argument on other channels, sizes, non-increasing
/// times, values outside [0, 300] µs or a duration not after the last time.
StimulationSchedule MakeSchedule(const protocols::StimulationProgram& program, double delay_s);

struct IntegrationSpec {
  double max_step_s = 1e-3;       ///< h_max, s, in (0, 0.01].
  double stability_factor = 2.0;  ///< h ≤ factor/λ̂, in (0, 2.7].
};

/// States at each of sample_times_s (increasing, in [0, schedule.duration_s]) from x0 at t = 0.
/// Throws std::runtime_error naming the time when the state stops being finite.
std::vector<Eigen::VectorXd> IntegratePlant(const Plant& plant, const StimulationSchedule& schedule,
                                            const Eigen::VectorXd& x0,
                                            const std::vector<double>& sample_times_s,
                                            const IntegrationSpec& spec = {});

}  // namespace fesim::foreign
