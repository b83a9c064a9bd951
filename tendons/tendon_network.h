// Tendon network R(y) ([Hand Hammerstein] eq. 8): rows = joints, columns = muscles,
// R_ij = r_ij(q_j) = −∂l_MT,j/∂q_i, and the musculotendon lengths consistent with it:
//
//   l_MT,m(q) = l_ref,m + Σ_i Δl(q_i − q_ref,i)   (Δl from landsmeer.h)
//
// q_ref is the posture at which eq. (9)/(10) has its zero (the joint's anatomical zero unless the
// muscle says otherwise) and l_ref the length there. Each muscle crosses a few joints; each
// crossing has its own moment-arm model.
#pragma once

#include <string>
#include <vector>

#include "tendons/landsmeer.h"

namespace fesim::tendons {

/// One muscle crossing one joint.
struct Crossing {
  int joint = 0;           ///< index of the joint coordinate q_i.
  MomentArmParams arm;     ///< r(q) model, sign r = −∂l/∂q.
  double q_ref_rad = 0.0;  ///< angle at which eq. (10)'s argument is zero, rad.
};

/// Path of one musculotendon unit.
struct MusclePath {
  std::string name;
  double length_at_ref_m = 0.3;  ///< l_ref: l_MT with every crossed joint at q_ref, m, > 0.
  std::vector<Crossing> crossings;
};

/// Whether `a` and `b` give the same l_MT(q), its velocity and moment arms for every q: the same
/// l_ref and crossings (joint, q_ref, r(q) model and d, d̃), compared with == (the name is not
/// geometry).
bool SameGeometry(const MusclePath& a, const MusclePath& b);

/// l_MT(q), m. `q` holds every joint coordinate (rad).
double MusculotendonLength(const MusclePath& path, const std::vector<double>& q);

/// dl_MT/dt = −Σ_i r_i(q) q̇_i, m/s.
double MusculotendonVelocity(const MusclePath& path, const std::vector<double>& q,
                             const std::vector<double>& qdot);

/// R(q) as a row-major joints × muscles matrix (m): R[i * n_muscles + m].
std::vector<double> MomentArmMatrix(const std::vector<MusclePath>& paths,
                                    const std::vector<double>& q);

/// Joint torques τ = R(q) f (N·m), one per joint, for tendon forces f (N).
std::vector<double> JointTorques(const std::vector<MusclePath>& paths, const std::vector<double>& q,
                                 const std::vector<double>& f);

/// The moment arm r(q) of every crossing, path after path in `crossings` order (m): one
/// evaluation each, for the overloads below, which give the same bits as the functions above
/// (the force element evaluates each arm once per right-hand side, not once per use).
std::vector<double> CrossingMomentArms(const std::vector<MusclePath>& paths,
                                       const std::vector<double>& q);
/// The same into `arms` (resized; its capacity is reused between calls). With `skip` ([path],
/// non-empty), the crossings of a skipped path are not evaluated: their entries keep what they
/// held (0 when `arms` grows).
void CrossingMomentArms(const std::vector<MusclePath>& paths, const std::vector<double>& q,
                        std::vector<double>* arms, const std::vector<char>& skip = {});

/// dl_MT/dt = −Σ_i r_i q̇_i, m/s, with `arms` the path's crossings' r (from CrossingMomentArms,
/// pointing at the path's first crossing). Joint indices as checked by CrossingMomentArms.
double MusculotendonVelocity(const MusclePath& path, const double* arms,
                             const std::vector<double>& qdot);

/// τ = R f (N·m), `num_joints` of them, with `arms` = CrossingMomentArms(paths, q).
std::vector<double> JointTorques(const std::vector<MusclePath>& paths,
                                 const std::vector<double>& arms, const std::vector<double>& f,
                                 std::size_t num_joints);
/// The same into `tau` (resized to num_joints; its capacity is reused between calls).
void JointTorques(const std::vector<MusclePath>& paths, const std::vector<double>& arms,
                  const std::vector<double>& f, std::size_t num_joints, std::vector<double>* tau);

}  // namespace fesim::tendons
