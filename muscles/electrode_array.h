// Electrode array A ([Hand Hammerstein] eq. 1): v = A u maps the n stimulation
// channels (pulse width, µs) to the effective stimulation v of the l muscles (µs).
//
// A is given explicitly or derived from geometry: pads and motor points are located on the
// unrolled skin surface of the forearm (coordinate s along the forearm from the elbow, m, and c
// around its circumference, m). A channel drives a set of pads; a pad at distance d from a
// muscle's motor point reaches it with the weight exp(−d² / (2σ²)) (isotropic Gaussian current
// spread, σ the spread length). This spread model is fesim's assumption; [Hand Hammerstein] treats
// A as an identified matrix.
#pragma once

#include <string>
#include <vector>

namespace fesim::muscles {

/// A point on the unrolled forearm surface.
struct SkinPoint {
  double along_m = 0.0;   ///< s, distance from the elbow crease along the forearm, m.
  double around_m = 0.0;  ///< c, arc length around the forearm from its anterior midline, m.
};

/// Geometry of an array: pad centres, which pads each channel drives, motor points.
struct ArrayGeometry {
  std::vector<SkinPoint> pads;                 ///< pad centres.
  std::vector<std::vector<int>> channel_pads;  ///< channel k drives pads channel_pads[k].
  std::vector<SkinPoint> motor_points;         ///< one per muscle (row of A).
  double spread_m = 0.01;                      ///< σ, m, > 0.
  double gain = 1.0;                           ///< weight at zero distance, ≥ 0.
};

/// A dense l × n matrix, row-major: A[j * n + k] is channel k's weight on muscle j.
struct ArrayMatrix {
  int muscles = 0;   ///< l
  int channels = 0;  ///< n
  std::vector<double> a;
  double operator()(int j, int k) const { return a[static_cast<std::size_t>(j) * channels + k]; }
};

/// A from geometry as described above. Throws std::invalid_argument on a pad index out of range.
ArrayMatrix ArrayFromGeometry(const ArrayGeometry& g);

/// A regular rows × cols grid of pads (pitch in m) with its first pad at `origin`; rows run
/// along the forearm, columns around it. Pad index = row * cols + col.
std::vector<SkinPoint> PadGrid(int rows, int cols, double pitch_m, SkinPoint origin);

/// v = A u (µs). Sizes are checked (std::invalid_argument).
std::vector<double> ApplyArray(const ArrayMatrix& a, const std::vector<double>& u_us);

}  // namespace fesim::muscles
