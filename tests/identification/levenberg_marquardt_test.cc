// Bounded Levenberg–Marquardt (identification/levenberg_marquardt.h): convergence on a
// well-posed problem and an honest stop reason when it does not converge (issue 10).
#include "identification/levenberg_marquardt.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>

namespace fesim::identification {
namespace {

/// Distance of the Rosenbrock minimiser (1, 1) reached from the standard start.
constexpr double kRosenbrockTol = 1e-6;

/// Rosenbrock's function as least squares: r = [10 (x₂ − x₁²), 1 − x₁], minimum 0 at (1, 1).
Eigen::VectorXd Rosenbrock(const Eigen::VectorXd& x) {
  return Eigen::Vector2d(10.0 * (x(1) - x(0) * x(0)), 1.0 - x(0));
}

Eigen::VectorXd Unbounded(double sign) {
  return Eigen::VectorXd::Constant(2, sign * std::numeric_limits<double>::infinity());
}

TEST(LevenbergMarquardt, ConvergesOnRosenbrockFromTheStandardStart) {
  const LmResult r =
      LevenbergMarquardt(Rosenbrock, Eigen::Vector2d(-1.2, 1.0), Unbounded(-1), Unbounded(1));
  EXPECT_TRUE(r.converged) << LmStopReasonName(r.stop_reason);
  EXPECT_TRUE(LmConverged(r.stop_reason));
  EXPECT_NE(r.stop_reason, LmStopReason::kIterationLimit);
  EXPECT_LT((r.x - Eigen::Vector2d(1.0, 1.0)).norm(), kRosenbrockTol);
  EXPECT_LT(r.iterations, LmOptions{}.max_iterations);
  const Convergence c = ToConvergence(r);
  EXPECT_TRUE(c.converged);
  EXPECT_EQ(c.stop_reason, LmStopReasonName(r.stop_reason));
  EXPECT_EQ(c.iterations, r.iterations);
}

TEST(LevenbergMarquardt, BroydenUpdatesReachTheSameMinimumWithFewerJacobians) {
  LmOptions o;
  o.broyden = true;
  const LmResult b =
      LevenbergMarquardt(Rosenbrock, Eigen::Vector2d(-1.2, 1.0), Unbounded(-1), Unbounded(1), o);
  const LmResult f =
      LevenbergMarquardt(Rosenbrock, Eigen::Vector2d(-1.2, 1.0), Unbounded(-1), Unbounded(1));
  EXPECT_TRUE(b.converged) << LmStopReasonName(b.stop_reason);
  EXPECT_LT((b.x - Eigen::Vector2d(1.0, 1.0)).norm(), kRosenbrockTol);
  EXPECT_LT(b.jacobian_evaluations, b.iterations);
  EXPECT_LT(b.jacobian_evaluations, f.jacobian_evaluations);
  EXPECT_EQ(f.jacobian_evaluations, f.iterations + 1);  // one per accepted step and the start
  // The stop was declared on an evaluated Jacobian: JᵀJ is the one at the minimiser,
  // J = [[−20 x₁, 10], [−1, 0]] at (1, 1).
  const Eigen::Matrix2d J_min = (Eigen::Matrix2d() << -20.0, 10.0, -1.0, 0.0).finished();
  EXPECT_LT((b.jtj - J_min.transpose() * J_min).norm(), 1e-4 * (J_min.transpose() * J_min).norm());
}

/// Trial steps LM rejected: residual evaluations less the start, the accepted steps and the
/// forward-difference Jacobians' p evaluations each.
int RejectedTrials(const LmResult& r, int p) {
  return r.evaluations - 1 - r.iterations - p * r.jacobian_evaluations;
}

TEST(LevenbergMarquardt, GainRatioDampingReachesTheSameMinimaWithNoMoreRejectedTrials) {
  // Rosenbrock's curved valley, and Box's 3-D exponential fit (Moré, Garbow & Hillstrom 1981,
  // problem 12: r_i = e^{−t_i x₁} − e^{−t_i x₂} − x₃ (e^{−t_i} − e^{−10 t_i}), t_i = 0.1 i,
  // minimum 0 at (1, 10, 1), start (0, 10, 20)).
  const auto box = [](const Eigen::VectorXd& x) {
    Eigen::VectorXd r(10);
    for (int i = 0; i < 10; ++i) {
      const double t = 0.1 * (i + 1);
      r(i) = std::exp(-t * x(0)) - std::exp(-t * x(1)) - x(2) * (std::exp(-t) - std::exp(-10 * t));
    }
    return r;
  };
  LmOptions nielsen;
  nielsen.gain_ratio_damping = true;
  const LmResult rn = LevenbergMarquardt(Rosenbrock, Eigen::Vector2d(-1.2, 1.0), Unbounded(-1),
                                         Unbounded(1), nielsen);
  const LmResult rf =
      LevenbergMarquardt(Rosenbrock, Eigen::Vector2d(-1.2, 1.0), Unbounded(-1), Unbounded(1));
  const Eigen::VectorXd inf = Eigen::VectorXd::Constant(3, std::numeric_limits<double>::infinity());
  const LmResult bn = LevenbergMarquardt(box, Eigen::Vector3d(0.0, 10.0, 20.0), -inf, inf, nielsen);
  const LmResult bf = LevenbergMarquardt(box, Eigen::Vector3d(0.0, 10.0, 20.0), -inf, inf);
  std::printf(
      "rejected trials / accepted steps: Rosenbrock %d/%d (1/3 rule %d/%d), Box 3-D %d/%d "
      "(1/3 rule %d/%d)\n",
      RejectedTrials(rn, 2), rn.iterations, RejectedTrials(rf, 2), rf.iterations,
      RejectedTrials(bn, 3), bn.iterations, RejectedTrials(bf, 3), bf.iterations);
  EXPECT_TRUE(rn.converged) << LmStopReasonName(rn.stop_reason);
  EXPECT_LT((rn.x - Eigen::Vector2d(1.0, 1.0)).norm(), kRosenbrockTol);
  EXPECT_TRUE(bn.converged) << LmStopReasonName(bn.stop_reason);
  EXPECT_LT((bn.x - Eigen::Vector3d(1.0, 10.0, 1.0)).norm(), 1e-5);
  // Seen: Rosenbrock 6 rejected / 29 accepted (1/3 rule: 10 / 25), Box 3 / 10 both.
  EXPECT_LT(RejectedTrials(rn, 2), RejectedTrials(rf, 2));
  EXPECT_LE(RejectedTrials(rn, 2) + rn.iterations, RejectedTrials(rf, 2) + rf.iterations);
  EXPECT_LE(RejectedTrials(bn, 3), RejectedTrials(bf, 3));
}

TEST(LevenbergMarquardt, PredictedDecreaseStopIgnoresAPoorStepAlongAnInexactJacobian) {
  // r(x) = x − 1 from x = 0, but the Jacobian is given 1000× too large: the Gauss–Newton step is
  // 1000× too short, gains 0.2 % where its linear model predicts all of the cost.
  const ResidualFn r = [](const Eigen::VectorXd& x) { return Eigen::VectorXd(x.array() - 1.0); };
  const JacobianFn wrong = [](const Eigen::VectorXd&, const Eigen::VectorXd&, int*) {
    return Eigen::MatrixXd::Constant(1, 1, 1000.0);
  };
  LmOptions o;
  o.relative_tolerance = 1e-2;
  o.scale_free_damping = true;
  o.max_iterations = 20;
  const Eigen::VectorXd x0 = Eigen::VectorXd::Zero(1);
  const LmResult plain =
      LevenbergMarquardt(r, x0, Unbounded(-1).head(1), Unbounded(1).head(1), o, {}, wrong);
  EXPECT_EQ(plain.stop_reason, LmStopReason::kRelativeDecrease);  // far from x = 1
  EXPECT_LT(plain.x(0), 0.01);
  o.stop_needs_predicted_decrease = true;
  const LmResult guarded =
      LevenbergMarquardt(r, x0, Unbounded(-1).head(1), Unbounded(1).head(1), o, {}, wrong);
  EXPECT_NE(guarded.stop_reason, LmStopReason::kRelativeDecrease);
  EXPECT_GT(guarded.iterations, plain.iterations);
  EXPECT_GT(guarded.x(0), plain.x(0));
}

TEST(LevenbergMarquardt, OneIterationIsReportedAsTheIterationLimitNotConvergence) {
  LmOptions o;
  o.max_iterations = 1;
  const Eigen::Vector2d start(-1.2, 1.0);
  const LmResult r = LevenbergMarquardt(Rosenbrock, start, Unbounded(-1), Unbounded(1), o);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.stop_reason, LmStopReason::kIterationLimit);
  EXPECT_STREQ(LmStopReasonName(r.stop_reason), "iteration_limit");
  EXPECT_EQ(r.iterations, 1);
  EXPECT_LT(r.cost, Rosenbrock(start).squaredNorm());  // one accepted step was taken
}

TEST(LevenbergMarquardt, NoDecreasePossibleIsReportedAndKeepsTheStart) {
  // The cost is finite only at the start: every trial step is rejected and the damping grows
  // until the step vanishes. LM must not call the start point a converged fit.
  const Eigen::VectorXd start = Eigen::VectorXd::Constant(1, 1.0);
  const ResidualFn r = [&](const Eigen::VectorXd& x) {
    return Eigen::VectorXd::Constant(
        1, x(0) == start(0) ? 1.0 : std::numeric_limits<double>::quiet_NaN());
  };
  const JacobianFn jac = [](const Eigen::VectorXd&, const Eigen::VectorXd&, int*) {
    return Eigen::MatrixXd::Ones(1, 1);
  };
  LmOptions o;
  const Eigen::VectorXd inf = Eigen::VectorXd::Constant(1, std::numeric_limits<double>::infinity());
  const LmResult res = LevenbergMarquardt(r, start, -inf, inf, o, {}, jac);
  EXPECT_FALSE(res.converged);
  EXPECT_EQ(res.stop_reason, LmStopReason::kNoDecrease);
  EXPECT_EQ(res.iterations, 0);
  EXPECT_EQ(res.x(0), start(0));
}

TEST(LevenbergMarquardt, ExactFitStopsOnZeroCost) {
  // A linear residual: one Gauss–Newton step reaches r = 0 exactly.
  const ResidualFn r = [](const Eigen::VectorXd& x) {
    return Eigen::VectorXd::Constant(1, 2.0 * x(0) - 4.0);
  };
  const JacobianFn jac = [](const Eigen::VectorXd&, const Eigen::VectorXd&, int*) {
    return Eigen::MatrixXd::Constant(1, 1, 2.0);
  };
  LmOptions o;
  o.initial_damping = 0.0;
  const Eigen::VectorXd inf = Eigen::VectorXd::Constant(1, std::numeric_limits<double>::infinity());
  const LmResult res = LevenbergMarquardt(r, Eigen::VectorXd::Zero(1), -inf, inf, o, {}, jac);
  EXPECT_TRUE(res.converged);
  EXPECT_EQ(res.stop_reason, LmStopReason::kZeroCost);
  EXPECT_DOUBLE_EQ(res.x(0), 2.0);
}

/// A valley x1 ≈ x0 whose unconstrained minimum (2, 2) lies beyond the bound x0 ≤ 1:
/// r = [10 (x1 − x0), x0 + x1 − 4]. Constrained minimiser x0 = 1, x1 = 103/101 (from
/// ∂/∂x1 = 0), where ∂cost/∂x0 < 0, so the bound is active (KKT).
Eigen::VectorXd Valley(const Eigen::VectorXd& x) {
  return Eigen::Vector2d(10.0 * (x(1) - x(0)), x(0) + x(1) - 4.0);
}

TEST(LevenbergMarquardt, HoldingActiveBoundsReachesTheConstrainedMinimiser) {
  const Eigen::Vector2d lower(-10.0, -10.0), upper(1.0, 10.0), start(-5.0, 6.0);
  LmOptions o;
  o.relative_tolerance = 1e-14;
  o.hold_active_bounds = true;
  const LmResult held = LevenbergMarquardt(Valley, start, lower, upper, o);
  EXPECT_TRUE(held.converged) << LmStopReasonName(held.stop_reason);
  EXPECT_DOUBLE_EQ(held.x(0), 1.0);
  EXPECT_NEAR(held.x(1), 103.0 / 101.0, 1e-7);
  o.hold_active_bounds = false;
  const LmResult clamped = LevenbergMarquardt(Valley, start, lower, upper, o);
  EXPECT_LE(held.iterations, clamped.iterations);
  std::printf("valley with an active bound: %d iterations holding it, %d clamping (x1 = %.9f)\n",
              held.iterations, clamped.iterations, clamped.x(1));
}

TEST(LevenbergMarquardt, NormalEquationsCallbackMatchesTheJacobianPath) {
  // The same exact Jacobian given as J or as (JᵀJ, Jᵀr): identical iterates.
  const auto J = [](const Eigen::VectorXd&) {
    Eigen::Matrix2d j;
    j << -10.0, 10.0, 1.0, 1.0;
    return Eigen::MatrixXd(j);
  };
  const JacobianFn jac = [&](const Eigen::VectorXd& x, const Eigen::VectorXd&, int*) {
    return J(x);
  };
  const NormalEquationsFn normal = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& r,
                                       Eigen::MatrixXd* jtj, Eigen::VectorXd* jtr, int*) {
    *jtj = J(x).transpose() * J(x);
    *jtr = J(x).transpose() * r;
  };
  const Eigen::Vector2d lower(-10.0, -10.0), upper(1.0, 10.0), start(-5.0, 6.0);
  LmOptions o;
  o.hold_active_bounds = true;
  const LmResult a = LevenbergMarquardt(Valley, start, lower, upper, o, {}, jac);
  const LmResult b = LevenbergMarquardt(Valley, start, lower, upper, o, {}, {}, normal);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_NEAR((a.x - b.x).norm(), 0.0, 1e-12);
  EXPECT_EQ(a.cost_history.size(), static_cast<std::size_t>(a.iterations) + 1);
  o.broyden = true;
  EXPECT_THROW(LevenbergMarquardt(Valley, start, lower, upper, o, {}, {}, normal),
               std::invalid_argument);
}

