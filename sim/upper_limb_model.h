// The ground-truth upper-limb model of [Hand Hammerstein] eq. (12) in Simbody:
//   skeleton (H_RB, eq. 11) + passive joints (eq. 14 and range limits) + arm support
//   + electrode array A (eq. 1) → recruitment (eq. 3) → activation (eq. 6, own Ω_i per muscle)
//   → Hill muscles (eq. 4, 7) → Landsmeer tendon network R(q) (eq. 8–10) → joint torques.
//
// Muscles act through the tendon network as generalised forces τ = R(q) f with R = −∂l_MT/∂q
// ([Hand Hammerstein] eq. 8), not as spatial line forces; this is the paper's formulation.
//
// Skeleton: thorax = ground. Shoulder as a Y–X–Y Euler sequence of three pins ([Schearer 2014])
// with two massless intermediate bodies; it is singular at zero elevation (plane and axial
// rotation share an axis), so elevation is kept ≥ 5° by its range limit. The forearm carries the
// pro/supination pin at the wrist (the hand pronates, the forearm's inertia does not — departure
// from an anatomical radius/ulna split). Wrist flexion then deviation, index MCP, PIP, DIP.
//
// The Simbody adapters (Force::Custom implementations in upper_limb_model.cc) only gather the
// state and call the pure functions of muscles/, tendons/, passive_joint.h and arm_support.h.
// The model is immutable after construction; every trial works on its own SimTK::State, so many
// trials may run on one model in parallel.
#pragma once

#include <Simbody.h>

#include <memory>
#include <vector>

#include "muscles/electrode_array.h"
#include "sim/chain_dynamics.h"
#include "sim/model_params.h"

