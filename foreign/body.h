// Planar rigid-body model of the hand and index finger of the foreign simulator: anthropometry and
// the closed-form equations of motion M(q) q̈ + C(q, q̇) q̇ + G(q) = τ.
//
// Frame and signs. The chain moves in the flexion–extension plane of the hand, frame F fixed to
// the forearm: origin at the wrist centre, x_F along the forearm axis pointing distally, y_F
// pointing palmar (volar). Generalised coordinates q = (q1, q2, q3) = (wrist flexion, index MCP
// flexion, index PIP flexion), rad, flexion positive (toward y_F). The four bodies are
//   0 hand (carpus, metacarpals and fingers III–V, which move with it), wrist → index MCP,
//   1 proximal phalanx, MCP → PIP,   2 middle phalanx, PIP → DIP,   3 distal phalanx, DIP → tip,
// with the DIP joint coupled to the PIP as θ_DIP = c·q3, c = dip_pip_ratio (2/3 by default,
// Rijpkema & Girard 1991, Computer Graphics (SIGGRAPH) 25(4)). The absolute angle of body i from
// x_F is θ = S q with the constant 4×3 matrix S = [1 0 0; 1 1 0; 1 1 1; 1 1 1+c].
//
// Equations (Lagrange in absolute angles, then mapped by S; our own derivation): with
//   m⁺_i = Σ_{k>i} m_k (mass distal to body i), b_i = m_i c_i + m⁺_i l_i,
//   A_ii = I_i + m_i c_i² + m⁺_i l_i²,  A_ik = l_i (m_k c_k + m⁺_k l_k) for i < k (A symmetric),
//   H(θ)_ik = A_ik cos(θ_i − θ_k),  h_i(θ, θ̇) = Σ_k A_ik sin(θ_i − θ_k) θ̇_k²,
//   V_g(θ) = −Σ_i m_i g·p_i,  ∂V_g/∂θ_i = −b_i |g| sin(φ − θ_i),
// the coordinates obey M(q) = Sᵀ H S, C(q, q̇) q̇ = Sᵀ h, G(q) = Sᵀ ∂V_g/∂θ. Gravity in F is
// g_F = |g| (cos φ, sin φ). p_i is body i's centre of mass, c_i its distance from the proximal
// joint along the body axis, l_i the joint-to-joint length, I_i the inertia about the centre of
// mass normal to the plane.
#pragma once

#include <Eigen/Core>
#include <array>