TEST(LevenbergMarquardt, CostOnlyPathMatchesTheResidualPath) {
  // The same normal equations with r formed or only its cost: identical iterates, no residual.
  const auto J = [](const Eigen::VectorXd&) {
    Eigen::Matrix2d j;
    j << -10.0, 10.0, 1.0, 1.0;
    return Eigen::MatrixXd(j);
  };
  const NormalEquationsFn normal = [&](const Eigen::VectorXd& x, const Eigen::VectorXd&,
                                       Eigen::MatrixXd* jtj, Eigen::VectorXd* jtr, int*) {
    *jtj = J(x).transpose() * J(x);
    *jtr = J(x).transpose() * Valley(x);
  };
  const CostFn cost = [](const Eigen::VectorXd& x) { return Valley(x).squaredNorm(); };
  const Eigen::Vector2d lower(-10.0, -10.0), upper(1.0, 10.0), start(-5.0, 6.0);
  LmOptions o;
  o.hold_active_bounds = true;
  const LmResult a = LevenbergMarquardt(Valley, start, lower, upper, o, {}, {}, normal);
  const LmResult b = LevenbergMarquardtOnCost(cost, start, lower, upper, normal, o);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.evaluations, b.evaluations);
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.cost_history, b.cost_history);
  EXPECT_EQ(b.residual.size(), 0);
  EXPECT_THROW(LevenbergMarquardtOnCost(cost, start, lower, upper, {}, o), std::invalid_argument);
  o.broyden = true;
  EXPECT_THROW(LevenbergMarquardtOnCost(cost, start, lower, upper, normal, o),
               std::invalid_argument);
}

TEST(ConvergenceReport, JsonYamlAndWarningNameTheBestRun) {
  const std::vector<Convergence> runs = {{true, "step_below_tolerance", 7},
                                         {false, "iteration_limit", 30}};
  const std::string json = ConvergenceJson(runs, 1).Dump(0);
  EXPECT_NE(json.find("\"best_run\":1"), std::string::npos) << json;
  EXPECT_NE(json.find("\"converged\":false,\"stop_reason\":\"iteration_limit\""), std::string::npos)
      << json;
  const std::string yaml = ConvergenceYaml("convergence", runs, 1, 0);
  EXPECT_NE(yaml.find("  converged: false\n  stop_reason: iteration_limit\n"), std::string::npos)
      << yaml;
  EXPECT_EQ(NotConvergedWarning("fit", runs, 0), "");
  EXPECT_EQ(NotConvergedWarning("fit", runs, 1),
            "fit: the best local run (2 of 2) did not converge (iteration_limit after 30 "
            "iterations)");
}

}  // namespace
}  // namespace fesim::identification