namespace fesim::sim {

/// Per-muscle quantities at one instant.
struct MuscleSnapshot {
  std::vector<double> activation;       ///< a, 0–1.
  std::vector<double> force_n;          ///< tendon force f, N.
  std::vector<double> length_m;         ///< l_MT, m.
  std::vector<double> velocity_m_s;     ///< dl_MT/dt, m/s.
  std::vector<double> joint_torque_nm;  ///< τ = R f per coordinate, N·m.
  bool any_clamped = false;             ///< a fibre hit its minimum length.
};

/// Recruited fraction w_j = H_IRC(Σ_k A_jk u_k) of every muscle (eq. 1, 3) for stimulation
/// u (µs per channel, clipped to [0, 300] as UpperLimbModel::SetStimulation does); `array` =
/// BuildElectrodeMatrix(params). The muscle force element computes exactly this. Throws
/// std::invalid_argument when u has the wrong number of channels.
std::vector<double> RecruitedFractions(const ModelParams& params, const muscles::ArrayMatrix& array,
                                       const std::vector<double>& u_us);

/// The generalised forces (N·m per coordinate) that depend on muscle and joint parameters, at
/// angles q (rad), speeds q̇ (rad/s) and activations a: τ = R(q) f (eq. 8–10) with the Hill
/// tendon forces f (eq. 4, 7; each muscle's active force × gains[j], the fatigue and
/// potentiation gain ActiveForceGain; empty `gains`: 1) plus the passive joint moments (eq. 14 and
/// range limits). `paths[j]` = params.muscles[j].path (built once by the caller). The force
/// elements apply exactly these, plus gravity, support and tremor.
std::vector<double> MuscleAndPassiveTorques(const ModelParams& params,
                                            const std::vector<tendons::MusclePath>& paths,
                                            const std::vector<double>& q,
                                            const std::vector<double>& qd,
                                            const std::vector<double>& a,
                                            const std::vector<double>& gains = {});

/// ∂τ/∂a of MuscleAndPassiveTorques at (q, q̇, a, gains), N·m per unit activation, coordinates ×
/// muscles row-major: [c · n_muscles + j] = R_cj(q) ∂f_j/∂a_j (forward difference of the Hill
/// tendon force, exact where f is affine in a).
std::vector<double> TorquePerActivation(const ModelParams& params,
                                        const std::vector<tendons::MusclePath>& paths,
                                        const std::vector<double>& q, const std::vector<double>& qd,
                                        const std::vector<double>& a,
                                        const std::vector<double>& gains = {});
/// ∂τ/∂gain of MuscleAndPassiveTorques the same way: [c · n_muscles + j] = R_cj(q) ∂f_j/∂g_j,
/// N·m per unit gain (f is affine in the gain: exact).
std::vector<double> TorquePerActiveGain(const ModelParams& params,
                                        const std::vector<tendons::MusclePath>& paths,
                                        const std::vector<double>& q, const std::vector<double>& qd,
                                        const std::vector<double>& a,
                                        const std::vector<double>& gains = {});

/// MuscleAndPassiveTorques at one (q, q̇, a) with its parts kept, for difference quotients that
/// move one coordinate's q or q̇, or only passive joint parameters (the forward sensitivities'
/// ∂τ/∂y and ∂τ/∂θ, sim/integrator.cc): each such evaluation recomputes only what the change
/// reaches and gives MuscleAndPassiveTorques' values bit for bit
/// (UpperLimbModel.TorquePointGivesMuscleAndPassiveTorquesBits).
class TorquePoint {
 public:
  /// `params`, `paths`, `q`, `qd`, `a` and `gains` as for MuscleAndPassiveTorques; all but the
  /// gains and `read` are referenced, not copied, and must outlive the point. `read`
  /// ([coordinate], empty: all) are the coordinates whose torques the caller reads: a muscle that
  /// crosses none of them is not evaluated (force 0), nor an unread coordinate's passive torque,
  /// so that every result below is MuscleAndPassiveTorques' at the read coordinates only (the
  /// forward sensitivities read the free ones); WithCoordinate then moves read coordinates only.
  TorquePoint(const ModelParams& params, const std::vector<tendons::MusclePath>& paths,
              const std::vector<double>& q, const std::vector<double>& qd,
              const std::vector<double>& a, std::vector<double> gains = {},
              std::vector<char> read = {});
  /// MuscleAndPassiveTorques(params, paths, q, qd, a, gains).
  const std::vector<double>& torques() const { return tau_; }
  /// The same with q[coordinate] (speed: qd[coordinate]) set to `value`: the muscles that cross
  /// the coordinate are evaluated again, the others' forces (same lengths and velocities) kept.
  /// The result lives in the point's scratch (no allocation: the forward sensitivities call it
  /// for every free q and u at every step) and holds until the next call; a point is therefore
  /// used by one thread.
  const std::vector<double>& WithCoordinate(int coordinate, bool speed, double value) const;
  /// MuscleAndPassiveTorques(other, paths, q, qd, a) for `other` with the same muscles as
  /// `params` (only passive joint parameters may differ): the muscles' torques kept, and the
  /// passive torque of a coordinate whose parameters are bytewise those of `params` too.
  std::vector<double> WithPassiveOf(const ModelParams& other) const;
  /// MuscleAndPassiveTorques(other, other_paths, q, qd, a, other_gains): a muscle whose Hill
  /// parameters (bytewise), path (tendons::SameGeometry) and gain (bitwise) are the point's keeps
  /// its moment arms and force, the others are evaluated again; the passive torques as
  /// WithPassiveOf. The same bits as MuscleAndPassiveTorques.
  std::vector<double> WithMusclesOf(const ModelParams& other,
                                    const std::vector<tendons::MusclePath>& other_paths,
                                    const std::vector<double>& other_gains) const;
  /// TorquePerActivation (`gain` false) or TorquePerActiveGain (true) at the point, from its
  /// moment arms, lengths, velocities and forces: one Hill force per muscle, no moment arm
  /// evaluated again (the forward sensitivities form it at every step).
  std::vector<double> PerMuscleInput(bool gain) const;

 private:
  const ModelParams& params_;
  const std::vector<tendons::MusclePath>& paths_;
  const std::vector<double>& q_;
  const std::vector<double>& qd_;
  const std::vector<double>& a_;
  /// Whether the caller reads coordinate i's torque.
  bool Read(int i) const { return read_.empty() || read_[i] != 0; }

