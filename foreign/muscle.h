// Muscles of the foreign simulator: geometry, recruitment, activation and contraction, each a pure
// function of its parameters. Forms deliberately differ from fesim's (foreign/simulate.h).
//
// Geometry (per crossing j ∈ {wrist, MCP, PIP, DIP}, anatomical joint angle θ_j, rad):
//   r_j(θ) = r0 + r1 θ + r2 θ²                               moment arm, m (assumed polynomial),
//   l_MT(θ) = l_MT0 − Σ_j (r0 θ_j + r1 θ_j²/2 + r2 θ_j³/3)     musculotendon length, m,
// so that r_j = −∂l_MT/∂θ_j exactly: a muscle with r > 0 shortens as the joint flexes (flexor).
// With θ_DIP = c·q3 (foreign/body.h) the generalised moment arms are
//   ρ = (r_wrist(q1), r_MCP(q2), r_PIP(q3) + c·r_DIP(c q3)) = −∂l_MT/∂q,
// and the muscle's generalised force is ρ·F. Fibre length l_M = l_MT − l_TS (rigid tendon, no
// pennation); fibre velocity v_M = dl_MT/dt = −ρ·q̇ (positive when lengthening).
//
// Recruitment (threshold–saturation curve of Durfee & MacLean 1989, IEEE Trans Biomed Eng 36(7);
// the cubic smoothstep between the two points is our assumed interpolant):
//   x = clamp((u − u_th)/(u_sat − u_th), 0, 1),  w(u) = w_max · x²(3 − 2x),   u pulse width, µs.
//
// Activation: two first-order stages, excitation–contraction coupling e then force state a,
//   ė = (w − e)/τ_e,  ȧ = (e − a)/τ_a,  τ = τ_act when the input exceeds the state, else τ_deact
// (activation faster than deactivation: Zajac 1989, Crit Rev Biomed Eng 17(4); Thelen 2003,
// J Biomech Eng 125(1)); the FES time constants are slower than the voluntary ones (assumed).
//
// Contraction: F = F_max·(capacity·a·f_L(l̃)·f_V(ṽ)) + F_pe(l̃), l̃ = l_M/l_opt,
// ṽ = v_M/(v_max·l_opt):
//   f_L = max(0, 1 − ((l̃ − 1)/W)²)    parabola, W = 0.56 (van Soest & Bobbert 1993, Biol Cybern
//   69), f_V = (1 − x)/(1 + x/k), x = −ṽ ≥ 0     Hill 1938 (Proc R Soc B 126) hyperbola, k = a/F0 =
//   0.25,
//         clipped at 0 beyond x = 1;
//   f_V = f_e − (f_e − 1)·β/(β + ṽ), ṽ ≥ 0, β = (f_e − 1)k/(1 + k)   lengthening, plateau f_e = 1.8
//         (Katz 1939, J Physiol 96), β chosen so that f_V is C¹ at ṽ = 0;
//   F_pe = F_max·k_pe·(l̃ − 1)² for l̃ > 1, else 0         passive fibre force (assumed quadratic),
//   V_pe = F_max·k_pe·l_opt·(l̃ − 1)³/3 for l̃ > 1           its elastic energy, J;
//   v_max = 10 l_opt/s (Zajac 1989).
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>

