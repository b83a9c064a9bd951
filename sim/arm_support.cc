#include "sim/arm_support.h"

#include <cmath>

namespace fesim::sim {
namespace {

double Stretch(const BandParams& band, const Vec3d& p, Vec3d* unit) {
  Vec3d d{band.anchor_in_ground_m[0] - p[0], band.anchor_in_ground_m[1] - p[1],
          band.anchor_in_ground_m[2] - p[2]};
  const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  if (unit != nullptr) {
    for (int i = 0; i < 3; ++i) (*unit)[i] = len > 0.0 ? d[i] / len : 0.0;
  }
  return len - band.slack_length_m;
}

}  // namespace

Vec3d BandForce(const BandParams& band, const Vec3d& p_cuff_m) {
  Vec3d u{};
  const double s = Stretch(band, p_cuff_m, &u);
  if (s <= 0.0) return {0.0, 0.0, 0.0};
  const double f = band.stiffness_n_per_m * s;
  return {f * u[0], f * u[1], f * u[2]};
}

double BandPotential(const BandParams& band, const Vec3d& p_cuff_m) {
  const double s = Stretch(band, p_cuff_m, nullptr);
  return s > 0.0 ? 0.5 * band.stiffness_n_per_m * s * s : 0.0;
}

}  // namespace fesim::sim
