#include "muscles/electrode_array.h"

#include <cmath>
#include <stdexcept>

namespace fesim::muscles {

ArrayMatrix ArrayFromGeometry(const ArrayGeometry& g) {
  ArrayMatrix m;
  m.muscles = static_cast<int>(g.motor_points.size());
  m.channels = static_cast<int>(g.channel_pads.size());
  m.a.assign(static_cast<std::size_t>(m.muscles) * m.channels, 0.0);
  const double two_s2 = 2.0 * g.spread_m * g.spread_m;
  for (int k = 0; k < m.channels; ++k) {
    for (int pad : g.channel_pads[k]) {
      if (pad < 0 || pad >= static_cast<int>(g.pads.size())) {
        throw std::invalid_argument("electrode channel " + std::to_string(k) + " names pad " +
                                    std::to_string(pad) + ", allowed 0.." +
                                    std::to_string(g.pads.size() - 1));
      }
      for (int j = 0; j < m.muscles; ++j) {
        const double ds = g.pads[pad].along_m - g.motor_points[j].along_m;
        const double dc = g.pads[pad].around_m - g.motor_points[j].around_m;
        m.a[static_cast<std::size_t>(j) * m.channels + k] +=
            g.gain * std::exp(-(ds * ds + dc * dc) / two_s2);
      }
    }
  }
  return m;
}

std::vector<SkinPoint> PadGrid(int rows, int cols, double pitch_m, SkinPoint origin) {
  std::vector<SkinPoint> pads;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      pads.push_back({origin.along_m + r * pitch_m, origin.around_m + c * pitch_m});
    }
  }
  return pads;
}

std::vector<double> ApplyArray(const ArrayMatrix& a, const std::vector<double>& u_us) {
  if (static_cast<int>(u_us.size()) != a.channels) {
    throw std::invalid_argument("electrode array: " + std::to_string(u_us.size()) + " inputs for " +
                                std::to_string(a.channels) + " channels");
  }
  std::vector<double> v(a.muscles, 0.0);
  for (int j = 0; j < a.muscles; ++j) {
    for (int k = 0; k < a.channels; ++k) v[j] += a(j, k) * u_us[k];
  }
  return v;
}

}  // namespace fesim::muscles
