#include "foreign/joint.h"

#include <cmath>
#include <string>

#include "foreign/check.h"

namespace fesim::foreign {

void ValidateJoint(const JointParams& joint, const char* prefix) {
  const std::string p = std::string(prefix) + ".";
  CheckRange(joint.rest_angle_rad, -1.5, 1.5, p + "rest_angle_rad");
  CheckRange(joint.flexion_stiffness_nm_per_rad, 0.0, 100.0, p + "flexion_stiffness_nm_per_rad");
  CheckAbove(joint.flexion_stiffening_per_rad, 0.0, 20.0, p + "flexion_stiffening_per_rad");
  CheckRange(joint.extension_stiffness_nm_per_rad, 0.0, 100.0,
             p + "extension_stiffness_nm_per_rad");
  CheckAbove(joint.extension_stiffening_per_rad, 0.0, 20.0, p + "extension_stiffening_per_rad");
  CheckRange(joint.damping_nm_s_per_rad, 0.0, 100.0, p + "damping_nm_s_per_rad");
}

double ElasticMoment(const JointParams& j, double q_rad) {
  const double d = q_rad - j.rest_angle_rad;
  const double kf = j.flexion_stiffness_nm_per_rad, af = j.flexion_stiffening_per_rad;
  const double ke = j.extension_stiffness_nm_per_rad, ae = j.extension_stiffening_per_rad;
  return -(kf / af) * std::expm1(af * d) + (ke / ae) * std::expm1(-ae * d);
}

double ElasticStiffness(const JointParams& j, double q_rad) {
  const double d = q_rad - j.rest_angle_rad;
  return j.flexion_stiffness_nm_per_rad * std::exp(j.flexion_stiffening_per_rad * d) +
         j.extension_stiffness_nm_per_rad * std::exp(-j.extension_stiffening_per_rad * d);
}

double ElasticEnergy(const JointParams& j, double q_rad) {
  const double d = q_rad - j.rest_angle_rad;
  const double kf = j.flexion_stiffness_nm_per_rad, af = j.flexion_stiffening_per_rad;
  const double ke = j.extension_stiffness_nm_per_rad, ae = j.extension_stiffening_per_rad;
  return (kf / (af * af)) * (std::expm1(af * d) - af * d) +
         (ke / (ae * ae)) * (std::expm1(-ae * d) + ae * d);
}

double DampingMoment(const JointParams& joint, double qd_rad_s) {
  return -joint.damping_nm_s_per_rad * qd_rad_s;
}

}  // namespace fesim::foreign
