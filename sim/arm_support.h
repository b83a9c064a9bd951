// Mobile arm support / exoskeleton (PRODUCT.md "Arm support"; [Schearer 2014] §II uses rubber bands
// on a mobile arm support). Two mechanisms, each applied at a cuff point on a segment:
//   elastic band:  F = k (L − L_s) · û  when L > L_s, else 0     (slack band; û points from the
//                  cuff to the anchor, L = |p_anchor − p_cuff|). Potential ½ k (L − L_s)² for L >
//                  L_s.
//   weight compensation: a constant force of magnitude F_w opposite to gravity at the cuff.
// Units: m, N, N/m. Positions and forces in the ground frame G.
#pragma once

#include <array>

namespace fesim::sim {

using Vec3d = std::array<double, 3>;

/// One elastic band from a fixed anchor to a cuff on a segment.
struct BandParams {
  int segment = 0;                 ///< which segment the cuff is on (see UpperLimbModel).
  Vec3d cuff_in_segment_m{};       ///< cuff point in the segment frame, m.
  Vec3d anchor_in_ground_m{};      ///< anchor point in G, m.
  double stiffness_n_per_m = 0.0;  ///< k, N/m, ≥ 0.
  double slack_length_m = 0.0;     ///< L_s, m, ≥ 0.
};

/// A constant anti-gravity force at a cuff.
struct WeightCompensationParams {
  int segment = 0;
  Vec3d cuff_in_segment_m{};
  double force_n = 0.0;  ///< F_w, N, ≥ 0.
};

/// Band force on the cuff (N, in G) for cuff and anchor positions in G.
Vec3d BandForce(const BandParams& band, const Vec3d& p_cuff_m);
/// Band potential energy, J.
double BandPotential(const BandParams& band, const Vec3d& p_cuff_m);

}  // namespace fesim::sim
