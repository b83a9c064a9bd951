#include "sim/upper_limb_model.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <type_traits>

#include "muscles/activation.h"
#include "muscles/hill.h"
#include "muscles/recruitment.h"
#include "sim/arm_support.h"
#include "sim/chain_dynamics.h"
#include "sim/mechanisms.h"
#include "sim/passive_joint.h"
#include "sim/prescribed_motion.h"
#include "tendons/tendon_network.h"

namespace fesim::sim {

using SimTK::Real;
using SimTK::State;
using SimTK::Vec3;
using SimTK::Vector;

/// Position of each coordinate's q and u in the state vectors. Filled once after the topology
/// is realised (the layout is fixed from then on) and shared read-only with the force elements,
/// which read q, u and add mobility forces by index instead of through MobilizedBody handles.
struct CoordinateSlots {
  std::vector<int> q, u;         ///< −1 for a welded coordinate (ModelBuildOptions::weld_locked).
  std::vector<double> welded_q;  ///< a welded coordinate's angle, rad (unused otherwise).
};

namespace {

constexpr double kMaxPulseWidthUs = 300.0;

Vec3 ToVec3(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

/// Frame at `p` whose Z axis is `axis` (a Pin rotates about its frames' common Z).
SimTK::Transform PinFrame(const Vec3& axis, const Vec3& p) {
  return {SimTK::Rotation(SimTK::UnitVec3(axis), SimTK::ZAxis), p};
}

SimTK::Body::Rigid RigidBody(const SegmentParams& s) {
  const Vec3 com = ToVec3(s.com_in_body_m);
  const SimTK::Inertia about_com(ToVec3(s.inertia_about_com_kg_m2));
  return SimTK::Body::Rigid(
      SimTK::MassProperties(s.mass_kg, com, about_com.shiftFromMassCenter(com, s.mass_kg)));
}

/// Every coordinate's q from Simbody's Q `q` (a welded one: its angle).
std::vector<double> QsOf(const CoordinateSlots& slots, const double* q) {
  std::vector<double> out(slots.q.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = slots.q[i] >= 0 ? q[slots.q[i]] : slots.welded_q[i];
  }
  return out;
}
std::vector<double> QsOf(const CoordinateSlots& slots, const State& s) {
  return QsOf(slots, s.getNQ() > 0 ? s.getQ().getContiguousScalarData() : nullptr);
}

/// Every coordinate's q̇ from Simbody's U `u` (a welded one: 0).
std::vector<double> UsOf(const CoordinateSlots& slots, const double* u) {
  std::vector<double> out(slots.u.size());
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = slots.u[i] >= 0 ? u[slots.u[i]] : 0.0;
  return out;
}
std::vector<double> UsOf(const CoordinateSlots& slots, const State& s) {
  return UsOf(slots, s.getNU() > 0 ? s.getU().getContiguousScalarData() : nullptr);
}

/// w_j = H_IRC(Σ_k A_jk u_k) of muscle j (eq. 1, 3) for stimulation u (µs, already clipped).
double RecruitedFraction(const MuscleParams& m, const muscles::ArrayMatrix& array, int j,
                         const double* u_us) {
  double v = 0.0;
  for (int k = 0; k < array.channels; ++k) v += array(j, k) * u_us[k];
  return muscles::Recruitment(m.recruitment, v);
}

/// Tendon force of one muscle at activation a with gain `active_gain` on the active part
/// (eq. 4, 7), and the musculotendon kinematics it came from.
struct MuscleTendonSample {
  double force_n = 0.0, length_m = 0.0, velocity_m_s = 0.0;
  bool clamped = false;
};
MuscleTendonSample MuscleTendonForceAt(const MuscleParams& m, double length_m, double velocity_m_s,
                                       double a, double active_gain) {
  MuscleTendonSample out;
  out.length_m = length_m;
  out.velocity_m_s = velocity_m_s;
  const auto fibre = muscles::FibreFromMusculotendon(m.hill, out.length_m, out.velocity_m_s);
  out.clamped = fibre.clamped;
  out.force_n = muscles::HillTendonForce(m.hill, a, fibre, active_gain);
  return out;
}
MuscleTendonSample MuscleTendonForce(const MuscleParams& m, const tendons::MusclePath& path,
                                     const std::vector<double>& q, const std::vector<double>& qd,
                                     double a, double active_gain) {
  return MuscleTendonForceAt(m, tendons::MusculotendonLength(path, q),
                             tendons::MusculotendonVelocity(path, q, qd), a, active_gain);
}

/// Adds the passive joint moments (eq. 14 and range limits) of every coordinate that has a
/// mobility and the tremor torque at time t (s) to `mobility` (N·m, U layout) for Simbody's Q
/// and U. Both right-hand sides apply exactly this (PassiveJointForce and
/// UpperLimbModel::CalcYDot).
void AddPassiveMobilityForces(const CoordinateSlots& slots, const ModelParams& params,
                              const double* q, const double* u, double t, double* mobility) {
  for (int i = 0; i < kNumCoordinates; ++i) {
    if (slots.u[i] < 0) continue;  // welded: the weld takes every moment
    mobility[slots.u[i]] +=
        PassiveJointTorque(params.coordinates[i].passive, q[slots.q[i]], u[slots.u[i]]);
  }
  const TremorParams& tremor = params.mechanisms.tremor;
  if (tremor.enabled && slots.u[tremor.coordinate] >= 0) {
    mobility[slots.u[tremor.coordinate]] += TremorTorque(tremor, t);
  }
}

/// The direction opposite to gravity (weight compensation's force direction); +Y without gravity.
Vec3 UpDirection(const ModelParams& params) {
  const Vec3 g = ToVec3(params.gravity_m_s2);
  return g.norm() > 0 ? Vec3(-g / g.norm()) : Vec3(0, 1, 0);
}

/// Calls apply(segment, p_B, f_G) for every cuff of the arm support: each band's force (N, in G,
/// arm_support.h) at its cuff p_B (m, in the segment) located in G by station(segment, p_B), and
/// each weight compensation's F_w · up. Segments with on_ground(segment) are skipped: a segment
/// welded to the ground end of the chain (ModelBuildOptions::weld_locked) is the ground, and what
/// acts on it is held by the ground.
template <class OnGround, class Station, class Apply>
void ForEachSupportForce(const ModelParams& params, const Vec3& up, OnGround on_ground,
                         Station station, Apply apply) {
  for (const auto& band : params.bands) {
    if (on_ground(band.segment)) continue;
    const Vec3 p_B = ToVec3(band.cuff_in_segment_m);
    const Vec3 p_G = station(band.segment, p_B);
    const Vec3d f = BandForce(band, {p_G[0], p_G[1], p_G[2]});
    apply(band.segment, p_B, Vec3(f[0], f[1], f[2]));
  }
  for (const auto& w : params.weight_compensation) {
    if (on_ground(w.segment)) continue;
    apply(w.segment, ToVec3(w.cuff_in_segment_m), w.force_n * up);
  }
}

/// Passive joint moments on every coordinate and the tremor torque (thin adapter over
/// AddPassiveMobilityForces).
class PassiveJointForce : public SimTK::Force::Custom::Implementation {
 public:
  PassiveJointForce(std::shared_ptr<const CoordinateSlots> slots,
                    std::shared_ptr<const ModelParams> params)
      : slots_(std::move(slots)), params_(std::move(params)) {}

  void calcForce(const State& s, SimTK::Vector_<SimTK::SpatialVec>& /*body_forces*/,
                 SimTK::Vector_<Vec3>& /*particle_forces*/,
                 Vector& mobility_forces) const override {
    if (mobility_forces.size() == 0) return;
    AddPassiveMobilityForces(*slots_, *params_, s.getQ().getContiguousScalarData(),
                             s.getU().getContiguousScalarData(), s.getTime(), &mobility_forces[0]);
  }
  Real calcPotentialEnergy(const State& s) const override {
    const std::vector<double> q = QsOf(*slots_, s);
    double v = 0.0;
    for (int i = 0; i < kNumCoordinates; ++i) {
      v += PassiveJointPotential(params_->coordinates[i].passive, q[i]);
    }
    return v;
  }

 private:
  std::shared_ptr<const CoordinateSlots> slots_;
  std::shared_ptr<const ModelParams> params_;
};

/// Elastic bands and weight compensation of the arm support (adapter over arm_support.h).
class ArmSupportForce : public SimTK::Force::Custom::Implementation {
 public:
  ArmSupportForce(const SimTK::SimbodyMatterSubsystem& matter,
                  std::vector<SimTK::MobilizedBodyIndex> segments,
                  std::shared_ptr<const ModelParams> params)
      : matter_(matter),
        segments_(std::move(segments)),
        params_(std::move(params)),
        up_(UpDirection(*params_)) {}

  void calcForce(const State& s, SimTK::Vector_<SimTK::SpatialVec>& body_forces,
                 SimTK::Vector_<Vec3>& /*particle_forces*/,
                 Vector& /*mobility_forces*/) const override {
    ForEachSupportForce(
        *params_, up_, [&](int segment) { return Segment(segment).isGround(); },
        [&](int segment, const Vec3& p_B) {
          return Segment(segment).findStationLocationInGround(s, p_B);
        },
        [&](int segment, const Vec3& p_B, const Vec3& f_G) {
          Segment(segment).applyForceToBodyPoint(s, p_B, f_G, body_forces);
        });
  }
  Real calcPotentialEnergy(const State& s) const override {
    double v = 0.0;
    for (const auto& band : params_->bands) {
      const Vec3 p = matter_.getMobilizedBody(segments_[band.segment])
                         .findStationLocationInGround(s, ToVec3(band.cuff_in_segment_m));
      v += BandPotential(band, {p[0], p[1], p[2]});
    }
    for (const auto& w : params_->weight_compensation) {
      const Vec3 p = matter_.getMobilizedBody(segments_[w.segment])
                         .findStationLocationInGround(s, ToVec3(w.cuff_in_segment_m));
      v -= w.force_n * SimTK::dot(up_, p);  // F = F_w·up is −∇V
    }
    return v;
  }

 private:
  const SimTK::MobilizedBody& Segment(int segment) const {
    return matter_.getMobilizedBody(segments_[segment]);
  }
  const SimTK::SimbodyMatterSubsystem& matter_;
  std::vector<SimTK::MobilizedBodyIndex> segments_;
  std::shared_ptr<const ModelParams> params_;
  Vec3 up_;
};

/// A coordinate driven along q(t) = offset + A sin(2πft + φ) (robot-driven rigs).
class SineMotion : public SimTK::Motion::Custom::Implementation {
 public:
  explicit SineMotion(const SinePrescription& p) : p_(p) {}
  SimTK::Motion::Level getLevel(const State& /*s*/) const override {
    return SimTK::Motion::Position;
  }
  void calcPrescribedPosition(const State& s, int /*nq*/, Real* q) const override {
    *q = p_.offset_rad + p_.amplitude_rad * std::sin(w() * s.getTime() + p_.phase_rad);
  }
  void calcPrescribedPositionDot(const State& s, int /*nq*/, Real* qd) const override {
    *qd = p_.amplitude_rad * w() * std::cos(w() * s.getTime() + p_.phase_rad);
  }
  void calcPrescribedPositionDotDot(const State& s, int /*nq*/, Real* qdd) const override {
    *qdd = -p_.amplitude_rad * w() * w() * std::sin(w() * s.getTime() + p_.phase_rad);
  }

 private:
  double w() const { return 2.0 * SimTK::Pi * p_.frequency_hz; }
  SinePrescription p_;
};

/// Muscle j's active-force gain: gains[j], 1 when `gains` is empty.
double GainOf(const std::vector<double>& gains, std::size_t j) {
  return gains.empty() ? 1.0 : gains[j];
}

}  // namespace

/// Muscles: stimulation (discrete variable) → A → recruitment → activation ODE (z states)
/// → Hill force → τ = R(q) f. Thin adapter over muscles/ and tendons/.
class UpperLimbModel::MuscleForce : public SimTK::Force::Custom::Implementation {
 public:
  MuscleForce(const SimTK::GeneralForceSubsystem& forces,
              std::shared_ptr<const CoordinateSlots> slots,
              std::shared_ptr<const ModelParams> params,
              std::shared_ptr<const muscles::ArrayMatrix> array)
      : forces_(forces),
        slots_(std::move(slots)),
        params_(std::move(params)),
        array_(std::move(array)) {
    for (const auto& m : params_->muscles) {
      paths_.push_back(m.path);
      asymmetric_ |= m.deactivation_ratio != 1.0;
    }
    inert_.assign(paths_.size(), 0);  // FindInertMuscles, once the slots are known
    reflex_slot_.assign(params_->muscles.size(), -1);
    const StretchReflexParams& reflex = params_->mechanisms.stretch_reflex;
    if (!reflex.enabled()) return;
    for (const std::string& name : reflex.muscles) {
      const auto it = std::find_if(params_->muscles.begin(), params_->muscles.end(),
                                   [&](const MuscleParams& m) { return m.name == name; });
      if (it == params_->muscles.end()) {
        throw std::invalid_argument("mechanisms.stretch_reflex.muscles: unknown muscle '" + name +
                                    "'");
      }
      int& slot = reflex_slot_[it - params_->muscles.begin()];
      if (slot < 0) slot = num_reflex_++;
    }
  }