  std::vector<double> gains_;       // active-force gain of each muscle (empty: 1)
  std::vector<char> read_;          // [coordinate] read by the caller (empty: all)
  std::vector<char> skip_;          // [muscle] crosses no read coordinate (empty: none)
  std::vector<double> arms_;        // CrossingMomentArms(paths, q)
  std::vector<std::size_t> first_;  // index in arms_ of each path's first crossing
  std::vector<double> lengths_;     // l_MT of each muscle, m
  std::vector<double> velocities_;  // musculotendon velocity of each muscle, m/s
  std::vector<double> forces_;      // tendon force of each muscle, N
  std::vector<double> muscle_tau_;  // R f, N·m
  std::vector<double> passive_;     // PassiveJointTorque of each coordinate, N·m
  std::vector<double> tau_;         // R f + passive
  /// Adds each coordinate's passive torque of `other` to *tau (the point's where its parameters
  /// are bytewise the same).
  void AddPassiveOf(const ModelParams& other, std::vector<double>* tau) const;

  // WithCoordinate's scratch: q_, qd_, arms_, forces_ (restored after each call) and its result.
  mutable std::vector<double> moved_q_, moved_qd_, moved_arms_, moved_forces_, moved_tau_;
};

struct CoordinateSlots;  // where each coordinate's q and u sit in the state (upper_limb_model.cc)

/// Scratch of UpperLimbModel::CalcYDot, one per thread; reused between calls, so that a
/// right-hand side allocates nothing once the vectors have their sizes.
///
/// It also keeps what depends on the positions alone — the bodies' poses, the arm support's
/// forces, the articulated inertias, the muscles' lengths and moment arms — with the model and
/// the Simbody Q they are of: a call at the same model and bitwise the same Q (the speed columns
/// of CVODES' difference-quotient Jacobian) reuses them, and gives the same bits as one that
/// computes them (UpperLimbModel.RightHandSideAtTheSamePositionsReusesThemBitwise).
struct RhsWorkspace {
  ChainWorkspace chain;
  MuscleSnapshot muscles;              ///< the muscles at the last call's state
  std::vector<double> q, qdot;         ///< every coordinate's q, q̇ (welded: its angle, 0)
  std::vector<double> arms;            ///< each crossing's moment arm (tendons::CrossingMomentArms)
  std::vector<double> lengths;         ///< each muscle's l_MT at q, m
  const void* positions_of = nullptr;  ///< the model whose position terms are kept (null: none)
  std::vector<double> positions_q;     ///< the Simbody Q they are of
  /// Drops the kept position terms: the next call computes them (a benchmark from scratch).
  void ForgetPositions() { positions_of = nullptr; }
};

/// How the Simbody system of an UpperLimbModel is built; not a model parameter (the same
/// ModelParams give the same dynamics either way).
struct ModelBuildOptions {
  /// Each locked coordinate becomes a weld at its initial angle instead of a pin held by
  /// Simbody's lock, so the system has mobilities only for the free and prescribed coordinates
  /// (the hand rig: 5 of 10). Welds at the ground end of the chain are folded into the first
  /// mobile joint, their bodies left out (the hand rig's humerus and forearm: the ground is their
  /// CoordinateBody and SegmentBody, and arm-support forces on them are the ground's); a weld
  /// below a mobile body keeps its body and mass. A welded coordinate keeps its angle (GetQ,
  /// GetQs) but has no state slot (QIndex −1), reads no sensor torque (SensorTorques throws) nor
  /// muscle torque (MuscleMobilityForces gives 0 there; the weld takes it), and cannot be moved.
  /// For runs that read only the free coordinates: the fits' simulations (identification/fullmodel
  /// SimulateLike); −23 % instructions per hand-rig simulation (docs/performance.md "`fesim
  /// diagnose` wall time"). Same dynamics to round-off, the same error norm (the integrator's
  /// steps then differ only as round-off moves them):
  /// UpperLimbModel.WeldedLockedCoordinatesGiveTheSameDynamics,
  /// Integrator.WeldedLockedCoordinatesIntegrateTheSameTrajectoryAndSensitivities.
  bool weld_locked = false;
};

class UpperLimbModel {
 public:
  /// Builds and realises the topology. Throws std::invalid_argument on inconsistent params.
  explicit UpperLimbModel(ModelParams params, ModelBuildOptions options = {});
  UpperLimbModel(const UpperLimbModel&) = delete;
  UpperLimbModel& operator=(const UpperLimbModel&) = delete;
  ~UpperLimbModel();