namespace fesim::foreign {

constexpr int kNumMuscles = 7;
/// Muscle order everywhere (arrays, W rows, trial columns a.<name>).
enum MuscleId { kEcr = 0, kEcu, kEdc, kFcr, kFcu, kFds, kFdp };
/// ECR lumps ECRL and ECRB; EDC, FDS and FDP are the index slips.
constexpr std::array<const char*, kNumMuscles> kMuscleNames = {"ecr", "ecu", "edc", "fcr",
                                                               "fcu", "fds", "fdp"};
/// True for the muscles driven by the extensor channel ("ext"); the others by "flex".
constexpr bool IsExtensor(int m) { return m <= kEdc; }

constexpr int kNumCrossings = 4;
enum CrossingId { kWristCrossing = 0, kMcpCrossing, kPipCrossing, kDipCrossing };
constexpr std::array<const char*, kNumCrossings> kCrossingNames = {"wrist", "mcp", "pip", "dip"};

using MuscleArray = std::array<double, kNumMuscles>;

/// r(θ) = r0 + r1 θ + r2 θ² for one joint the muscle crosses.
struct MomentArmPoly {
  bool crosses = false;        ///< false: r ≡ 0 and the coefficients must be 0.
  double r0_m = 0.0;           ///< m, |r0| ≤ 0.05, > 0 for a flexor.
  double r1_m_per_rad = 0.0;   ///< m/rad, |r1| ≤ 0.05.
  double r2_m_per_rad2 = 0.0;  ///< m/rad², |r2| ≤ 0.05.
};

struct RecruitmentParams {
  double threshold_us = 50.0;    ///< u_th, µs, in [0, 1000).
  double saturation_us = 250.0;  ///< u_sat, µs, in (u_th, 2000].
  double max_fraction = 0.3;     ///< w_max, dimensionless, in (0, 1].
};

struct ActivationParams {
  double coupling_activation_tau_s = 0.05;    ///< τ_e,act, s, in (0, 2].
  double coupling_deactivation_tau_s = 0.09;  ///< τ_e,deact, s, in (0, 2].
  double force_activation_tau_s = 0.15;       ///< τ_a,act, s, in (0, 2].
  double force_deactivation_tau_s = 0.22;     ///< τ_a,deact, s, in (0, 2].
};

struct ContractionParams {
  double max_force_n = 100.0;             ///< F_max, N, ≥ 0.
  double optimal_fibre_length_m = 0.06;   ///< l_opt, m, in (0, 0.5].
  double tendon_slack_length_m = 0.2;     ///< l_TS, m, ≥ 0.
  double mt_length_at_zero_m = 0.26;      ///< l_MT0 = l_MT(θ = 0), m, > l_TS.
  double fl_width = 0.56;                 ///< W, dimensionless, in (0.1, 2].
  double max_velocity_lopt_per_s = 10.0;  ///< v_max/l_opt, 1/s, in (0, 100].
  double hill_curvature = 0.25;           ///< k = a/F0, dimensionless, in (0.05, 2].
  double eccentric_plateau = 1.8;         ///< f_e, dimensionless, in (1, 3].
  double passive_coefficient = 2.0;       ///< k_pe, dimensionless, in [0, 100].
};

struct MuscleParams {
  std::array<MomentArmPoly, kNumCrossings> moment_arms;  ///< wrist, MCP, PIP, DIP.
  RecruitmentParams recruitment;
  ActivationParams activation;
  ContractionParams contraction;
};

/// Throws std::invalid_argument naming `prefix`.field and the allowed range.
void ValidateMuscle(const MuscleParams& muscle, const std::string& prefix);

/// r(θ), m.
double MomentArm(const MomentArmPoly& p, double angle_rad);
/// ∫₀^θ r = r0 θ + r1 θ²/2 + r2 θ³/3, m (the shortening of the muscle due to this joint).
double MomentArmIntegral(const MomentArmPoly& p, double angle_rad);

/// Anatomical joint angles (wrist, MCP, PIP, DIP) from q with θ_DIP = c·q3.
std::array<double, kNumCrossings> CrossingAngles(const Eigen::Vector3d& q, double dip_pip_ratio);

/// l_MT(q), m.
double MusculotendonLength(const MuscleParams& muscle, const Eigen::Vector3d& q,
                           double dip_pip_ratio);

/// ρ(q) = −∂l_MT/∂q, m (see the file comment).
Eigen::Vector3d GeneralisedMomentArms(const MuscleParams& muscle, const Eigen::Vector3d& q,
                                      double dip_pip_ratio);

/// w(u), dimensionless in [0, w_max].
double Recruitment(const RecruitmentParams& p, double pulse_width_us);

/// (input − state)/τ with τ = tau_up when input > state, else tau_down; 1/s.
double FirstOrderRate(double input, double state, double tau_up_s, double tau_down_s);

/// f_L(l̃), dimensionless.
double ForceLength(double norm_length, double width);
/// f_V(ṽ), ṽ > 0 lengthening, dimensionless.
double ForceVelocity(double norm_velocity, double curvature, double eccentric_plateau);
/// Largest slope df_V/dṽ, at ṽ = 0: (1 + k)/k.
double ForceVelocityMaxSlope(double curvature);
/// F_pe/F_max, dimensionless.
double PassiveFibreForce(double norm_length, double coefficient);

/// F, N, at activation a ∈ [0, 1], force capacity factor (1 = fresh), fibre length l_M (m) and
/// velocity v_M (m/s, > 0 lengthening).
double MuscleForce(const ContractionParams& p, double activation, double capacity,
                   double fibre_length_m, double fibre_velocity_m_s);

/// V_pe, J (elastic energy of the passive fibre at fibre length l_M).
double PassiveFibreEnergy(const ContractionParams& p, double fibre_length_m);

}  // namespace fesim::foreign
