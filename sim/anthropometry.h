// Segment inertial parameters scaled by body height and mass.
//
// Sources (published tables, cited per value in anthropometry.cc):
//  - segment lengths: Winter, Biomechanics and Motor Control of Human Movement, 4th ed. 2009,
//    Fig. 4.1 (Drillis & Contini): upper arm 0.186 H, forearm 0.146 H, hand 0.108 H;
//  - masses, centres of mass, radii of gyration of upper arm and forearm: de Leva 1996,
//    J Biomech 29(9):1223, Table 4 (males);
//  - hand: Winter 2009 Table 4.1 (mass 0.006 M, COM 0.506 of wrist–knuckle length, radius of
//    gyration 0.297 about the COM);
//  - index phalanx lengths: Buchholz, Armstrong & Goldstein 1992, J Biomech 25(2):149, Table 1
//    (proximal 0.245, middle 0.143, distal 0.097 of hand length).
// Assumed (no table): phalanges are uniform solid cylinders of density 1100 kg/m³ with radii 9, 8,
// 7 mm scaled by H / 1.75 m; their mass is taken out of the hand's; the palm (wrist to index MCP)
// is 0.463 of hand length, the remainder of the phalanx chain.
#pragma once

#include <array>

#include "sim/model_params.h"

namespace fesim::sim {

/// Segment parameters for a participant of the given height (m, 1.2–2.2) and mass (kg, 30–150).
/// Throws std::invalid_argument outside those ranges.
std::array<SegmentParams, kNumSegments> ScaledSegments(double height_m, double mass_kg);

}  // namespace fesim::sim
