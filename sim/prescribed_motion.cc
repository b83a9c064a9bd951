#include "sim/prescribed_motion.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace fesim::sim {

QuinticHermiteSpline::QuinticHermiteSpline(const TablePrescription& table) {
  const std::size_t n = table.times_s.size();
  if (table.q_rad.size() != n || table.qd_rad_s.size() != n || table.qdd_rad_s2.size() != n) {
    throw std::invalid_argument(
        "TablePrescription: times_s, q_rad, qd_rad_s, qdd_rad_s2 differ "
        "in length");
  }
  if (n < 2) throw std::invalid_argument("TablePrescription: needs at least 2 samples");
  for (std::size_t k = 0; k < n; ++k) {
    if (!std::isfinite(table.times_s[k]) || !std::isfinite(table.q_rad[k]) ||
        !std::isfinite(table.qd_rad_s[k]) || !std::isfinite(table.qdd_rad_s2[k])) {
      throw std::invalid_argument("TablePrescription: sample " + std::to_string(k) +
                                  " is not finite");
    }
    if (k > 0 && !(table.times_s[k] > table.times_s[k - 1])) {
      throw std::invalid_argument("TablePrescription.times_s not strictly increasing at " +
                                  std::to_string(k));
    }
  }
  t_ = table.times_s;
  c_.resize(n - 1);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const double h = t_[k + 1] - t_[k];
    const double d = table.q_rad[k + 1] - table.q_rad[k];
    const double v0 = h * table.qd_rad_s[k], v1 = h * table.qd_rad_s[k + 1];
    const double a0 = h * h * table.qdd_rad_s2[k], a1 = h * h * table.qdd_rad_s2[k + 1];
    c_[k] = {table.q_rad[k],
             v0,
             0.5 * a0,
             10.0 * d - 6.0 * v0 - 4.0 * v1 - 0.5 * (3.0 * a0 - a1),
             -15.0 * d + 8.0 * v0 + 7.0 * v1 + 0.5 * (3.0 * a0 - 2.0 * a1),
             6.0 * d - 3.0 * v0 - 3.0 * v1 - 0.5 * (a0 - a1)};
  }
  first_ = {table.q_rad.front(), 0.0, 0.0};
  last_ = {table.q_rad.back(), 0.0, 0.0};
}

PrescribedSample QuinticHermiteSpline::Evaluate(double t_s) const {
  if (t_s < t_.front()) return first_;
  if (t_s > t_.back()) return last_;
  std::size_t k =
      static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), t_s) - t_.begin());
  k = std::min(k == 0 ? 0 : k - 1, c_.size() - 1);
  const double h = t_[k + 1] - t_[k];
  const double s = (t_s - t_[k]) / h;
  const auto& c = c_[k];
  PrescribedSample out;
  out.q = c[0] + s * (c[1] + s * (c[2] + s * (c[3] + s * (c[4] + s * c[5]))));
  out.qd = (c[1] + s * (2 * c[2] + s * (3 * c[3] + s * (4 * c[4] + s * 5 * c[5])))) / h;
  out.qdd = (2 * c[2] + s * (6 * c[3] + s * (12 * c[4] + s * 20 * c[5]))) / (h * h);
  return out;
}

}  // namespace fesim::sim
