#include "sim/integrator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "muscles/activation.h"
#include "sim/default_model.h"

namespace fesim::sim {
namespace {

constexpr double kAgreementTol = 1e-6;  // rad, issue 2
constexpr double kActivationTol = 1e-6;

std::vector<double> Times(double duration, double dt) {
  std::vector<double> t;
  for (double x = 0.0; x <= duration + 1e-12; x += dt) t.push_back(x);
  return t;
}

TEST(Integrator, CvodesAndSimbodyAgreeOnFiveSecondTrial) {
  const UpperLimbModel model(DefaultModelParams());
  StimulationSchedule stim;
  stim.times = {0.0, 1.0, 2.5, 4.0};
  stim.values = {{0, 0, 0, 0, 0, 0},
                 {180, 60, 150, 0, 100, 50},
                 {40, 220, 0, 160, 30, 120},
                 {0, 0, 0, 0, 0, 0}};
  const auto times = Times(5.0, 0.05);
  std::vector<std::vector<double>> a, b;
  IntegratorParams cv{IntegratorParams::Method::kCvodes, 1e-9};
  IntegratorParams rk{IntegratorParams::Method::kSimbodyRkMerson, 1e-9};
  SimTK::State s1 = model.MakeInitialState();
  IntegrateTrial(model, cv, stim, times, &s1,
                 [&](const SimTK::State& s) { a.push_back(model.GetQs(s)); });
  SimTK::State s2 = model.MakeInitialState();
  IntegrateTrial(model, rk, stim, times, &s2,
                 [&](const SimTK::State& s) { b.push_back(model.GetQs(s)); });
  ASSERT_EQ(a.size(), b.size());
  double worst = 0.0, moved = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    for (int i = 0; i < kNumCoordinates; ++i) {
      worst = std::max(worst, std::abs(a[k][i] - b[k][i]));
      moved = std::max(moved, std::abs(a[k][i] - a[0][i]));
    }
  }
  EXPECT_GT(moved, 0.1);
  EXPECT_LT(worst, kAgreementTol);
  std::printf("CVODES vs Simbody RKM: max |dq| = %.3g rad over 5 s (largest excursion %.3g rad)\n",
              worst, moved);
}

TEST(Integrator, LockedActivationFollowsAnalyticStepResponse) {
  // With every coordinate locked the activation of each muscle is exactly eq. (6)'s step
  // response to w = H_IRC(A u): checks the z-state wiring, the schedule and the breakpoints.
  ModelParams p = DefaultModelParams();
  for (auto& c : p.coordinates) c.mode = CoordinateMode::kLocked;
  const UpperLimbModel model(p);
  StimulationSchedule stim;
  stim.times = {0.3};
  stim.values = {{0, 0, 200, 0, 0, 0}};
  const int bic = 8;
  ASSERT_EQ(p.muscles[bic].name, "BIC");
  const double w = muscles::Recruitment(p.muscles[bic].recruitment, 200.0);
  SimTK::State s = model.MakeInitialState();
  IntegrateTrial(model, {IntegratorParams::Method::kCvodes, 1e-10}, stim, Times(2.0, 0.1), &s,
                 [&](const SimTK::State& st) {
                   const double expected =
                       muscles::ActivationStepResponse(p.muscles[bic].activation_omega_rad_s, w,
                                                       st.getTime() - 0.3)
                           .a;
                   EXPECT_NEAR(model.ComputeMuscles(st).activation[bic], expected, kActivationTol);
                 });
}

TEST(Integrator, LockedCoordinatesLeftOutOfCvodesStillAgreeWithSimbody) {
  // Hand rig: shoulder, elbow and pro/supination locked. CVODES advances only the free q, u (its
  // tolerance scaled to keep the same error norm); Simbody's RKM integrates the whole state. The
  // free joints must agree to the issue-2 tolerance and the locked ones stay exactly put.
  ModelParams p = DefaultModelParams();
  for (int c : {kShoulderElvPlane, kShoulderElevation, kShoulderRotation, kElbowFlexion, kProSup}) {
    p.coordinates[c].mode = CoordinateMode::kLocked;
  }
  const UpperLimbModel model(p);
  SimTK::State s0 = model.MakeInitialState();
  EXPECT_EQ(model.LockedYIndices(s0).size(), 10u);
  StimulationSchedule stim;
  stim.times = {0.0, 0.5, 2.0};
  stim.values = {{0, 0, 0, 0, 0, 0}, {200, 80, 0, 0, 0, 0}, {60, 250, 0, 0, 0, 0}};
  const auto times = Times(3.0, 0.05);
  std::vector<std::vector<double>> a, b;
  SimTK::State s1 = s0;
  IntegrateTrial(model, {IntegratorParams::Method::kCvodes, 1e-9}, stim, times, &s1,
                 [&](const SimTK::State& s) { a.push_back(model.GetQs(s)); });
  SimTK::State s2 = s0;
  IntegrateTrial(model, {IntegratorParams::Method::kSimbodyRkMerson, 1e-9}, stim, times, &s2,
                 [&](const SimTK::State& s) { b.push_back(model.GetQs(s)); });
  ASSERT_EQ(a.size(), b.size());
  double worst = 0.0, moved = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    for (int i = 0; i < kNumCoordinates; ++i) {
      if (p.coordinates[i].mode == CoordinateMode::kLocked) {
        EXPECT_EQ(a[k][i], p.coordinates[i].initial_rad);
        continue;
      }
      worst = std::max(worst, std::abs(a[k][i] - b[k][i]));
      moved = std::max(moved, std::abs(a[k][i] - a[0][i]));
    }
  }
  EXPECT_GT(moved, 0.1);
  EXPECT_LT(worst, kAgreementTol);
  std::printf("hand rig, CVODES (free q, u only) vs Simbody RKM: max |dq| = %.3g rad\n", worst);
}

TEST(Integrator, ScheduleHoldsValues) {
  StimulationSchedule s;
  s.times = {1.0, 2.0};
  s.values = {{10}, {20}};
  EXPECT_EQ(s.At(0.5, 1)[0], 0.0);
  EXPECT_EQ(s.At(1.0, 1)[0], 10.0);
  EXPECT_EQ(s.At(1.99, 1)[0], 10.0);
  EXPECT_EQ(s.At(7.0, 1)[0], 20.0);
}

}  // namespace
}  // namespace fesim::sim
