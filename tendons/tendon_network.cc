#include "tendons/tendon_network.h"

#include <stdexcept>

namespace fesim::tendons {
namespace {

void CheckJoint(const MusclePath& path, const Crossing& c, std::size_t n) {
  if (c.joint < 0 || static_cast<std::size_t>(c.joint) >= n) {
    throw std::invalid_argument("muscle " + path.name + " crosses joint index " +
                                std::to_string(c.joint) + ", have " + std::to_string(n));
  }
}

}  // namespace

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

}  // namespace fesim::tendons
