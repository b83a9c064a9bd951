// Hill-type muscle H_hill ([Hand Hammerstein] eq. 4 and 7) with a rigid tendon.
//
// Tendon force  F = F_max (a · f_L(l̃) · f_V(ṽ) + f_PE(l̃)) cos φ
//   l̃ = l_f / l_opt (normalised fibre length), ṽ = v_f / (v_max l_opt) (negative = shortening),
//   φ the pennation angle.
// Curves (Thelen 2003, J Biomech Eng 125:70, eq. 3–4 and the Hill hyperbola of its eq. 6):
//   f_L(l̃) = exp(−(l̃ − 1)² / γ_L),                                  γ_L = 0.45
//   f_PE(l̃) = (exp(k_PE (l̃ − 1)/ε₀) − 1) / (exp(k_PE) − 1) for l̃ > 1, else 0,   k_PE = 4, ε₀ = 0.6
//   f_V(ṽ) = (1 + ṽ)/(1 − ṽ/A_f) for −1 < ṽ ≤ 0 (0 for ṽ ≤ −1),         A_f = 0.25
//   f_V(ṽ) = (f_ecc ṽ + c)/(ṽ + c) for ṽ > 0, f_ecc = 1.8, c = (f_ecc − 1)/(1 + 1/A_f)
// The eccentric branch departs from Thelen's: c is chosen so f_V is C¹ at ṽ = 0.
// Rigid tendon and constant-height pennation: l_f cos φ = l_MT − l_ts, l_f sin φ = l_opt sin φ₀,
// hence the fibre velocity v_f = v_MT cos φ. This is [Hand Hammerstein]'s "fibre length follows
// from musculotendon length".
#pragma once

namespace fesim::muscles {

/// Architecture of one muscle (Holzbaur et al. 2005 notation).
struct HillParams {
  double max_isometric_force_n = 100.0;    ///< F_max, N, > 0.
  double optimal_fibre_length_m = 0.1;     ///< l_opt, m, > 0.
  double tendon_slack_length_m = 0.2;      ///< l_ts, m, ≥ 0.
  double pennation_at_optimal_rad = 0.0;   ///< φ₀, rad, [0, π/3].
  double max_contraction_velocity = 10.0;  ///< v_max, optimal fibre lengths per s, > 0.
};

/// Fibre kinematics derived from the musculotendon path.
struct FibreKinematics {
  double length_m = 0.0;       ///< l_f, m.
  double velocity_m_s = 0.0;   ///< v_f, m/s (negative = shortening).
  double cos_pennation = 1.0;  ///< cos φ.
  bool clamped = false;        ///< true when l_MT − l_ts was below its minimum (see below).
};

/// Hill curves, dimensionless, of the normalised fibre length l = l_f / l_opt and the normalised
/// fibre velocity v = v_f / v_max.
double ActiveForceLength(double l);
double PassiveForceLength(double l);
double ForceVelocity(double v);

/// Fibre length, velocity and pennation from musculotendon length l_mt_m (m) and its rate
/// v_mt_m_s (m/s). The along-tendon fibre projection l_MT − l_ts is kept ≥ 0.05 l_opt (flagged
/// with `clamped`) so the geometry stays defined.
FibreKinematics FibreFromMusculotendon(const HillParams& p, double l_mt_m, double v_mt_m_s);

/// Tendon force F (N, ≥ 0) at activation a (0–1) and the given fibre kinematics. `active_gain`
/// (≥ 0) scales the active part only: fatigue (fitness φ) and potentiation (1 + g p).
double HillTendonForce(const HillParams& p, double activation, const FibreKinematics& fibre,
                       double active_gain = 1.0);

/// Musculotendon length (m) at which the fibre is at optimal length: l_ts + l_opt cos φ₀.
double OptimalMusculotendonLength(const HillParams& p);

}  // namespace fesim::muscles