  /// Marks the muscles whose every crossing is welded (ModelBuildOptions::weld_locked): their
  /// torques act on welds only, and a right-hand side skips them (RightHandSideForces). Called
  /// once the coordinate slots are filled (after realizeTopology).
  /// Also checks every crossing's joint (as tendons::CrossingMomentArms does), once: a
  /// right-hand side's Geometry does not.
  void FindInertMuscles() {
    std::vector<double> arms;
    tendons::CrossingMomentArms(paths_, std::vector<double>(slots_->u.size(), 0.0), &arms);
    num_crossings_ = arms.size();
    for (std::size_t j = 0; j < paths_.size(); ++j) {
      bool inert = true;
      for (const auto& c : paths_[j].crossings) inert = inert && slots_->u[c.joint] < 0;
      inert_[j] = inert;
    }
  }

  void realizeTopology(State& s) const override {
    const int nm = static_cast<int>(params_->muscles.size());
    // z = [a_0, ȧ_0, …, a_{n−1}, ȧ_{n−1}, φ_0…φ_{n−1} (fatigue), p_0…p_{n−1} (potentiation),
    //      {x, r, ṙ} of each stretch-reflex muscle (mechanisms.h)].
    const auto& mech = params_->mechanisms;
    const int n_extra =
        (mech.fatigue.enabled ? nm : 0) + (mech.potentiation.enabled ? nm : 0) + 3 * num_reflex_;
    Vector z0(2 * nm + n_extra, 0.0);
    if (mech.fatigue.enabled) {
      for (int j = 0; j < nm; ++j) z0[2 * nm + j] = 1.0;  // fully fit at t = 0
    }
    z_start_ = forces_.allocateZ(s, z0);
    fitness_offset_ = mech.fatigue.enabled ? 2 * nm : -1;
    potentiation_offset_ =
        mech.potentiation.enabled ? 2 * nm + (mech.fatigue.enabled ? nm : 0) : -1;
    reflex_offset_ = num_reflex_ > 0 ? 2 * nm + n_extra - 3 * num_reflex_ : -1;
    stim_index_ = forces_.allocateDiscreteVariable(
        s, SimTK::Stage::Dynamics,
        new SimTK::Value<Vector>(Vector(static_cast<int>(params_->channels.size()), 0.0)));
    closed_form_index_ =
        forces_.allocateDiscreteVariable(s, SimTK::Stage::Dynamics, new SimTK::Value<bool>(false));
    Vector omega(nm);
    for (int j = 0; j < nm; ++j) omega[j] = params_->muscles[j].activation_omega_rad_s;
    omega_index_ = forces_.allocateDiscreteVariable(s, SimTK::Stage::Dynamics,
                                                    new SimTK::Value<Vector>(omega));
  }