namespace fesim::foreign {

constexpr int kNumBodies = 4;
constexpr int kNumJoints = 3;  // generalised coordinates q1..q3

/// One rigid body of the chain (see the file comment for the frame).
struct SegmentParams {
  double mass_kg = 0.0;        ///< m_i, kg, > 0.
  double length_m = 0.0;       ///< l_i, proximal joint → distal joint (or tip), m, > 0.
  double com_m = 0.0;          ///< c_i, proximal joint → centre of mass along the axis, m, ≥ 0.
  double inertia_kg_m2 = 0.0;  ///< I_i about the centre of mass, normal to the plane, kg·m², ≥ 0.
};

/// The four bodies and the DIP–PIP coupling.
struct BodyParams {
  std::array<SegmentParams, kNumBodies> segments;  ///< hand, proximal, middle, distal phalanx.
  double dip_pip_ratio = 2.0 / 3.0;  ///< c: θ_DIP = c·q3, dimensionless, in [0, 1.5].
};

/// Gravity in the plane of the chain: g_F = magnitude·(cos φ, sin φ) in frame F.
struct GravityParams {
  /// |g| in the plane, m/s², ≥ 0. Default: the hand rig (forearm horizontal, pronated 45° from
  /// neutral): 9.81·cos 45°; the out-of-plane part acts on the locked deviation axis, not here.
  double magnitude_m_s2 = 9.81 * 0.70710678118654752;
  /// φ, rad, angle of g_F from x_F toward y_F. Default π/2: palmar. A forearm pronated from the
  /// thumb-up neutral turns the palm down, so gravity pulls the hand toward flexion (the brief's
  /// "toward extension" holds for a supinated forearm: φ = −π/2).
  double direction_rad = 1.57079632679489662;
};

/// Anthropometry of a person of height H and body mass m_b (all lengths ∝ H, hand mass ∝ m_b):
///  - hand length L = 0.108 H (Drillis & Contini 1966, as tabulated in Winter 2009, Biomechanics
///    and Motor Control of Human Movement, 4th ed., Fig. 4.1);
///  - body 0: wrist centre → third metacarpale length 0.0862 m · H / 1.741 m, hand mass 0.61 % of
///    m_b, centre of mass at 79.0 % of that length, radius of gyration about the transverse
///    (flexion) axis 51.3 % (de Leva 1996, J Biomech 29(9), Table 4, males); the index segments'
///    masses are taken out of the hand mass and its centre of mass is kept (departure);
///  - index phalanx lengths 0.245 L, 0.143 L, 0.097 L (Buchholz, Armstrong & Goldstein 1992,
///    Ergonomics 35(3), index finger segment-length coefficients);
///  - phalanges as uniform solid cylinders of density 1160 kg/m³ (hand density, Dempster 1955 via
///    Winter 2009 Table 4.1) with radii 0.050 L, 0.044 L, 0.040 L (assumed: ≈ 9.5, 8.3, 7.6 mm for
///    L = 0.19 m).
/// Throws std::invalid_argument when height_m ∉ [1.0, 2.5] or mass_kg ∉ [20, 250].
BodyParams HandBody(double height_m, double mass_kg);

/// Throws std::invalid_argument naming the first field out of range.
void ValidateBody(const BodyParams& body);
void ValidateGravity(const GravityParams& gravity);

/// The constant coefficients of the file comment, computed once per body: A (kg·m²), the first
/// moments b_i (kg·m) and S.
struct ChainCoefficients {
  Eigen::Matrix4d inertia;                          ///< A, kg·m².
  Eigen::Vector4d first_moment;                     ///< b_i, kg·m.
  Eigen::Matrix<double, kNumBodies, kNumJoints> s;  ///< S, dimensionless.
};
ChainCoefficients Coefficients(const BodyParams& body);

/// The three terms of M(q) q̈ + C(q, q̇) q̇ + G(q) = τ at one state.
struct EquationTerms {
  Eigen::Matrix3d mass;      ///< M(q), kg·m².
  Eigen::Vector3d coriolis;  ///< C(q, q̇) q̇, N·m.
  Eigen::Vector3d gravity;   ///< G(q), N·m.
};
EquationTerms EvaluateEquations(const ChainCoefficients& chain, const GravityParams& gravity,
                                const Eigen::Vector3d& q, const Eigen::Vector3d& qd);

/// S of the file comment (absolute body angles θ = S q).
Eigen::Matrix<double, kNumBodies, kNumJoints> AbsoluteAngleMap(const BodyParams& body);

/// M(q), kg·m², symmetric positive definite.
Eigen::Matrix3d MassMatrix(const BodyParams& body, const Eigen::Vector3d& q);

/// C(q, q̇) q̇: centrifugal and Coriolis generalised forces, N·m.
Eigen::Vector3d CoriolisCentrifugal(const BodyParams& body, const Eigen::Vector3d& q,
                                    const Eigen::Vector3d& qd);

/// G(q) = ∂V_g/∂q, N·m (so that gravity contributes −G(q) to M q̈).
Eigen::Vector3d GravityTorque(const BodyParams& body, const GravityParams& gravity,
                              const Eigen::Vector3d& q);

/// Kinetic energy ½ q̇ᵀ M(q) q̇, J.
double KineticEnergy(const BodyParams& body, const Eigen::Vector3d& q, const Eigen::Vector3d& qd);

/// Gravitational potential V_g(q) = −Σ m_i g·p_i, J (zero with the centres of mass at the wrist).
double GravityPotential(const BodyParams& body, const GravityParams& gravity,
                        const Eigen::Vector3d& q);

/// Position of body i's centre of mass in F, m (i in 0..3).
Eigen::Vector2d CentreOfMass(const BodyParams& body, const Eigen::Vector3d& q, int body_index);

}  // namespace fesim::foreign
