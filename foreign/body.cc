#include "foreign/body.h"

#include <Eigen/Dense>
#include <cmath>
#include <string>

#include "foreign/check.h"

namespace fesim::foreign {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Anthropometric coefficients (sources in body.h).
constexpr double kHandLengthPerHeight = 0.108;   // Drillis & Contini 1966 / Winter 2009
constexpr double kWristMet3LengthM = 0.0862;     // de Leva 1996, males
constexpr double kDeLevaStatureM = 1.741;        // de Leva 1996, males
constexpr double kHandMassFraction = 0.0061;     // de Leva 1996, males
constexpr double kHandComFraction = 0.790;       // de Leva 1996, males
constexpr double kHandGyrationFraction = 0.513;  // de Leva 1996, males, transverse axis
constexpr std::array<double, 3> kPhalanxLengthCoef = {0.245, 0.143, 0.097};  // Buchholz 1992
constexpr std::array<double, 3> kPhalanxRadiusCoef = {0.050, 0.044, 0.040};  // assumed
constexpr double kHandDensityKgM3 = 1160.0;  // Dempster 1955 via Winter 2009 Table 4.1

/// Mass distal to body i, kg.
std::array<double, kNumBodies> DistalMass(const BodyParams& body) {
  std::array<double, kNumBodies> out{};
  double sum = 0.0;
  for (int i = kNumBodies - 1; i >= 0; --i) {
    out[i] = sum;
    sum += body.segments[i].mass_kg;
  }
  return out;
}

Eigen::Vector4d Absolute(const BodyParams& body, const Eigen::Vector3d& q) {
  return AbsoluteAngleMap(body) * q;
}

}  // namespace

BodyParams HandBody(double height_m, double mass_kg) {
  CheckRange(height_m, 1.0, 2.5, "height_m");
  CheckRange(mass_kg, 20.0, 250.0, "mass_kg");
  BodyParams body;
  const double hand_length = kHandLengthPerHeight * height_m;
  double finger_mass = 0.0;
  for (int k = 0; k < 3; ++k) {
    SegmentParams& s = body.segments[k + 1];
    const double r = kPhalanxRadiusCoef[k] * hand_length;
    s.length_m = kPhalanxLengthCoef[k] * hand_length;
    s.mass_kg = kHandDensityKgM3 * kPi * r * r * s.length_m;
    s.com_m = 0.5 * s.length_m;
    s.inertia_kg_m2 = s.mass_kg * (3.0 * r * r + s.length_m * s.length_m) / 12.0;
    finger_mass += s.mass_kg;
  }
  SegmentParams& hand = body.segments[0];
  hand.length_m = kWristMet3LengthM * height_m / kDeLevaStatureM;
  hand.mass_kg = kHandMassFraction * mass_kg - finger_mass;
  hand.com_m = kHandComFraction * hand.length_m;
  const double gyration = kHandGyrationFraction * hand.length_m;
  hand.inertia_kg_m2 = hand.mass_kg * gyration * gyration;
  return body;
}

void ValidateBody(const BodyParams& body) {
  for (int i = 0; i < kNumBodies; ++i) {
    const std::string p = "body.segments[" + std::to_string(i) + "].";
    const SegmentParams& s = body.segments[i];
    CheckAbove(s.mass_kg, 0.0, 10.0, p + "mass_kg");
    CheckAbove(s.length_m, 0.0, 1.0, p + "length_m");
    CheckRange(s.com_m, 0.0, s.length_m, p + "com_m");
    CheckRange(s.inertia_kg_m2, 0.0, 1.0, p + "inertia_kg_m2");
  }
  CheckRange(body.dip_pip_ratio, 0.0, 1.5, "body.dip_pip_ratio");
}

void ValidateGravity(const GravityParams& gravity) {
  CheckRange(gravity.magnitude_m_s2, 0.0, 30.0, "gravity.magnitude_m_s2");
  CheckRange(gravity.direction_rad, -2.0 * kPi, 2.0 * kPi, "gravity.direction_rad");
}

Eigen::Matrix<double, kNumBodies, kNumJoints> AbsoluteAngleMap(const BodyParams& body) {
  Eigen::Matrix<double, kNumBodies, kNumJoints> s;
  s << 1, 0, 0,  //
      1, 1, 0,   //
      1, 1, 1,   //
      1, 1, 1 + body.dip_pip_ratio;
  return s;
}