  /// w = H_IRC(A u) of muscle j for stimulation u (µs).
  double Recruited(const Vector& u, int j) const {
    return RecruitedFraction(params_->muscles[j], *array_, j, u.size() > 0 ? &u[0] : nullptr);
  }

  int ZStart() const { return z_start_; }
  /// Offsets from ZStart() of muscle 0's fitness and potentiation state (−1: mechanism off).
  int FitnessOffset() const { return fitness_offset_; }
  int PotentiationOffset() const { return potentiation_offset_; }

  void realizeDynamics(const State& s) const override {
    if (params_->muscles.empty()) return;
    if (fitness_offset_ < 0 && potentiation_offset_ < 0 && reflex_offset_ < 0 &&
        ClosedFormActivations(s)) {
      return;
    }
    Vector& zdot = forces_.updZDot(s);
    ZDot(s, &zdot[z_start_]);
  }

  /// ż of this element's z block (from ZStart) into zdot[0…]: ȧ, ä of eq. (6) driven by
  /// w = H_IRC(A u) — unless an integrator advances the activations in closed form
  /// (SetActivationsInClosedForm): then nothing reads them and they are left unwritten — and the
  /// fatigue, potentiation and stretch-reflex states' ż. Reads only state variables (no stage
  /// needed).
  void ZDot(const State& s, double* zdot) const {
    const MuscleSnapshot snap = reflex_offset_ >= 0 ? Compute(s) : MuscleSnapshot{};
    ZDot(s, ZBlock(s), snap.velocity_m_s.data(), zdot);
  }
  /// The same for this element's z block `z` instead of the state's (`s` gives the stimulation
  /// and the closed-form flag) and the muscles' dl_MT/dt `velocity_m_s` (m/s; read only with the
  /// stretch reflex on).
  void ZDot(const State& s, const double* z, const double* velocity_m_s, double* zdot) const {
    const int nm = static_cast<int>(params_->muscles.size());
    if (nm == 0) return;
    if (reflex_offset_ >= 0) ReflexZDot(z, velocity_m_s, zdot);
    const bool closed_form = ClosedFormActivations(s);
    const Vector* u = closed_form ? nullptr : &Stimulation(s);
    const Vector* omega = closed_form ? nullptr : &IntervalOmega(s);
    for (int j = 0; j < nm; ++j) {
      if (!closed_form) {
        const double w = Recruited(*u, j);
        const auto d = muscles::ActivationDerivative((*omega)[j], w, {z[2 * j], z[2 * j + 1]});
        zdot[2 * j] = d.a;
        zdot[2 * j + 1] = d.a_dot;
      }
      const double a = std::clamp(Activation(z, j), 0.0, 1.0);
      if (fitness_offset_ >= 0) {
        const int k = fitness_offset_ + j;
        zdot[k] = FitnessDerivative(params_->mechanisms.fatigue, a, z[k]);
      }
      if (potentiation_offset_ >= 0) {
        const int k = potentiation_offset_ + j;
        zdot[k] = PotentiationDerivative(params_->mechanisms.potentiation, a, z[k]);
      }
    }
  }

  /// ż of the stretch-reflex states {x, r, ṙ} of each reflex muscle (mechanisms.h).
  void ReflexZDot(const double* z, const double* velocity_m_s, double* zdot) const {
    const StretchReflexParams& reflex = params_->mechanisms.stretch_reflex;
    for (std::size_t j = 0; j < reflex_slot_.size(); ++j) {
      if (reflex_slot_[j] < 0) continue;
      const MuscleParams& m = params_->muscles[j];
      const int k = reflex_offset_ + 3 * reflex_slot_[j];
      const double drive =
          StretchReflexDrive(reflex, velocity_m_s[j] / m.hill.optimal_fibre_length_m);
      const auto d = StretchReflexDerivative(reflex, m.activation_omega_rad_s, drive,
                                             {z[k], z[k + 1], z[k + 2]});
      std::copy(d.begin(), d.end(), zdot + k);
    }
  }

  /// Muscle j's activation a (eq. 6); with the stretch reflex a + r clipped to [0, 1], so that
  /// the reported activation is the one the force, fatigue and potentiation see.
  double Activation(const double* z, int j) const {
    const int slot = reflex_slot_[j];
    if (slot < 0) return z[2 * j];
    return std::clamp(z[2 * j] + z[reflex_offset_ + 3 * slot + 1], 0.0, 1.0);
  }

  void calcForce(const State& s, SimTK::Vector_<SimTK::SpatialVec>& /*body_forces*/,
                 SimTK::Vector_<Vec3>& /*particle_forces*/,
                 Vector& mobility_forces) const override {
    const MuscleSnapshot snap = Compute(s);
    for (int i = 0; i < kNumCoordinates; ++i) {
      if (slots_->u[i] >= 0) mobility_forces[slots_->u[i]] += snap.joint_torque_nm[i];
    }
  }
  Real calcPotentialEnergy(const State& /*s*/) const override { return 0.0; }

  MuscleSnapshot Compute(const State& s) const {
    RhsWorkspace ws;
    Compute(s.getNQ() > 0 ? s.getQ().getContiguousScalarData() : nullptr,
            s.getNU() > 0 ? s.getU().getContiguousScalarData() : nullptr, ZBlock(s), &ws);
    return std::move(ws.muscles);
  }

  /// This element's z block in the state; null without muscles.
  const double* ZBlock(const State& s) const {
    const Vector& z = forces_.getZ(s);
    return z.size() > 0 ? &z[z_start_] : nullptr;
  }

  /// The muscles at Simbody's Q and U `q`, `u` and this element's z block `z` into ws->muscles
  /// (ws's vectors reused): Geometry, then Forces.
  void Compute(const double* q_state, const double* u_state, const double* z,
               RhsWorkspace* ws) const {
    Geometry(q_state, ws);
    Forces(u_state, z, ws);
  }

  /// What depends on the positions alone, into ws: every coordinate's q, each crossing's moment
  /// arm and each muscle's musculotendon length — with `skip_inert`, not those of the muscles
  /// that cross welds only (their entries keep whatever they held).
  void Geometry(const double* q_state, RhsWorkspace* ws, bool skip_inert = false) const {
    std::vector<double>& q = ws->q;
    q.resize(slots_->q.size());
    for (std::size_t i = 0; i < q.size(); ++i) {
      q[i] = slots_->q[i] >= 0 ? q_state[slots_->q[i]] : slots_->welded_q[i];
    }
    // Each crossing's moment arm once, for the velocity and τ = R f (same bits as per use).
    if (!skip_inert) {
      tendons::CrossingMomentArms(paths_, q, &ws->arms);  // checks every crossing's joint
    } else {  // a right-hand side: the joints were checked once (FindInertMuscles)
      ws->arms.resize(num_crossings_);
      double* arm = ws->arms.data();
      for (std::size_t j = 0; j < paths_.size(); ++j) {
        for (const auto& c : paths_[j].crossings) {
          if (!inert_[j]) *arm = tendons::MomentArm(c.arm, q[c.joint] - c.q_ref_rad);
          ++arm;
        }
      }
    }
    ws->lengths.resize(paths_.size());
    for (std::size_t j = 0; j < paths_.size(); ++j) {
      if (skip_inert && inert_[j]) continue;
      ws->lengths[j] = tendons::MusculotendonLength(paths_[j], q);
    }
  }