  const ModelParams& params() const { return *params_; }
  const ModelBuildOptions& build_options() const { return build_options_; }
  /// True when `coordinate` is a Weld (ModelBuildOptions::weld_locked): no q or u in the state.
  bool Welded(int coordinate) const;
  /// Number of welded coordinates.
  int NumWelded() const;
  /// Index of the coordinate's q in the state's Q (u in U); −1 when it is welded.
  int QIndex(int coordinate) const;
  int UIndex(int coordinate) const;
  const SimTK::MultibodySystem& system() const { return *system_; }
  const SimTK::SimbodyMatterSubsystem& matter() const { return *matter_; }
  int num_muscles() const { return static_cast<int>(params_->muscles.size()); }
  int num_channels() const { return static_cast<int>(params_->channels.size()); }
  /// A (muscles × channels), dimensionless.
  const muscles::ArrayMatrix& electrode_matrix() const { return *array_; }

  /// A state at t = 0: initial angles and speeds, locks applied, activations 0, stimulation 0,
  /// prescribed coordinates on their trajectories. Realised to Stage::Velocity.
  SimTK::State MakeInitialState() const;

  /// Sets the stimulation u (µs per channel) held from now on. Values are clipped to [0, 300].
  void SetStimulation(SimTK::State& state, const std::vector<double>& u_us) const;
  std::vector<double> GetStimulation(const SimTK::State& state) const;

  double GetQ(const SimTK::State& state, int coordinate) const;
  std::vector<double> GetQs(const SimTK::State& state) const;
  std::vector<double> GetUs(const SimTK::State& state) const;
  /// The same read from a whole Y `y` (NY values in Simbody's layout [q, u, z], e.g. an
  /// integrator's VariablesObserver's) instead of the state's variables; `layout` gives only the
  /// layout. ComputeMuscles too (the stimulation is not read).
  double GetQ(const SimTK::State& layout, const double* y, int coordinate) const;
  std::vector<double> GetQs(const SimTK::State& layout, const double* y) const;
  std::vector<double> GetUs(const SimTK::State& layout, const double* y) const;
  MuscleSnapshot ComputeMuscles(const SimTK::State& layout, const double* y) const;
  /// The same into ws->muscles (ws's vectors reused: a record of many rows allocates nothing
  /// per row); drops the position terms ws keeps for CalcYDot.
  const MuscleSnapshot& ComputeMuscles(const SimTK::State& layout, const double* y,
                                       RhsWorkspace* ws) const;

  /// Recruited fraction w_j = H_IRC(A u) of every muscle for the state's stimulation (eq. 1, 3).
  std::vector<double> RecruitedFractions(const SimTK::State& state) const;
  /// Index in the state vector Y = [q, u, z] of muscle 0's activation a; muscle j's a and ȧ are
  /// at +2j and +2j+1. Integrators that solve eq. (6) in closed form use it.
  int ActivationYIndex(const SimTK::State& state) const;
  /// Index in Y of muscle 0's fitness φ (fatigue) and of its potentiation state p; muscle j's at
  /// +j. −1 when the mechanism is off.
  int FitnessYIndex(const SimTK::State& state) const;
  int PotentiationYIndex(const SimTK::State& state) const;
  /// Each muscle's active-force gain φ (1 + g p) (ActiveForceGain) read from a whole Y `y`
  /// (Simbody's layout; `layout` gives only the layout); empty when neither fatigue nor
  /// potentiation is on (every gain 1).
  std::vector<double> ActiveForceGains(const SimTK::State& layout, const double* y) const;
  /// Integrators that advance the activations in closed form (eq. 6; the CVODES integrator) set
  /// true: realising Stage::Dynamics then leaves the activations' ż unwritten (stale), which
  /// nothing of theirs reads, and skips the recruitment and eq. (6) per muscle per right-hand
  /// side. False (a new state's value) for integrators that read ż (Simbody's). A change
  /// invalidates Stage::Dynamics.
  void SetActivationsInClosedForm(SimTK::State& state, bool closed_form) const;
  /// Indices in Y of the q and u of every locked (not welded) coordinate, sorted. They are constant
  /// in time (q̇ = u = 0, u̇ = 0), so integrators may leave them out of the state they advance.
  std::vector<int> LockedYIndices(const SimTK::State& state) const;

