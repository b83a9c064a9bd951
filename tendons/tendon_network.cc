#include "tendons/tendon_network.h"

#include <stdexcept>

namespace fesim::tendons {
namespace {

[[noreturn]] __attribute__((noinline, cold)) void ThrowBadJoint(const MusclePath& path,
                                                                const Crossing& c, std::size_t n) {
  throw std::invalid_argument("muscle " + path.name + " crosses joint index " +
                              std::to_string(c.joint) + ", have " + std::to_string(n));
}

/// The comparison inlined and the message built out of line: it runs for every crossing of
/// every right-hand side.
inline void CheckJoint(const MusclePath& path, const Crossing& c, std::size_t n) {
  if (c.joint < 0 || static_cast<std::size_t>(c.joint) >= n) ThrowBadJoint(path, c, n);
}

}  // namespace

bool SameGeometry(const MusclePath& a, const MusclePath& b) {
  if (a.length_at_ref_m != b.length_at_ref_m || a.crossings.size() != b.crossings.size()) {
    return false;
  }
  for (std::size_t i = 0; i < a.crossings.size(); ++i) {
    const Crossing& ca = a.crossings[i];
    const Crossing& cb = b.crossings[i];
    if (ca.joint != cb.joint || ca.q_ref_rad != cb.q_ref_rad || ca.arm.model != cb.arm.model ||
        ca.arm.d_m != cb.arm.d_m || ca.arm.d_tilde_m != cb.arm.d_tilde_m) {
      return false;
    }
  }
  return true;
}

double MusculotendonLength(const MusclePath& path, const std::vector<double>& q) {
  double l = path.length_at_ref_m;
  for (const auto& c : path.crossings) {
    CheckJoint(path, c, q.size());
    l += LengthChange(c.arm, q[c.joint] - c.q_ref_rad);
  }
  return l;
}

double MusculotendonVelocity(const MusclePath& path, const std::vector<double>& q,
                             const std::vector<double>& qdot) {
  double v = 0.0;
  for (const auto& c : path.crossings) {
    CheckJoint(path, c, q.size());
    v -= MomentArm(c.arm, q[c.joint] - c.q_ref_rad) * qdot[c.joint];
  }
  return v;
}

std::vector<double> MomentArmMatrix(const std::vector<MusclePath>& paths,
                                    const std::vector<double>& q) {
  const std::size_t nm = paths.size();
  std::vector<double> r(q.size() * nm, 0.0);
  for (std::size_t m = 0; m < nm; ++m) {
    for (const auto& c : paths[m].crossings) {
      CheckJoint(paths[m], c, q.size());
      r[c.joint * nm + m] += MomentArm(c.arm, q[c.joint] - c.q_ref_rad);
    }
  }
  return r;
}

std::vector<double> JointTorques(const std::vector<MusclePath>& paths, const std::vector<double>& q,
                                 const std::vector<double>& f) {
  if (f.size() != paths.size()) throw std::invalid_argument("JointTorques: force count mismatch");
  std::vector<double> tau(q.size(), 0.0);
  for (std::size_t m = 0; m < paths.size(); ++m) {
    for (const auto& c : paths[m].crossings) {
      CheckJoint(paths[m], c, q.size());
      tau[c.joint] += MomentArm(c.arm, q[c.joint] - c.q_ref_rad) * f[m];
    }
  }
  return tau;
}

std::vector<double> CrossingMomentArms(const std::vector<MusclePath>& paths,
                                       const std::vector<double>& q) {
  std::vector<double> arms;
  CrossingMomentArms(paths, q, &arms);
  return arms;
}

void CrossingMomentArms(const std::vector<MusclePath>& paths, const std::vector<double>& q,
                        std::vector<double>* arms, const std::vector<char>& skip) {
  if (!skip.empty() && skip.size() != paths.size()) {
    throw std::invalid_argument("CrossingMomentArms: skip mask size mismatch");
  }
  std::size_t crossings = 0;
  for (const auto& path : paths) crossings += path.crossings.size();
  arms->resize(crossings);
  std::size_t k = 0;
  for (std::size_t m = 0; m < paths.size(); ++m) {
    const MusclePath& path = paths[m];
    for (const auto& c : path.crossings) {
      CheckJoint(path, c, q.size());
      if (skip.empty() || !skip[m]) (*arms)[k] = MomentArm(c.arm, q[c.joint] - c.q_ref_rad);
      ++k;
    }
  }
}

double MusculotendonVelocity(const MusclePath& path, const double* arms,
                             const std::vector<double>& qdot) {
  double v = 0.0;
  for (std::size_t k = 0; k < path.crossings.size(); ++k) {
    v -= arms[k] * qdot[path.crossings[k].joint];
  }
  return v;
}

std::vector<double> JointTorques(const std::vector<MusclePath>& paths,
                                 const std::vector<double>& arms, const std::vector<double>& f,
                                 std::size_t num_joints) {
  std::vector<double> tau;
  JointTorques(paths, arms, f, num_joints, &tau);
  return tau;
}

void JointTorques(const std::vector<MusclePath>& paths, const std::vector<double>& arms,
                  const std::vector<double>& f, std::size_t num_joints, std::vector<double>* tau) {
  if (f.size() != paths.size()) throw std::invalid_argument("JointTorques: force count mismatch");
  std::size_t crossings = 0;
  for (const auto& path : paths) crossings += path.crossings.size();
  if (arms.size() != crossings) {
    throw std::invalid_argument("JointTorques: moment arm count mismatch");
  }
  tau->assign(num_joints, 0.0);
  std::size_t k = 0;
  for (std::size_t m = 0; m < paths.size(); ++m) {
    for (const auto& c : paths[m].crossings) (*tau)[c.joint] += arms[k++] * f[m];
  }
}

}  // namespace fesim::tendons