  /// Forces for a right-hand side (UpperLimbModel::CalcYDot): a muscle that crosses welds only
  /// gets force 0 and velocity 0 (its velocity at welds; its Geometry was skipped), so the joint
  /// torques of every coordinate with a mobility — sums over the muscles that cross it, in the
  /// same order — have the bits Forces gives; the welds' torques are not applied.
  void RightHandSideForces(const double* u_state, const double* z, RhsWorkspace* ws) const {
    Forces(u_state, z, ws, true);
  }

  /// The muscles' forces and joint torques at Simbody's U `u_state` and z block `z` into
  /// ws->muscles, on the Geometry in ws (`skip_inert`: RightHandSideForces).
  void Forces(const double* u_state, const double* z, RhsWorkspace* ws,
              bool skip_inert = false) const {
    std::vector<double>& qd = ws->qdot;
    qd.resize(slots_->u.size());
    for (std::size_t i = 0; i < qd.size(); ++i) {
      qd[i] = slots_->u[i] >= 0 ? u_state[slots_->u[i]] : 0.0;
    }
    const int nm = static_cast<int>(params_->muscles.size());
    MuscleSnapshot& out = ws->muscles;
    out.activation.resize(nm);
    out.force_n.resize(nm);
    out.length_m.resize(nm);
    out.velocity_m_s.resize(nm);
    out.any_clamped = false;
    const double* arms_j = ws->arms.data();
    for (int j = 0; j < nm; ++j) {
      out.activation[j] = Activation(z, j);
      if (skip_inert && inert_[j]) {
        arms_j += paths_[j].crossings.size();
        out.force_n[j] = 0.0;
        out.length_m[j] = 0.0;
        out.velocity_m_s[j] = 0.0;
        continue;
      }
      const double gain =
          ActiveForceGain(params_->mechanisms, fitness_offset_ >= 0 ? z[fitness_offset_ + j] : 1.0,
                          potentiation_offset_ >= 0 ? z[potentiation_offset_ + j] : 0.0);
      const MuscleTendonSample m = MuscleTendonForceAt(
          params_->muscles[j], ws->lengths[j],
          tendons::MusculotendonVelocity(paths_[j], arms_j, qd), out.activation[j], gain);
      arms_j += paths_[j].crossings.size();
      out.any_clamped = out.any_clamped || m.clamped;
      out.force_n[j] = m.force_n;
      out.length_m[j] = m.length_m;
      out.velocity_m_s[j] = m.velocity_m_s;
    }
    tendons::JointTorques(paths_, ws->arms, out.force_n, ws->q.size(), &out.joint_torque_nm);
  }

  const Vector& Stimulation(const State& s) const {
    return SimTK::Value<Vector>::downcast(forces_.getDiscreteVariable(s, stim_index_));
  }
  Vector& UpdStimulation(State& s) const {
    return SimTK::Value<Vector>::updDowncast(forces_.updDiscreteVariable(s, stim_index_));
  }
  /// Ω of eq. (6) of each muscle in the current stimulation interval (muscles::IntervalOmega),
  /// rad/s: set with the stimulation from the activations at that moment.
  const Vector& IntervalOmega(const State& s) const {
    return SimTK::Value<Vector>::downcast(forces_.getDiscreteVariable(s, omega_index_));
  }
  /// Sets IntervalOmega from the state's activations and the recruitment of its stimulation;
  /// written only when some Ω changes (a write invalidates Stage::Dynamics). Nothing to do when
  /// every ratio is 1: IntervalOmega keeps the Ω_i it was allocated with.
  void UpdateIntervalOmega(State& s) const {
    if (!asymmetric_) return;
    const int nm = static_cast<int>(params_->muscles.size());
    const Vector& u = Stimulation(s);
    const Vector& z = forces_.getZ(s);
    const Vector& now = IntervalOmega(s);
    Vector omega(nm);
    bool changed = false;
    for (int j = 0; j < nm; ++j) {
      const auto& m = params_->muscles[j];
      const muscles::ActivationState a{z[z_start_ + 2 * j], z[z_start_ + 2 * j + 1]};
      omega[j] = muscles::IntervalOmega(m.activation_omega_rad_s, m.deactivation_ratio,
                                        Recruited(u, j), a);
      changed |= omega[j] != now[j];
    }
    if (!changed) return;
    SimTK::Value<Vector>::updDowncast(forces_.updDiscreteVariable(s, omega_index_)) = omega;
  }
  bool ClosedFormActivations(const State& s) const {
    return SimTK::Value<bool>::downcast(forces_.getDiscreteVariable(s, closed_form_index_));
  }
  void SetClosedFormActivations(State& s, bool closed_form) const {
    // Written only when it changes: a write invalidates Stage::Dynamics.
    if (ClosedFormActivations(s) == closed_form) return;
    SimTK::Value<bool>::updDowncast(forces_.updDiscreteVariable(s, closed_form_index_)) =
        closed_form;
  }

