#include "sim/chain_dynamics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace fesim::sim {
namespace {

using SimTK::Vec3;

/// A body of mass m with its mass centre at c (in B) and inertia I_c about it: inertia about B's
/// origin by the parallel-axis theorem.
ChainBody PointLikeBody(int parent, double m, const Vec3& c, double i_c) {
  ChainBody b;
  b.parent = parent;
  b.mass_kg = m;
  b.com_m = c;
  const SimTK::Mat33 one(1, 0, 0, 0, 1, 0, 0, 0, 1);
  b.inertia_o = i_c * one + m * (SimTK::dot(c, c) * one - c * ~c);
  return b;
}

TEST(ChainDynamics, PendulumAcceleratesAsItsEquationOfMotion) {
  // A pin about Z with the mass centre at −L along B's y: I_o θ̈ = τ − m g L sin θ + F L cos θ
  // for gravity −g ŷ and a horizontal force F x̂ at the mass centre.
  constexpr double m = 1.3, L = 0.4, i_c = 0.02, g = 9.81, tau = 0.7, F = 2.0;
  ChainBody pendulum = PointLikeBody(-1, m, Vec3(0, -L, 0), i_c);
  pendulum.q = 0;
  pendulum.u = 0;
  const ChainDynamics chain({pendulum}, Vec3(0, -g, 0));
  ChainWorkspace ws;
  for (double theta : {0.0, 0.5, -1.2, 2.8}) {
    const double q = theta, u = 3.0;  // the speed adds no torque on a single pin
    chain.Kinematics(&q, &ws);
    const Vec3 p_G = chain.StationInGround(ws, 0, Vec3(0, -L, 0));
    EXPECT_NEAR(p_G[0], L * std::sin(theta), 1e-15);
    EXPECT_NEAR(p_G[1], -L * std::cos(theta), 1e-15);
    chain.ApplyForceAtStation(&ws, 0, Vec3(0, -L, 0), Vec3(F, 0, 0));
    double udot = NAN;
    chain.Accelerations(&u, &tau, &ws, &udot);
    const double expected =
        (tau - m * g * L * std::sin(theta) + F * L * std::cos(theta)) / (i_c + m * L * L);
    EXPECT_NEAR(udot, expected, 1e-12) << "theta " << theta;
  }
}

TEST(ChainDynamics, HeldPinAndWeldCarryTheirChildAsOneBody) {
  // A pin, a held pin (Simbody's lock) and a welded body below: the first pin sees one rigid
  // body of the three masses, so its acceleration is that of a compound pendulum, and the held
  // pin's is 0.
  constexpr double g = 9.81, L = 0.3;
  ChainBody root = PointLikeBody(-1, 1.0, Vec3(0, -L, 0), 0.01);
  root.q = 0;
  root.u = 0;
  ChainBody held = PointLikeBody(0, 0.5, Vec3(0, -0.1, 0), 0.002);
  held.X_PF = SimTK::Transform(Vec3(0, -2 * L, 0));
  held.q = 1;
  held.u = 1;
  held.held = true;
  ChainBody welded = PointLikeBody(1, 0.2, Vec3(0.05, 0, 0), 0.001);
  welded.X_PF = SimTK::Transform(Vec3(0, -0.2, 0));
  const ChainDynamics chain({root, held, welded}, Vec3(0, -g, 0));
  const double q[2] = {0.4, 0.0}, u[2] = {0.0, 0.0}, tau[2] = {0.0, 5.0};
  ChainWorkspace ws;
  chain.Kinematics(q, &ws);
  double udot[2] = {NAN, NAN};
  chain.Accelerations(u, tau, &ws, udot);
  // Compound body in B0: mass centres at (0, −L), (0, −2L − 0.1), (0.05, −2L − 0.2).
  const double masses[3] = {1.0, 0.5, 0.2};
  const Vec3 centres[3] = {Vec3(0, -L, 0), Vec3(0, -2 * L - 0.1, 0), Vec3(0.05, -2 * L - 0.2, 0)};
  const double i_c[3] = {0.01, 0.002, 0.001};
  double inertia = 0.0;
  Vec3 moment(0);
  for (int k = 0; k < 3; ++k) {
    inertia += i_c[k] + masses[k] * (centres[k][0] * centres[k][0] + centres[k][1] * centres[k][1]);
    moment += masses[k] * centres[k];
  }
  // Gravity's torque about Z at angle θ: (R c) × (−m g ŷ), z component = −m g (R c)_x.
  const double s = std::sin(q[0]), c = std::cos(q[0]);
  const double x = c * moment[0] - s * moment[1];
  EXPECT_NEAR(udot[0], -g * x / inertia, 1e-12);
  EXPECT_EQ(udot[1], 0.0);
}

TEST(ChainDynamics, ParentsComeBeforeChildren) {
  ChainBody a;
  a.parent = 0;  // itself
  EXPECT_THROW(ChainDynamics({a}, Vec3(0)), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::sim
