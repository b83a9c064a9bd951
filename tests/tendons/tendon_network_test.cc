#include "tendons/tendon_network.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace fesim::tendons {
namespace {

constexpr double kFdStep = 1e-6;
constexpr double kFdTol = 1e-9;

std::vector<MusclePath> TwoMuscles() {
  MusclePath flexor{"fds", 0.3, {}};
  flexor.crossings = {{0, {MomentArmParams::Model::kConstant, 0.014, 0}, 0.0},
                      {1, {MomentArmParams::Model::kLandsmeer, 0.01, -0.02}, 0.1}};
  MusclePath extensor{"edc", 0.32, {}};
  extensor.crossings = {{0, {MomentArmParams::Model::kConstant, -0.01, 0}, 0.0},
                        {1, {MomentArmParams::Model::kLandsmeer, -0.009, 0.01}, 0.0}};
  return {flexor, extensor};
}

TEST(TendonNetwork, MatrixIsMinusGradientOfLengths) {
  const auto paths = TwoMuscles();
  const std::vector<double> q = {0.3, 0.7};
  const auto r = MomentArmMatrix(paths, q);
  for (std::size_t m = 0; m < paths.size(); ++m) {
    for (std::size_t i = 0; i < q.size(); ++i) {
      auto qp = q, qm = q;
      qp[i] += kFdStep;
      qm[i] -= kFdStep;
      const double d =
          (MusculotendonLength(paths[m], qp) - MusculotendonLength(paths[m], qm)) / (2 * kFdStep);
      EXPECT_NEAR(r[i * paths.size() + m], -d, kFdTol);
    }
  }
}

TEST(TendonNetwork, PowerBalance) {
  // −Σ f dl/dt = Σ τ q̇ for any posture, velocity and forces.
  const auto paths = TwoMuscles();
  const std::vector<double> q = {-0.4, 1.1}, qd = {0.8, -2.0}, f = {120.0, 35.0};
  const auto tau = JointTorques(paths, q, f);
  double muscle_power = 0, joint_power = 0;
  for (std::size_t m = 0; m < 2; ++m) muscle_power -= f[m] * MusculotendonVelocity(paths[m], q, qd);
  for (std::size_t i = 0; i < 2; ++i) joint_power += tau[i] * qd[i];
  EXPECT_NEAR(muscle_power, joint_power, 1e-12);
  EXPECT_GT(tau[0], 0.0);  // flexor dominates the first joint: flexion torque
}

TEST(TendonNetwork, OverloadsOnPrecomputedArmsGiveTheSameBits) {
  const auto paths = TwoMuscles();
  const std::vector<double> q = {-0.4, 1.1}, qd = {0.8, -2.0}, f = {120.0, 35.0};
  const std::vector<double> arms = CrossingMomentArms(paths, q);
  ASSERT_EQ(arms.size(), 4u);
  const double* at = arms.data();
  for (const auto& path : paths) {
    EXPECT_EQ(MusculotendonVelocity(path, at, qd), MusculotendonVelocity(path, q, qd));
    at += path.crossings.size();
  }
  EXPECT_EQ(JointTorques(paths, arms, f, q.size()), JointTorques(paths, q, f));
  // The forms into a caller's vectors, whatever they held before.
  std::vector<double> reused(7, NAN), tau(1, NAN);
  CrossingMomentArms(paths, q, &reused);
  EXPECT_EQ(reused, arms);
  JointTorques(paths, arms, f, q.size(), &tau);
  EXPECT_EQ(tau, JointTorques(paths, q, f));
  EXPECT_THROW(JointTorques(paths, std::vector<double>(3), f, q.size()), std::invalid_argument);
  EXPECT_THROW(CrossingMomentArms(paths, {0.1}), std::invalid_argument);
  // A skipped path's crossings keep what they held; the others are evaluated.
  std::vector<double> partial(4, -7.0);
  CrossingMomentArms(paths, q, &partial, {1, 0});
  EXPECT_EQ(partial[0], -7.0);
  EXPECT_EQ(partial[1], -7.0);
  EXPECT_EQ(partial[2], arms[2]);
  EXPECT_EQ(partial[3], arms[3]);
  EXPECT_THROW(CrossingMomentArms(paths, q, &partial, {1}), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::tendons
