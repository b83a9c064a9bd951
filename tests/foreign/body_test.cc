// Tests of foreign/body.h: anthropometry and the closed-form planar equations of motion, checked
// against independent derivations (kinetic energy from centre-of-mass velocities, Lagrange's
// equations by finite differences).
#include "foreign/body.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <stdexcept>

#include "foreign/random.h"

namespace fesim::foreign {
namespace {

constexpr double kFdStep = 1e-6;     // rad (or s) for central differences
constexpr double kFdRelTol = 1e-6;   // relative agreement of central differences
constexpr double kExactTol = 1e-12;  // values computed exactly
constexpr int kPostures = 25;

Eigen::Vector3d RandomPosture(std::mt19937_64& rng) {
  return {UniformIn(rng, -1.2, 1.2), UniformIn(rng, -0.5, 1.6), UniformIn(rng, 0.0, 1.8)};
}

Eigen::Vector3d RandomVelocity(std::mt19937_64& rng) {
  return {UniformIn(rng, -5, 5), UniformIn(rng, -8, 8), UniformIn(rng, -10, 10)};
}

TEST(ForeignBody, AnthropometryFollowsTheCitedCoefficients) {
  const double height = 1.741, mass = 75.0;
  const BodyParams b = HandBody(height, mass);
  const double hand_length = 0.108 * height;
  EXPECT_NEAR(b.segments[0].length_m, 0.0862, kExactTol);
  EXPECT_NEAR(b.segments[0].com_m, 0.790 * 0.0862, kExactTol);
  EXPECT_NEAR(b.segments[1].length_m, 0.245 * hand_length, kExactTol);
  EXPECT_NEAR(b.segments[2].length_m, 0.143 * hand_length, kExactTol);
  EXPECT_NEAR(b.segments[3].length_m, 0.097 * hand_length, kExactTol);
  double total = 0.0;
  for (const SegmentParams& s : b.segments) total += s.mass_kg;
  EXPECT_NEAR(total, 0.0061 * mass, kExactTol);
  EXPECT_NO_THROW(ValidateBody(b));
  EXPECT_NEAR(b.dip_pip_ratio, 2.0 / 3.0, kExactTol);
  // Lengths scale with height, the hand's mass with body mass.
  const BodyParams tall = HandBody(2 * height / 1.5, mass);
  EXPECT_NEAR(tall.segments[1].length_m / b.segments[1].length_m, 2 / 1.5, 1e-12);
  EXPECT_THROW(HandBody(0.5, mass), std::invalid_argument);
  try {
    HandBody(1.75, 5.0);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("mass_kg"), std::string::npos);
  }
}

TEST(ForeignBody, MassMatrixIsSymmetricPositiveDefinite) {
  const BodyParams b = HandBody(1.75, 75);
  std::mt19937_64 rng(1);
  for (int i = 0; i < kPostures; ++i) {
    const Eigen::Matrix3d m = MassMatrix(b, RandomPosture(rng));
    EXPECT_LT((m - m.transpose()).norm(), kExactTol * m.norm());
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(m);
    EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0);
  }
}

TEST(ForeignBody, KineticEnergyEqualsTheSumOverBodiesOfTranslationAndRotation) {
  const BodyParams b = HandBody(1.80, 80);
  const auto s = AbsoluteAngleMap(b);
  std::mt19937_64 rng(2);
  for (int i = 0; i < kPostures; ++i) {
    const Eigen::Vector3d q = RandomPosture(rng), qd = RandomVelocity(rng);
    const Eigen::Vector4d omega = s * qd;
    double t = 0.0;
    for (int k = 0; k < kNumBodies; ++k) {
      const Eigen::Vector2d v =
          (CentreOfMass(b, q + kFdStep * qd, k) - CentreOfMass(b, q - kFdStep * qd, k)) /
          (2 * kFdStep);
      t += 0.5 * b.segments[k].mass_kg * v.squaredNorm() +
           0.5 * b.segments[k].inertia_kg_m2 * omega[k] * omega[k];
    }
    EXPECT_NEAR(KineticEnergy(b, q, qd), t, kFdRelTol * t);
  }
}