ChainCoefficients Coefficients(const BodyParams& body) {
  const auto tail = DistalMass(body);
  ChainCoefficients chain;
  for (int i = 0; i < kNumBodies; ++i) {
    const SegmentParams& si = body.segments[i];
    chain.first_moment[i] = si.mass_kg * si.com_m + tail[i] * si.length_m;
    chain.inertia(i, i) =
        si.inertia_kg_m2 + si.mass_kg * si.com_m * si.com_m + tail[i] * si.length_m * si.length_m;
    for (int k = i + 1; k < kNumBodies; ++k) {
      const SegmentParams& sk = body.segments[k];
      chain.inertia(i, k) = si.length_m * (sk.mass_kg * sk.com_m + tail[k] * sk.length_m);
      chain.inertia(k, i) = chain.inertia(i, k);
    }
  }
  chain.s = AbsoluteAngleMap(body);
  return chain;
}

EquationTerms EvaluateEquations(const ChainCoefficients& chain, const GravityParams& gravity,
                                const Eigen::Vector3d& q, const Eigen::Vector3d& qd) {
  const Eigen::Vector4d th = chain.s * q;
  const Eigen::Vector4d thd = chain.s * qd;
  Eigen::Vector4d c, s;
  for (int i = 0; i < kNumBodies; ++i) {
    c[i] = std::cos(th[i]);
    s[i] = std::sin(th[i]);
  }
  const double gc = gravity.magnitude_m_s2 * std::cos(gravity.direction_rad);
  const double gs = gravity.magnitude_m_s2 * std::sin(gravity.direction_rad);
  Eigen::Matrix4d h;
  Eigen::Vector4d centrifugal = Eigen::Vector4d::Zero();
  Eigen::Vector4d dv;
  for (int i = 0; i < kNumBodies; ++i) {
    h(i, i) = chain.inertia(i, i);
    for (int k = i + 1; k < kNumBodies; ++k) {
      const double cik = c[i] * c[k] + s[i] * s[k];  // cos(θ_i − θ_k)
      const double sik = s[i] * c[k] - c[i] * s[k];  // sin(θ_i − θ_k)
      h(i, k) = h(k, i) = chain.inertia(i, k) * cik;
      centrifugal[i] += chain.inertia(i, k) * sik * thd[k] * thd[k];
      centrifugal[k] -= chain.inertia(i, k) * sik * thd[i] * thd[i];
    }
    dv[i] = -chain.first_moment[i] * (gs * c[i] - gc * s[i]);  // |g| sin(φ − θ_i)
  }
  EquationTerms terms;
  terms.mass = chain.s.transpose() * h * chain.s;
  terms.coriolis = chain.s.transpose() * centrifugal;
  terms.gravity = chain.s.transpose() * dv;
  return terms;
}

Eigen::Matrix3d MassMatrix(const BodyParams& body, const Eigen::Vector3d& q) {
  return EvaluateEquations(Coefficients(body), GravityParams{}, q, Eigen::Vector3d::Zero()).mass;
}

Eigen::Vector3d CoriolisCentrifugal(const BodyParams& body, const Eigen::Vector3d& q,
                                    const Eigen::Vector3d& qd) {
  return EvaluateEquations(Coefficients(body), GravityParams{}, q, qd).coriolis;
}

Eigen::Vector3d GravityTorque(const BodyParams& body, const GravityParams& gravity,
                              const Eigen::Vector3d& q) {
  return EvaluateEquations(Coefficients(body), gravity, q, Eigen::Vector3d::Zero()).gravity;
}

double KineticEnergy(const BodyParams& body, const Eigen::Vector3d& q, const Eigen::Vector3d& qd) {
  return 0.5 * qd.dot(MassMatrix(body, q) * qd);
}

Eigen::Vector2d CentreOfMass(const BodyParams& body, const Eigen::Vector3d& q, int body_index) {
  CheckRange(body_index, 0, kNumBodies - 1, "body_index");
  const Eigen::Vector4d th = Absolute(body, q);
  Eigen::Vector2d p = Eigen::Vector2d::Zero();
  for (int j = 0; j < body_index; ++j) {
    p += body.segments[j].length_m * Eigen::Vector2d(std::cos(th[j]), std::sin(th[j]));
  }
  const double c = body.segments[body_index].com_m;
  return p + c * Eigen::Vector2d(std::cos(th[body_index]), std::sin(th[body_index]));
}

double GravityPotential(const BodyParams& body, const GravityParams& gravity,
                        const Eigen::Vector3d& q) {
  const Eigen::Vector2d g =
      gravity.magnitude_m_s2 *
      Eigen::Vector2d(std::cos(gravity.direction_rad), std::sin(gravity.direction_rad));
  double v = 0.0;
  for (int i = 0; i < kNumBodies; ++i)
    v -= body.segments[i].mass_kg * g.dot(CentreOfMass(body, q, i));
  return v;
}

}  // namespace fesim::foreign
