// Forward dynamics of a tree of pins and welds by the articulated-body algorithm
// ([Featherstone 2008] Rigid Body Dynamics Algorithms, Springer, §7.3 and Table 7.1), in
// Simbody's frame conventions so that a chain read from a SimbodyMatterSubsystem gives Simbody's
// accelerations to round-off (test: ChainDynamics.*, UpperLimbModel.FastDerivativesMatchSimbody).
//
// Why: one right-hand side of the upper-limb model through Simbody's stage machinery
// (realize(Acceleration) with its force subsystem) costs ≈ 20 µs, most of it bookkeeping
// (docs/performance.md "Default model real-time factor"); the same physics as plain recursions
// over ≤ 10 bodies costs a fraction of that. Simbody still builds the model, owns the state and
// realises everything that is reported.
//
// Spatial vectors are (angular; linear), all in the ground frame G about its origin (§7.3's
// algorithm in one frame: no coordinate transforms between bodies, so a massless body costs only
// its kinematics). Units: m, kg, s, rad, N, N·m.
#pragma once

#include <SimTKcommon.h>

#include <vector>

namespace fesim::sim {

/// One body of the tree: a pin (rotation by q about the common Z of its mobilizer frames F on
/// the parent P and M on the body B, Simbody's MobilizedBody::Pin) or a weld (F and M coincide).
struct ChainBody {
  int parent = -1;         ///< index of the parent in the chain, −1 = ground; parents first.
  SimTK::Transform X_PF;   ///< F in the parent's frame (ground's for parent −1).
  SimTK::Transform X_BM;   ///< M in B.
  double mass_kg = 0.0;    ///< m ≥ 0 (massless bodies allowed inside the chain).
  SimTK::Vec3 com_m{0.0};  ///< mass centre in B, m.
  SimTK::Mat33 inertia_o{0, 0, 0, 0, 0, 0, 0, 0, 0};  ///< about B's origin, in B, kg·m².
  int q = -1;                                         ///< the pin's index in Q; −1 for a weld.
  int u = -1;                                         ///< the pin's index in U; −1 for a weld.
  bool held = false;  ///< a pin held at its q (u = u̇ = 0; Simbody's lock): moves as a weld.
};

/// Per-call scratch of ChainDynamics (one per thread; the dynamics object is immutable). Spatial
/// quantities are in G, about G's origin.
struct ChainWorkspace {
  std::vector<SimTK::Mat33> R_GM;    ///< orientation of each mobilizer frame M in G
  std::vector<SimTK::Vec3> p_GM;     ///< M's origin in G, m
  std::vector<SimTK::Mat33> R_GB;    ///< orientation of B in G (bodies with mass only)
  std::vector<SimTK::Vec3> p_GB;     ///< B's origin in G, m (bodies with mass only)
  std::vector<SimTK::SpatialVec> S;  ///< each moving pin's axis as a unit motion
  std::vector<SimTK::SpatialVec> v, c, p, U, a;
  std::vector<SimTK::SpatialVec> f;      ///< applied body forces (ApplyForceAtStation)
  std::vector<SimTK::Mat33> RA, RB, RC;  ///< rigid-body inertia blocks [[A, B], [Bᵀ, C]] (massive)
  std::vector<SimTK::Mat33> IA, IB, IC;  ///< articulated inertia blocks
  std::vector<SimTK::Mat33> PA, PB, PC;  ///< I^A less U D⁻¹ Uᵀ, passed to the parent (moving pins)
  std::vector<double> D, inv_d, uu;
  std::vector<double> tau;  ///< the caller's mobility forces (UpperLimbModel::CalcYDot)
};

class ChainDynamics {
 public:
  /// `gravity_m_s2` in G. Throws std::invalid_argument when a parent does not come before its
  /// child.
  ChainDynamics(std::vector<ChainBody> bodies, SimTK::Vec3 gravity_m_s2);

  int num_bodies() const { return static_cast<int>(bodies_.size()); }
  const ChainBody& body(int b) const { return bodies_[b]; }

  /// Poses of every body at the generalized coordinates Q (`q` indexed as ChainBody::q) and
  /// clears the applied body forces. First call of an evaluation.
  void Kinematics(const double* q, ChainWorkspace* ws) const;
  /// Location in G of station p_B of body b, m (after Kinematics; a body with mass).
  SimTK::Vec3 StationInGround(const ChainWorkspace& ws, int b, const SimTK::Vec3& p_B) const;
  /// Applies force f_G (N, in G) at station p_B of body b (after Kinematics; a body with mass).
  void ApplyForceAtStation(ChainWorkspace* ws, int b, const SimTK::Vec3& p_B,
                           const SimTK::Vec3& f_G) const;
  /// u̇ (indexed as ChainBody::u) for speeds u and mobility forces τ (both indexed as
  /// ChainBody::u) with gravity and the applied body forces; a held pin's u̇ is 0. After
  /// Kinematics. O(n): Table 7.1's three passes — ArticulatedInertias, then
  /// AccelerationsAtInertias.
  void Accelerations(const double* u, const double* tau, ChainWorkspace* ws, double* udot) const;
  /// The part of Table 7.1's passes that depends on the positions alone (after Kinematics): the
  /// rigid-body and articulated inertias, U = I^A S, D = Sᵀ U and the inertia each body passes to
  /// its parent. A caller that evaluates several speeds at one position (the speed columns of a
  /// difference-quotient Jacobian, UpperLimbModel::CalcYDot) calls it once.
  void ArticulatedInertias(ChainWorkspace* ws) const;
  /// The speed- and force-dependent rest of Accelerations, on the inertias of the last
  /// ArticulatedInertias; the same arithmetic in the same order, so the same bits as
  /// Accelerations.
  void AccelerationsAtInertias(const double* u, const double* tau, ChainWorkspace* ws,
                               double* udot) const;

 private:
  std::vector<ChainBody> bodies_;
  std::vector<SimTK::Transform> X_MF_;   ///< the body's F in its parent's M (ground's G at −1)
  std::vector<SimTK::Transform> X_MB_;   ///< B in M
  std::vector<SimTK::Mat33> inertia_c_;  ///< inertia about the mass centre, in B
  SimTK::Vec3 gravity_;
};

}  // namespace fesim::sim