TEST(ForeignBody, GravityTorqueIsTheGradientOfThePotential) {
  const BodyParams b = HandBody(1.65, 60);
  GravityParams g;
  g.direction_rad = 0.7;
  std::mt19937_64 rng(3);
  for (int i = 0; i < kPostures; ++i) {
    const Eigen::Vector3d q = RandomPosture(rng);
    const Eigen::Vector3d gt = GravityTorque(b, g, q);
    for (int j = 0; j < kNumJoints; ++j) {
      Eigen::Vector3d dq = Eigen::Vector3d::Zero();
      dq[j] = kFdStep;
      const double fd =
          (GravityPotential(b, g, q + dq) - GravityPotential(b, g, q - dq)) / (2 * kFdStep);
      EXPECT_NEAR(gt[j], fd, kFdRelTol * (std::abs(fd) + 1e-3));
    }
  }
}

TEST(ForeignBody, CoriolisTermFollowsLagrangesEquations) {
  // C q̇ = Ṁ q̇ − ½ ∂(q̇ᵀ M q̇)/∂q.
  const BodyParams b = HandBody(1.75, 75);
  std::mt19937_64 rng(4);
  for (int i = 0; i < kPostures; ++i) {
    const Eigen::Vector3d q = RandomPosture(rng), qd = RandomVelocity(rng);
    const Eigen::Vector3d mdot_qd =
        (MassMatrix(b, q + kFdStep * qd) - MassMatrix(b, q - kFdStep * qd)) * qd / (2 * kFdStep);
    Eigen::Vector3d grad;
    for (int j = 0; j < kNumJoints; ++j) {
      Eigen::Vector3d dq = Eigen::Vector3d::Zero();
      dq[j] = kFdStep;
      grad[j] = (KineticEnergy(b, q + dq, qd) - KineticEnergy(b, q - dq, qd)) / (2 * kFdStep);
    }
    const Eigen::Vector3d expected = mdot_qd - grad;
    const Eigen::Vector3d c = CoriolisCentrifugal(b, q, qd);
    EXPECT_LT((c - expected).norm(), kFdRelTol * (expected.norm() + 1e-6)) << c.transpose();
  }
}

TEST(ForeignBody, DefaultGravityPullsTheHandTowardFlexion) {
  const BodyParams b = HandBody(1.75, 75);
  const GravityParams g;  // palmar, 9.81·cos 45°
  EXPECT_NEAR(g.magnitude_m_s2, 9.81 / std::sqrt(2.0), 1e-12);
  const Eigen::Vector3d q = Eigen::Vector3d::Zero();
  const Eigen::Vector3d qdd = MassMatrix(b, q).llt().solve(-GravityTorque(b, g, q));
  EXPECT_GT(qdd[0], 0.0);
  // Gravity torque at the wrist with the chain straight: |g|·Σ m_i·x_i (centres of mass along x).
  double moment = 0.0;
  for (int k = 0; k < kNumBodies; ++k) moment += b.segments[k].mass_kg * CentreOfMass(b, q, k).x();
  EXPECT_NEAR(GravityTorque(b, g, q)[0], -g.magnitude_m_s2 * moment, kExactTol);
}

TEST(ForeignBody, DistalPhalanxFollowsTheDipCoupling) {
  BodyParams b = HandBody(1.75, 75);
  b.dip_pip_ratio = 0.5;
  const Eigen::Vector3d q(0.1, 0.2, 0.6);
  const Eigen::Vector2d dip =
      CentreOfMass(b, q, 2) + (b.segments[2].length_m - b.segments[2].com_m) *
                                  Eigen::Vector2d(std::cos(0.9), std::sin(0.9));
  const double theta3 = 0.1 + 0.2 + 1.5 * 0.6;
  const Eigen::Vector2d expected =
      dip + b.segments[3].com_m * Eigen::Vector2d(std::cos(theta3), std::sin(theta3));
  EXPECT_LT((CentreOfMass(b, q, 3) - expected).norm(), kExactTol);
}

TEST(ForeignBody, ValidationNamesTheField) {
  BodyParams b = HandBody(1.75, 75);
  b.segments[2].com_m = 1.0;
  try {
    ValidateBody(b);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("body.segments[2].com_m"), std::string::npos);
  }
  GravityParams g;
  g.magnitude_m_s2 = -1;
  EXPECT_THROW(ValidateGravity(g), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::foreign
