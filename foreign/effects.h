// Plantable effects of the foreign simulator: mechanisms (and sensor artefacts) that a test hides
// in the data so that a diagnosis must find them. Each effect is its own implementation of
// EffectModel, registered once in EffectTable(); the plant (foreign/plant.h) calls every effect's
// hooks and never asks which effect it is.
//
// Scale: every effect takes a scale s > 0; s = 1 is "clearly visible" — on a 60 s pseudo-random
// step trial of the nominal person its RMS on the angles (truth with − truth without) is of the
// order of 0.01–0.03 rad. Larger s makes the effect proportionally stronger (the delay longer, the
// slip larger, …). Randomness (frequencies, phases, times, signs) comes from the seed given to
// MakeEffect, so an effect is deterministic per seed.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "foreign/person.h"

namespace fesim::foreign {

/// An effect to plant: id from EffectIds(), scale s > 0.
struct PlantedEffect {
  std::string id;
  double scale = 1.0;
};

/// The ids of EffectTable(), in its order: fatigue, potentiation, delay, tremor, crosstalk,
/// moment_arm_posture, force_length_velocity, unequal_muscle_dynamics,
/// passive_stiffness_nonlinear, stiction, spasticity, sensor_drift, wander, slip, voluntary.
std::vector<std::string> EffectIds();

/// What the plant's right-hand side shows an effect at one instant.
struct EffectContext {
  double t_s = 0.0;                        ///< s.
  Eigen::Vector3d q_rad;                   ///< physical joint angles, rad.
  Eigen::Vector3d qd_rad_s;                ///< rad/s.
  MuscleArray recruitment{};               ///< w from the stimulation, 0–1.
  MuscleArray coupling{};                  ///< first activation stage e, 0–1.
  MuscleArray activation{};                ///< force state a, 0–1.
  MuscleArray lengthening_velocity_m_s{};  ///< dl_MT/dt, m/s, > 0 lengthening.
  const Person* person = nullptr;          ///< the person the plant runs (effects applied).
};

/// Hooks of one effect; each defaults to "no change". x points at the effect's own NumStates()
/// states inside the plant state.
class EffectModel {
 public:
  virtual ~EffectModel() = default;
  /// Structural change of the person's parameters, applied once before the trial.
  virtual void ModifyPerson(Person* person) const {}
  /// The joint a joint-local effect acts at (index into kJointNames), or −1 for an effect on
  /// several joints or on the stimulation. A diagnosis that names the effect at another joint
  /// has not found it (bench/diagnosis_suite.cc).
  virtual int JointIndex() const { return -1; }
  /// Electromechanical transport delay of the stimulation, s, ≥ 0.
  virtual double StimulationDelay_s() const { return 0.0; }
  virtual int NumStates() const { return 0; }
  virtual void InitialState(double* x) const {}
  /// Adds to each muscle's drive (the input of the activation dynamics; clipped to [0, 1]).
  virtual void AddDrive(const EffectContext& ctx, const double* x, MuscleArray* drive) const {}
  /// Multiplies each muscle's active force capacity (1 = unchanged).
  virtual void ScaleCapacity(const EffectContext& ctx, const double* x,
                             MuscleArray* capacity) const {}
  /// Adds generalised forces, N·m.
  virtual void AddJointTorque(const EffectContext& ctx, const double* x,
                              Eigen::Vector3d* tau) const {}
  /// Adds friction-like generalised forces that depend on all the others: `net` is the
  /// generalised force M q̈ would have without them (τ − C q̇ − G), `m_inv` = M⁻¹.
  virtual void AddFrictionTorque(const EffectContext& ctx, const Eigen::Matrix3d& m_inv,
                                 const Eigen::Vector3d& net, Eigen::Vector3d* tau) const {}
  /// dx/dt of the effect's own states.
  virtual void StateDerivative(const EffectContext& ctx, const double* x, double* dx) const {}
  /// Added to the physical angles in the noiseless reading (sensor artefacts), rad.
  virtual Eigen::Vector3d ReadingOffset(double t_s) const { return Eigen::Vector3d::Zero(); }
  // Bounds the plant's step-size rule needs (foreign/plant.h StableStep).
  /// Largest drive the effect adds to any muscle, 0–1.
  virtual double DriveBound() const { return 0.0; }
  /// Largest capacity factor, ≥ 1.
  virtual double CapacityBound() const { return 1.0; }
  /// Largest damping (−∂τ/∂q̇) the effect adds per joint at posture q, N·m·s/rad.
  virtual Eigen::Vector3d DampingBound(const Person& person, const Eigen::Vector3d& q) const {
    return Eigen::Vector3d::Zero();
  }
  /// Largest stiffness (−∂τ/∂q) the effect adds per joint at posture q, N·m/rad.
  virtual Eigen::Vector3d StiffnessBound(const Person& person, const Eigen::Vector3d& q) const {
    return Eigen::Vector3d::Zero();
  }
};

/// What an effect may know about the trial it is planted in.
struct EffectSetup {
  double duration_s = 60.0;  ///< trial length, s, > 0.
  std::uint64_t seed = 1;    ///< the effect's own seed (SimulateTrial derives it per effect id).
  /// The seed of what the effect is in this person, the same in all their trials (e.g. a
  /// tremor's frequency); MakePlant derives it from the person's seed and the effect id.
  std::uint64_t person_seed = 1;
};

/// One row of the effect table.
struct EffectEntry {
  const char* id;
  std::unique_ptr<EffectModel> (*make)(double scale, const EffectSetup& setup);
};

/// All effects, in the order of EffectIds().
std::vector<EffectEntry> EffectTable();

/// The effect `effect.id` at `effect.scale`. Throws std::invalid_argument on an unknown id (the
/// message lists the known ones) or a scale outside (0, 1000].
std::unique_ptr<EffectModel> MakeEffect(const PlantedEffect& effect, const EffectSetup& setup);

}  // namespace fesim::foreign