 private:
  const SimTK::GeneralForceSubsystem& forces_;
  std::shared_ptr<const CoordinateSlots> slots_;
  std::shared_ptr<const ModelParams> params_;
  std::shared_ptr<const muscles::ArrayMatrix> array_;
  std::vector<tendons::MusclePath> paths_;
  // Topology-stage indices, written once by realizeTopology (Simbody's own pattern).
  mutable SimTK::ZIndex z_start_;
  mutable int fitness_offset_ = -1;       // from z_start_, −1 when fatigue is off
  mutable int potentiation_offset_ = -1;  // from z_start_, −1 when potentiation is off
  mutable int reflex_offset_ = -1;        // from z_start_, −1 when the stretch reflex is off
  std::vector<char> inert_;               // [muscle] crosses welded coordinates only
  std::size_t num_crossings_ = 0;         // of all paths (FindInertMuscles)
  std::vector<int> reflex_slot_;          // [muscle] its reflex block (0, 1, …) or −1
  int num_reflex_ = 0;                    // muscles with the stretch reflex
  bool asymmetric_ = false;               // some muscle's deactivation_ratio ≠ 1
  mutable SimTK::DiscreteVariableIndex stim_index_;
  mutable SimTK::DiscreteVariableIndex closed_form_index_;  // bool: activations in closed form
  mutable SimTK::DiscreteVariableIndex omega_index_;        // Vector: IntervalOmega
};

std::vector<double> RecruitedFractions(const ModelParams& params, const muscles::ArrayMatrix& array,
                                       const std::vector<double>& u_us) {
  if (static_cast<int>(u_us.size()) != array.channels) {
    throw std::invalid_argument("stimulation has " + std::to_string(u_us.size()) +
                                " channels, electrode matrix has " +
                                std::to_string(array.channels));
  }
  std::vector<double> u(u_us.size());
  for (std::size_t k = 0; k < u.size(); ++k) u[k] = std::clamp(u_us[k], 0.0, kMaxPulseWidthUs);
  std::vector<double> w(params.muscles.size());
  for (std::size_t j = 0; j < w.size(); ++j) {
    w[j] = RecruitedFraction(params.muscles[j], array, static_cast<int>(j), u.data());
  }
  return w;
}

std::vector<double> MuscleAndPassiveTorques(const ModelParams& params,
                                            const std::vector<tendons::MusclePath>& paths,
                                            const std::vector<double>& q,
                                            const std::vector<double>& qd,
                                            const std::vector<double>& a,
                                            const std::vector<double>& gains) {
  std::vector<double> f(params.muscles.size());
  for (std::size_t j = 0; j < f.size(); ++j) {
    f[j] = MuscleTendonForce(params.muscles[j], paths[j], q, qd, a[j], GainOf(gains, j)).force_n;
  }
  std::vector<double> tau = tendons::JointTorques(paths, q, f);
  for (int i = 0; i < kNumCoordinates; ++i) {
    tau[i] += PassiveJointTorque(params.coordinates[i].passive, q[i], qd[i]);
  }
  return tau;
}

TorquePoint::TorquePoint(const ModelParams& params, const std::vector<tendons::MusclePath>& paths,
                         const std::vector<double>& q, const std::vector<double>& qd,
                         const std::vector<double>& a, std::vector<double> gains,
                         std::vector<char> read)
    : params_(params),
      paths_(paths),
      q_(q),
      qd_(qd),
      a_(a),
      gains_(std::move(gains)),
      read_(std::move(read)) {
  const std::size_t nm = params.muscles.size();
  if (!read_.empty()) {
    if (read_.size() != q.size()) throw std::invalid_argument("TorquePoint: read mask size");
    skip_.assign(nm, 1);
    for (std::size_t j = 0; j < nm; ++j) {
      for (const auto& c : paths[j].crossings) {
        if (c.joint >= 0 && c.joint < static_cast<int>(read_.size()) && read_[c.joint]) {
          skip_[j] = 0;
        }
      }
    }
  }
  // MuscleAndPassiveTorques' steps, through the arm-based overloads (the same bits).
  tendons::CrossingMomentArms(paths, q, &arms_, skip_);
  first_.resize(nm);
  lengths_.assign(nm, 0.0);
  velocities_.assign(nm, 0.0);
  forces_.assign(nm, 0.0);
  std::size_t k = 0;
  for (std::size_t j = 0; j < nm; ++j) {
    first_[j] = k;
    k += paths[j].crossings.size();
    if (!skip_.empty() && skip_[j]) continue;
    lengths_[j] = tendons::MusculotendonLength(paths[j], q);
    velocities_[j] = tendons::MusculotendonVelocity(paths[j], &arms_[first_[j]], qd);
    forces_[j] =
        MuscleTendonForceAt(params.muscles[j], lengths_[j], velocities_[j], a[j], GainOf(gains_, j))
            .force_n;
  }
  tendons::JointTorques(paths, arms_, forces_, kNumCoordinates, &muscle_tau_);
  passive_.assign(kNumCoordinates, 0.0);
  tau_ = muscle_tau_;
  for (int i = 0; i < kNumCoordinates; ++i) {
    if (!Read(i)) continue;
    passive_[i] = PassiveJointTorque(params.coordinates[i].passive, q[i], qd[i]);
    tau_[i] += passive_[i];
  }
  moved_q_ = q;
  moved_qd_ = qd;
  moved_arms_ = arms_;
  moved_forces_ = forces_;
}

std::vector<double> TorquePoint::WithPassiveOf(const ModelParams& other) const {
  std::vector<double> tau = muscle_tau_;
  AddPassiveOf(other, &tau);
  return tau;
}

void TorquePoint::AddPassiveOf(const ModelParams& other, std::vector<double>* tau) const {
  static_assert(std::is_trivially_copyable_v<PassiveJointParams>, "compared bytewise");
  for (int i = 0; i < kNumCoordinates; ++i) {
    if (!Read(i)) continue;
    const PassiveJointParams& mine = params_.coordinates[i].passive;
    const PassiveJointParams& theirs = other.coordinates[i].passive;
    // The same parameters give the same bits (a pure function of them, q and q̇).
    // NOLINTNEXTLINE(bugprone-suspicious-memory-comparison): bytewise on purpose (±0 differ).
    (*tau)[i] += std::memcmp(&mine, &theirs, sizeof mine) == 0
                     ? passive_[i]
                     : PassiveJointTorque(theirs, q_[i], qd_[i]);
  }
}

std::vector<double> TorquePoint::WithMusclesOf(const ModelParams& other,
                                               const std::vector<tendons::MusclePath>& other_paths,
                                               const std::vector<double>& other_gains) const {
  static_assert(std::is_trivially_copyable_v<muscles::HillParams>, "compared bytewise");
  const std::size_t nm = paths_.size();
  if (other_paths.size() != nm || other.muscles.size() != nm) {
    return MuscleAndPassiveTorques(other, other_paths, q_, qd_, a_, other_gains);
  }
  std::vector<double> arms = arms_, forces = forces_;
  for (std::size_t j = 0; j < nm; ++j) {
    const tendons::MusclePath& path = other_paths[j];
    if (path.crossings.size() != paths_[j].crossings.size()) {  // other crossing offsets
      return MuscleAndPassiveTorques(other, other_paths, q_, qd_, a_, other_gains);
    }
    if (!skip_.empty() && skip_[j]) continue;
    const double gain = GainOf(other_gains, j), my_gain = GainOf(gains_, j);
    // NOLINTNEXTLINE(bugprone-suspicious-memory-comparison): bytewise on purpose (±0 differ).
    if (std::memcmp(&other.muscles[j].hill, &params_.muscles[j].hill,
                    sizeof(muscles::HillParams)) == 0 &&
        tendons::SameGeometry(path, paths_[j]) && std::memcmp(&gain, &my_gain, sizeof gain) == 0) {
      continue;
    }
    for (std::size_t i = 0; i < path.crossings.size(); ++i) {
      const auto& c = path.crossings[i];
      arms[first_[j] + i] = tendons::MomentArm(c.arm, q_[c.joint] - c.q_ref_rad);
    }
    forces[j] = MuscleTendonForceAt(other.muscles[j], tendons::MusculotendonLength(path, q_),
                                    tendons::MusculotendonVelocity(path, &arms[first_[j]], qd_),
                                    a_[j], gain)
                    .force_n;
  }
  std::vector<double> tau;
  tendons::JointTorques(other_paths, arms, forces, kNumCoordinates, &tau);
  AddPassiveOf(other, &tau);
  return tau;
}

namespace {

/// The activation or active-force-gain step of TorquePoint::PerMuscleInput's forward differences
/// (TorquePerActivation, TorquePerActiveGain).
constexpr double kMuscleInputStep = 1e-6;

}  // namespace

std::vector<double> TorquePoint::PerMuscleInput(bool gain) const {
  const std::size_t nm = paths_.size();
  // R as tendons::MomentArmMatrix sums it (from 0, crossing by crossing), from the kept arms.
  std::vector<double> out(q_.size() * nm, 0.0);
  for (std::size_t j = 0; j < nm; ++j) {
    const auto& crossings = paths_[j].crossings;
    for (std::size_t i = 0; i < crossings.size(); ++i) {
      out[crossings[i].joint * nm + j] += arms_[first_[j] + i];
    }
  }
  for (std::size_t j = 0; j < nm; ++j) {
    if (!skip_.empty() && skip_[j]) continue;  // its entries are at unread coordinates
    const double g = GainOf(gains_, j);
    const double moved = MuscleTendonForceAt(params_.muscles[j], lengths_[j], velocities_[j],
                                             a_[j] + (gain ? 0.0 : kMuscleInputStep),
                                             g + (gain ? kMuscleInputStep : 0.0))
                             .force_n;
    const double df = (moved - forces_[j]) / kMuscleInputStep;
    for (int c = 0; c < kNumCoordinates; ++c) out[c * nm + j] *= df;
  }
  return out;
}

const std::vector<double>& TorquePoint::WithCoordinate(int coordinate, bool speed,
                                                       double value) const {
  std::vector<double>& q = moved_q_;
  std::vector<double>& qd = moved_qd_;
  (speed ? qd : q)[coordinate] = value;
  for (std::size_t j = 0; j < paths_.size(); ++j) {
    const auto& crossings = paths_[j].crossings;
    bool crosses = false;
    for (std::size_t i = 0; i < crossings.size(); ++i) {
      if (crossings[i].joint != coordinate) continue;
      crosses = true;
      if (!speed) {
        const auto& c = crossings[i];
        moved_arms_[first_[j] + i] = tendons::MomentArm(c.arm, q[c.joint] - c.q_ref_rad);
      }
    }
    if (!crosses) continue;
    const double length = speed ? lengths_[j] : tendons::MusculotendonLength(paths_[j], q);
    moved_forces_[j] =
        MuscleTendonForceAt(params_.muscles[j], length,
                            tendons::MusculotendonVelocity(paths_[j], &moved_arms_[first_[j]], qd),
                            a_[j], GainOf(gains_, j))
            .force_n;
  }
  tendons::JointTorques(paths_, moved_arms_, moved_forces_, kNumCoordinates, &moved_tau_);
  // A joint's passive torque reads its own q and q̇ only: the others' are the point's.
  for (int i = 0; i < kNumCoordinates; ++i) {
    moved_tau_[i] += i == coordinate
                         ? PassiveJointTorque(params_.coordinates[i].passive, q[i], qd[i])
                         : passive_[i];
  }
  // Back to the point for the next call.
  (speed ? qd : q)[coordinate] = (speed ? qd_ : q_)[coordinate];
  for (std::size_t j = 0; j < paths_.size(); ++j) {
    const auto& crossings = paths_[j].crossings;
    for (std::size_t i = 0; i < crossings.size(); ++i) {
      if (crossings[i].joint != coordinate) continue;
      moved_arms_[first_[j] + i] = arms_[first_[j] + i];
      moved_forces_[j] = forces_[j];
    }
  }
  return moved_tau_;
}

std::vector<double> TorquePerActivation(const ModelParams& params,
                                        const std::vector<tendons::MusclePath>& paths,
                                        const std::vector<double>& q, const std::vector<double>& qd,
                                        const std::vector<double>& a,
                                        const std::vector<double>& gains) {
  return TorquePoint(params, paths, q, qd, a, gains).PerMuscleInput(false);
}

std::vector<double> TorquePerActiveGain(const ModelParams& params,
                                        const std::vector<tendons::MusclePath>& paths,
                                        const std::vector<double>& q, const std::vector<double>& qd,
                                        const std::vector<double>& a,
                                        const std::vector<double>& gains) {
  return TorquePoint(params, paths, q, qd, a, gains).PerMuscleInput(true);
}

UpperLimbModel::UpperLimbModel(ModelParams params, ModelBuildOptions options)
    : params_(std::make_shared<const ModelParams>(std::move(params))),
      build_options_(options),
      array_(std::make_shared<const muscles::ArrayMatrix>(BuildElectrodeMatrix(*params_))),
      system_(std::make_unique<SimTK::MultibodySystem>()),
      matter_(std::make_unique<SimTK::SimbodyMatterSubsystem>(*system_)),
      forces_(std::make_unique<SimTK::GeneralForceSubsystem>(*system_)) {
  const ModelParams& p = *params_;
  for (const auto& b : p.bands) {
    if (b.segment < 0 || b.segment >= kNumSegments) throw std::invalid_argument("band segment");
  }
  for (const auto& w : p.weight_compensation) {
    if (w.segment < 0 || w.segment >= kNumSegments) throw std::invalid_argument("cuff segment");
  }
  if (p.mechanisms.tremor.coordinate < 0 || p.mechanisms.tremor.coordinate >= kNumCoordinates) {
    throw std::invalid_argument("tremor coordinate");
  }
  const Vec3 X(1, 0, 0), Y(0, 1, 0), Z(0, 0, 1), O(0, 0, 0);
  const auto& seg = p.segments;
  // Coordinate c's mobilizer: a pin about `axis` at `offset` in the parent (X_PF = pending ·
  // PinFrame, `pending` the welds folded in since the last body) or, welded
  // (ModelBuildOptions::weld_locked), the pin's pose at the locked angle (a pin's X_FM is the
  // rotation by q about the frames' common Z, X_PB = X_PF · X_FM · X_MB). Welds of the chain's
  // ground end are folded into the next mobilizer's inboard frame, so their bodies (whose weight
  // the ground carries) are not in the system at all: their coordinate's and segment's body is
  // then the ground. A weld below a mobile body keeps its body, mass included.
  SimTK::Transform pending;  // identity
  const auto joint = [&](const SimTK::MobilizedBody& parent, int c, const Vec3& axis,
                         const Vec3& offset, const SimTK::Body& body) -> SimTK::MobilizedBody {
    const SimTK::Transform X_PF = pending * PinFrame(axis, offset);
    pending = SimTK::Transform();
    auto& mobile_parent = matter_->updMobilizedBody(parent.getMobilizedBodyIndex());
    if (options.weld_locked && p.coordinates[c].mode == CoordinateMode::kLocked) {
      const SimTK::Transform X_FM(SimTK::Rotation(p.coordinates[c].initial_rad, SimTK::ZAxis));
      if (parent.isGround()) {
        pending = X_PF * X_FM * ~PinFrame(axis, O);
        return parent;
      }
      return SimTK::MobilizedBody::Weld(mobile_parent, X_PF * X_FM, body, PinFrame(axis, O));
    }
    return SimTK::MobilizedBody::Pin(mobile_parent, X_PF, body, PinFrame(axis, O));
  };

  // Shoulder: Y (plane) – −X (elevation) – Y (axial rotation), [Schearer 2014] Y-X-Y sequence.
  SimTK::MobilizedBody plane = joint(matter_->getGround(), kShoulderElvPlane, Y,
                                     ToVec3(p.shoulder_in_ground_m), SimTK::Body::Massless());
  SimTK::MobilizedBody elevation = joint(plane, kShoulderElevation, -X, O, SimTK::Body::Massless());
  SimTK::MobilizedBody humerus =
      joint(elevation, kShoulderRotation, Y, O, RigidBody(seg[kHumerus]));
  SimTK::MobilizedBody forearm = joint(
      humerus, kElbowFlexion, Z, Vec3(0, -seg[kHumerus].length_m, 0), RigidBody(seg[kForearm]));
  SimTK::MobilizedBody radius =
      joint(forearm, kProSup, Y, Vec3(0, -seg[kForearm].length_m, 0), SimTK::Body::Massless());
  SimTK::MobilizedBody carpal = joint(radius, kWristFlexion, X, O, SimTK::Body::Massless());
  SimTK::MobilizedBody hand = joint(carpal, kWristDeviation, Z, O, RigidBody(seg[kHand]));
  SimTK::MobilizedBody proximal =
      joint(hand, kMcpFlexion, X, Vec3(p.index_mcp_offset_m, -seg[kHand].length_m, 0),
            RigidBody(seg[kProximalPhalanx]));
  SimTK::MobilizedBody middle =
      joint(proximal, kPipFlexion, X, Vec3(0, -seg[kProximalPhalanx].length_m, 0),
            RigidBody(seg[kMiddlePhalanx]));
  SimTK::MobilizedBody distal =
      joint(middle, kDipFlexion, X, Vec3(0, -seg[kMiddlePhalanx].length_m, 0),
            RigidBody(seg[kDistalPhalanx]));
  coordinate_bodies_ = {plane.getMobilizedBodyIndex(),   elevation.getMobilizedBodyIndex(),
                        humerus.getMobilizedBodyIndex(), forearm.getMobilizedBodyIndex(),
                        radius.getMobilizedBodyIndex(),  carpal.getMobilizedBodyIndex(),
                        hand.getMobilizedBodyIndex(),    proximal.getMobilizedBodyIndex(),
                        middle.getMobilizedBodyIndex(),  distal.getMobilizedBodyIndex()};
  segment_bodies_ = {humerus.getMobilizedBodyIndex(), forearm.getMobilizedBodyIndex(),
                     hand.getMobilizedBodyIndex(),    proximal.getMobilizedBodyIndex(),
                     middle.getMobilizedBodyIndex(),  distal.getMobilizedBodyIndex()};

  for (int i = 0; i < kNumCoordinates; ++i) {
    if (p.coordinates[i].mode == CoordinateMode::kPrescribed) {
      const auto& c = p.coordinates[i];
      SimTK::Motion::Custom::Implementation* motion =
          c.table.times_s.empty()
              ? static_cast<SimTK::Motion::Custom::Implementation*>(new SineMotion(c.prescription))
              : new TableMotion(c.table);
      SimTK::Motion::Custom(matter_->updMobilizedBody(coordinate_bodies_[i]), motion);
    }
  }

  // Simbody handle idiom: constructing a Force handle adopts the force into *forces_, which owns
  // it from then on; the temporary handle is meant to go (as in Simbody's own examples).
  // NOLINTNEXTLINE(bugprone-unused-raii): Simbody handle idiom, see above.
  SimTK::Force::UniformGravity(*forces_, *matter_, ToVec3(p.gravity_m_s2));
  auto slots = std::make_shared<CoordinateSlots>();
  // NOLINTNEXTLINE(bugprone-unused-raii): Simbody handle idiom, see above.
  SimTK::Force::Custom(*forces_, new PassiveJointForce(slots, params_));
  if (!p.bands.empty() || !p.weight_compensation.empty()) {
    SimTK::Force::Custom(*forces_, new ArmSupportForce(*matter_, segment_bodies_, params_));
  }
  auto* muscle = new MuscleForce(*forces_, slots, params_, array_);
  muscle_force_ = muscle;
  muscle_force_index_ = SimTK::Force::Custom(*forces_, muscle).getForceIndex();
  system_->realizeTopology();
  const State& s = system_->getDefaultState();
  for (int i = 0; i < kNumCoordinates; ++i) {
    const bool welded = CoordinateBody(i).getNumQ(s) == 0;
    slots->q.push_back(welded ? -1 : static_cast<int>(CoordinateBody(i).getFirstQIndex(s)));
    slots->u.push_back(welded ? -1 : static_cast<int>(CoordinateBody(i).getFirstUIndex(s)));
    slots->welded_q.push_back(welded ? p.coordinates[i].initial_rad : 0.0);
  }
  slots_ = slots;
  muscle->FindInertMuscles();
  up_ = UpDirection(p);
  if (std::none_of(p.coordinates.begin(), p.coordinates.end(), [](const CoordinateParams& c) {
        return c.mode == CoordinateMode::kPrescribed;
      })) {
    chain_ = std::make_unique<const ChainDynamics>(ReadChain(s), ToVec3(p.gravity_m_s2));
    for (int k = 0; k < kNumSegments; ++k) {
      segment_chain_.push_back(static_cast<int>(SegmentBody(k).getMobilizedBodyIndex()) - 1);
    }
  }
}

std::vector<ChainBody> UpperLimbModel::ReadChain(const State& s) const {
  // Mobilized body b ≥ 1 is chain body b − 1 (Simbody numbers parents before children). Every
  // mobilizer is a Pin (one q) or a Weld (none); a locked coordinate's pin is held.
  std::vector<bool> held(static_cast<std::size_t>(matter_->getNumBodies()), false);
  for (int i = 0; i < kNumCoordinates; ++i) {
    if (params_->coordinates[i].mode == CoordinateMode::kLocked && !Welded(i)) {
      held[CoordinateBody(i).getMobilizedBodyIndex()] = true;
    }
  }
  std::vector<ChainBody> chain;
  for (int b = 1; b < matter_->getNumBodies(); ++b) {
    const SimTK::MobilizedBody& mobod = matter_->getMobilizedBody(SimTK::MobilizedBodyIndex(b));
    const int nq = mobod.getNumQ(s);
    if (nq > 1 || mobod.getNumU(s) != nq) {
      throw std::logic_error("UpperLimbModel: mobilized body " + std::to_string(b) +
                             " is neither a pin nor a weld");
    }
    ChainBody body;
    body.parent = static_cast<int>(mobod.getParentMobilizedBody().getMobilizedBodyIndex()) - 1;
    body.X_PF = mobod.getDefaultInboardFrame();
    body.X_BM = mobod.getDefaultOutboardFrame();
    const SimTK::MassProperties& mp = mobod.getBody().getDefaultRigidBodyMassProperties();
    body.mass_kg = mp.getMass();
    body.com_m = mp.getMassCenter();
    body.inertia_o = mp.calcInertia().toMat33();
    if (nq == 1) {
      body.q = mobod.getFirstQIndex(s);
      body.u = mobod.getFirstUIndex(s);
      body.held = held[b];
    }
    chain.push_back(body);
  }
  return chain;
}

void UpperLimbModel::CalcYDot(const State& s, RhsWorkspace* ws, double* ydot) const {
  CalcYDot(s, s.getTime(), s.getNY() > 0 ? s.getY().getContiguousScalarData() : nullptr, ws, ydot);
}

void UpperLimbModel::CalcYDot(const State& s, double t, const double* y, RhsWorkspace* ws,
                              double* ydot) const {
  if (!chain_) throw std::logic_error("UpperLimbModel::CalcYDot: a coordinate is prescribed");
  const int nq = s.getNQ(), nu = s.getNU(), nz = s.getNZ();
  const double* q = nq > 0 ? y : nullptr;
  const double* u = nu > 0 ? y + nq : nullptr;
  ChainWorkspace* chain = &ws->chain;
  const bool same_positions =
      ws->positions_of == this && ws->positions_q.size() == static_cast<std::size_t>(nq) &&
      (nq == 0 || std::memcmp(ws->positions_q.data(), q, nq * sizeof(double)) == 0);
  if (!same_positions) {
    chain_->Kinematics(q, chain);
    ForEachSupportForce(
        *params_, up_, [&](int segment) { return segment_chain_[segment] < 0; },
        [&](int segment, const Vec3& p_B) {
          return chain_->StationInGround(*chain, segment_chain_[segment], p_B);
        },
        [&](int segment, const Vec3& p_B, const Vec3& f_G) {
          chain_->ApplyForceAtStation(chain, segment_chain_[segment], p_B, f_G);
        });
    chain_->ArticulatedInertias(chain);
    muscle_force_->Geometry(q, ws, true);
    ws->positions_of = this;
    ws->positions_q.assign(q, q + nq);
  }
  std::fill(ydot, ydot + nq + nu + nz, 0.0);
  double* tau = ydot + nq;  // τ first, then u̇ in its place
  AddPassiveMobilityForces(*slots_, *params_, q, u, t, tau);
  // This element's z block in y and in ẏ.
  const int z_block =
      nq + nu + s.getZStart(forces_->getMySubsystemIndex()) + muscle_force_->ZStart();
  muscle_force_->RightHandSideForces(u, y + z_block, ws);
  for (int i = 0; i < kNumCoordinates; ++i) {
    if (slots_->u[i] >= 0) tau[slots_->u[i]] += ws->muscles.joint_torque_nm[i];
  }
  chain->tau.assign(tau, tau + nu);
  chain_->AccelerationsAtInertias(u, chain->tau.data(), chain, tau);
  for (int b = 0; b < chain_->num_bodies(); ++b) {
    const ChainBody& body = chain_->body(b);
    if (body.q >= 0) ydot[body.q] = body.held ? 0.0 : u[body.u];  // a pin's q̇ = u
  }
  muscle_force_->ZDot(s, y + z_block, ws->muscles.velocity_m_s.data(), ydot + z_block);
}

bool UpperLimbModel::Welded(int coordinate) const { return slots_->q.at(coordinate) < 0; }

int UpperLimbModel::NumWelded() const {
  return static_cast<int>(std::count(slots_->q.begin(), slots_->q.end(), -1));
}

int UpperLimbModel::QIndex(int coordinate) const { return slots_->q.at(coordinate); }
int UpperLimbModel::UIndex(int coordinate) const { return slots_->u.at(coordinate); }

UpperLimbModel::~UpperLimbModel() = default;

State UpperLimbModel::MakeInitialState() const {
  State s = system_->getDefaultState();
  for (int i = 0; i < kNumCoordinates; ++i) {
    const auto& c = params_->coordinates[i];
    if (Welded(i)) continue;
    const auto& mobod = matter_->getMobilizedBody(coordinate_bodies_[i]);
    mobod.setOneQ(s, 0, c.initial_rad);
    mobod.setOneU(s, 0, c.mode == CoordinateMode::kFree ? c.initial_speed_rad_s : 0.0);
    if (c.mode == CoordinateMode::kLocked) mobod.lockAt(s, c.initial_rad, SimTK::Motion::Position);
  }
  system_->realizeModel(s);
  s.setTime(0.0);
  system_->prescribe(s);
  system_->realize(s, SimTK::Stage::Velocity);
  return s;
}

void UpperLimbModel::SetStimulation(State& state, const std::vector<double>& u_us) const {
  if (static_cast<int>(u_us.size()) != num_channels()) {
    throw std::invalid_argument("stimulation has " + std::to_string(u_us.size()) +
                                " channels, model has " + std::to_string(num_channels()));
  }
  Vector& u = muscle_force_->UpdStimulation(state);
  for (int k = 0; k < num_channels(); ++k) u[k] = std::clamp(u_us[k], 0.0, kMaxPulseWidthUs);
  muscle_force_->UpdateIntervalOmega(state);
}

std::vector<double> UpperLimbModel::GetStimulation(const State& state) const {
  const Vector& u = muscle_force_->Stimulation(state);
  std::vector<double> out(u.size());
  for (int k = 0; k < u.size(); ++k) out[k] = u[k];
  return out;
}

double UpperLimbModel::GetQ(const State& state, int coordinate) const {
  if (Welded(coordinate)) return slots_->welded_q[coordinate];
  return CoordinateBody(coordinate).getOneQ(state, 0);
}
std::vector<double> UpperLimbModel::GetQs(const State& s) const { return QsOf(*slots_, s); }
std::vector<double> UpperLimbModel::GetUs(const State& s) const { return UsOf(*slots_, s); }

std::vector<double> UpperLimbModel::RecruitedFractions(const State& s) const {
  const Vector& u = muscle_force_->Stimulation(s);
  std::vector<double> w(num_muscles());
  for (int j = 0; j < num_muscles(); ++j) w[j] = muscle_force_->Recruited(u, j);
  return w;
}

void UpperLimbModel::SetActivationsInClosedForm(State& state, bool closed_form) const {
  muscle_force_->SetClosedFormActivations(state, closed_form);
}

int UpperLimbModel::ActivationYIndex(const State& s) const {
  return s.getNQ() + s.getNU() + s.getZStart(forces_->getMySubsystemIndex()) +
         muscle_force_->ZStart();
}

int UpperLimbModel::FitnessYIndex(const State& s) const {
  const int offset = muscle_force_->FitnessOffset();
  return offset < 0 ? -1 : ActivationYIndex(s) + offset;
}

int UpperLimbModel::PotentiationYIndex(const State& s) const {
  const int offset = muscle_force_->PotentiationOffset();
  return offset < 0 ? -1 : ActivationYIndex(s) + offset;
}

std::vector<double> UpperLimbModel::ActiveForceGains(const State& layout, const double* y) const {
  const int fitness = FitnessYIndex(layout), potentiation = PotentiationYIndex(layout);
  if (fitness < 0 && potentiation < 0) return {};
  std::vector<double> gains(params_->muscles.size());
  for (std::size_t j = 0; j < gains.size(); ++j) {
    const auto i = static_cast<int>(j);
    gains[j] = ActiveForceGain(params_->mechanisms, fitness < 0 ? 1.0 : y[fitness + i],
                               potentiation < 0 ? 0.0 : y[potentiation + i]);
  }
  return gains;
}

std::vector<int> UpperLimbModel::LockedYIndices(const State& s) const {
  std::vector<int> out;
  for (int i = 0; i < kNumCoordinates; ++i) {
    if (params_->coordinates[i].mode != CoordinateMode::kLocked || Welded(i)) continue;
    out.push_back(slots_->q[i]);
    out.push_back(s.getNQ() + slots_->u[i]);
  }
  std::sort(out.begin(), out.end());
  return out;
}

MuscleSnapshot UpperLimbModel::ComputeMuscles(const State& s) const {
  return muscle_force_->Compute(s);
}

double UpperLimbModel::GetQ(const State& /*layout*/, const double* y, int coordinate) const {
  return Welded(coordinate) ? slots_->welded_q[coordinate] : y[slots_->q[coordinate]];
}
std::vector<double> UpperLimbModel::GetQs(const State& /*layout*/, const double* y) const {
  return QsOf(*slots_, y);
}
std::vector<double> UpperLimbModel::GetUs(const State& layout, const double* y) const {
  return UsOf(*slots_, y + layout.getNQ());
}
MuscleSnapshot UpperLimbModel::ComputeMuscles(const State& layout, const double* y) const {
  RhsWorkspace ws;
  ComputeMuscles(layout, y, &ws);
  return std::move(ws.muscles);
}
const MuscleSnapshot& UpperLimbModel::ComputeMuscles(const State& layout, const double* y,
                                                     RhsWorkspace* ws) const {
  const int nq = layout.getNQ(), nu = layout.getNU();
  ws->ForgetPositions();  // Geometry overwrites the lengths and arms CalcYDot keeps
  muscle_force_->Compute(
      y, y + nq,
      y + nq + nu + layout.getZStart(forces_->getMySubsystemIndex()) + muscle_force_->ZStart(), ws);
  return ws->muscles;
}

std::vector<double> UpperLimbModel::MuscleMobilityForces(const State& s) const {
  SimTK::Vector_<SimTK::SpatialVec> body_forces(matter_->getNumBodies(),
                                                SimTK::SpatialVec(Vec3(0), Vec3(0)));
  SimTK::Vector_<Vec3> particle_forces(0);
  Vector mobility(s.getNU(), 0.0);
  forces_->getForce(muscle_force_index_)
      .calcForceContribution(s, body_forces, particle_forces, mobility);
  std::vector<double> out(kNumCoordinates);
  for (int i = 0; i < kNumCoordinates; ++i) out[i] = Welded(i) ? 0.0 : mobility[slots_->u[i]];
  return out;
}

std::vector<double> UpperLimbModel::SensorTorques(const State& s) const {
  if (NumWelded() > 0) {
    throw std::logic_error("SensorTorques: the model welds its locked coordinates (weld_locked)");
  }
  Vector motion_forces;
  matter_->findMotionForces(s, motion_forces);
  std::vector<double> tau(kNumCoordinates, std::nan(""));
  for (int i = 0; i < kNumCoordinates; ++i) {
    const auto& mobod = CoordinateBody(i);
    if (params_->coordinates[i].mode == CoordinateMode::kFree) continue;
    // Simbody's motion forces are the generalised forces the rig adds to hold the motion, with
    // the sign of applied forces moved to the left-hand side (M u̇ = τ_applied − τ_motion): a held
    // joint reads +τ_motion = what the limb pushes against the sensor.
    tau[i] = motion_forces[mobod.getFirstUIndex(s)];
  }
  return tau;
}

const SimTK::MobilizedBody& UpperLimbModel::CoordinateBody(int coordinate) const {
  return matter_->getMobilizedBody(coordinate_bodies_.at(coordinate));
}

const SimTK::MobilizedBody& UpperLimbModel::SegmentBody(int segment) const {
  return matter_->getMobilizedBody(segment_bodies_.at(segment));
}

double UpperLimbModel::MechanicalEnergy(const State& s) const { return system_->calcEnergy(s); }

}  // namespace fesim::sim
