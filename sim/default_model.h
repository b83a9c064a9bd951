// The default virtual participant: 14 muscles with literature architecture, Landsmeer paths,
// passive joints, a 4×6 forearm electrode array and single electrode pairs.
//
// Muscle architecture (F_max, l_opt, l_ts, φ₀): Holzbaur, Murray & Delp 2005, Ann Biomed Eng
// 33(6):829, Table 2 (MoBL upper-limb model); index-finger compartments EDC-I, FDS-I, FDP-I from
// the same table. Moment arms (m, at the stated posture): wrist from Gonzalez et al. 1997
// (J Biomech 30:705) as used by Holzbaur 2005; elbow flexors from Murray, Delp & Buchanan 1995
// (J Biomech 28:513) expressed with eq. (10) of [Hand Hammerstein] so that r grows with flexion;
// finger flexors with eq. (10), extensors with eq. (9) (Brook et al. 1995). Values are rounded
// literature figures; the shoulder moment arms of the deltoids and the biarticular heads are
// assumed (order of magnitude from Holzbaur 2005 Fig. 4).
// Passive joint coefficients: [Schearer 2014] Table I (non-SCI subject) for
// elevation plane, elevation and elbow; wrist and finger values assumed from the ranges reported
// by Formica et al. 2012 (wrist ≈ 1 N·m/rad) and Kamper et al. 2002 (MCP).
// Recruitment (eq. 3) and activation frequency Ω_i (eq. 6) are assumed within [Hand Hammerstein]'s
// identification bounds (Ω ∈ [0, 10] rad/s, u_db ∈ [20, 280] µs, u_sat ∈ [42, 600] µs).
// Muscle fibres are at optimal length at the rest posture (assumption; see
// CalibrateReferenceLengths).
#pragma once

#include "sim/model_params.h"

namespace fesim::sim {

/// The default participant of the given height (m) and mass (kg): segments from anthropometry,
/// passive joints, 14 muscles, electrode array with two channels (extensor and flexor pad groups)
/// plus four electrode pairs (biceps, triceps, anterior and posterior deltoid). All coordinates
/// free, no arm support, rest posture as initial posture.
ModelParams DefaultModelParams(double height_m = 1.75, double mass_kg = 75.0);

/// Sets each muscle's l_MT at the reference posture so that its fibre is at optimal length at the
/// rest posture (every coordinate at its passive rest angle).
void CalibrateReferenceLengths(ModelParams* model);

/// Names of the 14 default muscles, in order.
const std::vector<std::string>& DefaultMuscleNames();

}  // namespace fesim::sim