  /// Muscle quantities. Reads only the state variables (q, u, activation states), so a state
  /// realised to Stage::Instance suffices.
  MuscleSnapshot ComputeMuscles(const SimTK::State& state) const;

  /// Generalised forces (N·m per coordinate) that the muscle force element applies to the
  /// multibody system, read back from Simbody (Force::calcForceContribution).
  std::vector<double> MuscleMobilityForces(const SimTK::State& state) const;

  /// Torque a sensor on each coordinate would read, N·m: for locked or prescribed coordinates
  /// the torque the limb exerts on the rig (Simbody's motion force, needs Stage::Acceleration);
  /// for a static held joint it equals the sum of applied moments (muscles, passive, gravity).
  /// NaN for free coordinates.
  std::vector<double> SensorTorques(const SimTK::State& state) const;

  /// Mobilized body of a coordinate (the body that its pin moves) and of a segment.
  const SimTK::MobilizedBody& CoordinateBody(int coordinate) const;
  const SimTK::MobilizedBody& SegmentBody(int segment) const;

  /// True when CalcYDot may be used: no coordinate is prescribed.
  bool HasFastDerivatives() const { return chain_ != nullptr; }
  /// Ẏ = [q̇, u̇, ż] in Simbody's Y layout (NY values into ydot) at the state's time and
  /// variables: the force elements' own functions (muscles, passive joints, tremor, arm support,
  /// fatigue and potentiation) with gravity, through the articulated-body algorithm of
  /// ChainDynamics instead of Simbody's realisation — Simbody's getYDot() after
  /// realize(Acceleration) to round-off (UpperLimbModel.FastDerivativesMatchSimbody), at a
  /// fraction of the cost (docs/performance.md "Default model real-time factor"). Reads state
  /// variables only, so the state need not be realised past Stage::Model. A locked coordinate's
  /// q̇ and u̇ are 0; activation ż are left unwritten when the activations are in closed form
  /// (SetActivationsInClosedForm). `ws` is the caller's scratch (one per thread). Throws
  /// std::logic_error when !HasFastDerivatives().
  void CalcYDot(const SimTK::State& state, RhsWorkspace* ws, double* ydot) const;
  /// The same at time t (s) and state variables y (NY values, Simbody's Y layout) instead of the
  /// state's: `state` gives only the stimulation and the closed-form flag (discrete variables)
  /// and the layout. For integrators that keep their own y, so that nothing is written into a
  /// SimTK::State (whose every write invalidates stages) per right-hand side.
  void CalcYDot(const SimTK::State& state, double t, const double* y, RhsWorkspace* ws,
                double* ydot) const;

  /// Total mechanical energy (kinetic + gravity + passive springs/limits + bands + weight
  /// compensation), J. Needs Stage::Velocity.
  double MechanicalEnergy(const SimTK::State& state) const;

 private:
  std::vector<ChainBody> ReadChain(const SimTK::State& s) const;

  std::shared_ptr<const ModelParams> params_;
  ModelBuildOptions build_options_;
  std::shared_ptr<const muscles::ArrayMatrix> array_;
  std::unique_ptr<SimTK::MultibodySystem> system_;
  std::unique_ptr<SimTK::SimbodyMatterSubsystem> matter_;
  std::unique_ptr<SimTK::GeneralForceSubsystem> forces_;
  std::vector<SimTK::MobilizedBodyIndex> coordinate_bodies_;  // index = Coordinate
  std::vector<SimTK::MobilizedBodyIndex> segment_bodies_;     // index = Segment
  class MuscleForce;
  std::shared_ptr<const CoordinateSlots> slots_;
  const MuscleForce* muscle_force_ = nullptr;  // owned by forces_
  SimTK::ForceIndex muscle_force_index_;
  std::unique_ptr<const ChainDynamics> chain_;  // CalcYDot's; null with prescribed coordinates
  std::vector<int> segment_chain_;              // chain body of each segment, −1 = the ground
  SimTK::Vec3 up_;                              // weight compensation's direction, unit
};

}  // namespace fesim::sim
