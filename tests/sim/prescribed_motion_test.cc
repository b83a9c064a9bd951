// Quintic Hermite prescribed trajectories (sim/prescribed_motion.h) and their Simbody Motion.
#include "sim/prescribed_motion.h"

#include <gtest/gtest.h>

#include <cmath>

#include "sim/default_model.h"
#include "sim/upper_limb_model.h"

namespace fesim::sim {
namespace {

constexpr double kSampleTol = 1e-12;       // reproduction of the samples themselves
constexpr double kValueTol = 1e-9;         // rad, between 100 Hz samples of a smooth function
constexpr double kRateTol = 1e-6;          // rad/s
constexpr double kAccelerationTol = 1e-3;  // rad/s²
constexpr double kContinuityTol = 1e-9;    // jump of q, q̇, q̈ across a knot (relative scale)

/// q(t) = sin(3t) + 0.2 t², with exact derivatives.
PrescribedSample Analytic(double t) {
  return {std::sin(3 * t) + 0.2 * t * t, 3 * std::cos(3 * t) + 0.4 * t, -9 * std::sin(3 * t) + 0.4};
}

TablePrescription Sampled(double t_end, double dt) {
  TablePrescription table;
  for (double t = 0.0; t <= t_end + 1e-12; t += dt) {
    const PrescribedSample s = Analytic(t);
    table.times_s.push_back(t);
    table.q_rad.push_back(s.q);
    table.qd_rad_s.push_back(s.qd);
    table.qdd_rad_s2.push_back(s.qdd);
  }
  return table;
}

TEST(QuinticHermiteSpline, ReproducesSamplesAndAnalyticFunctionBetweenThem) {
  const TablePrescription table = Sampled(2.0, 0.01);
  const QuinticHermiteSpline spline(table);
  for (std::size_t k = 0; k < table.times_s.size(); ++k) {
    const PrescribedSample s = spline.Evaluate(table.times_s[k]);
    EXPECT_NEAR(s.q, table.q_rad[k], kSampleTol);
    EXPECT_NEAR(s.qd, table.qd_rad_s[k], 1e-9);
    EXPECT_NEAR(s.qdd, table.qdd_rad_s2[k], 1e-6);
  }
  for (double t = 0.0013; t < 2.0; t += 0.0071) {
    const PrescribedSample s = spline.Evaluate(t), a = Analytic(t);
    EXPECT_NEAR(s.q, a.q, kValueTol) << t;
    EXPECT_NEAR(s.qd, a.qd, kRateTol) << t;
    EXPECT_NEAR(s.qdd, a.qdd, kAccelerationTol) << t;
  }
}

TEST(QuinticHermiteSpline, IsTwiceContinuouslyDifferentiableAcrossKnots) {
  const TablePrescription table = Sampled(1.0, 0.1);
  const QuinticHermiteSpline spline(table);
  for (std::size_t k = 1; k + 1 < table.times_s.size(); ++k) {
    const double t = table.times_s[k], e = 1e-10;
    const PrescribedSample l = spline.Evaluate(t - e), r = spline.Evaluate(t + e);
    EXPECT_NEAR(l.q, r.q, kContinuityTol);
    EXPECT_NEAR(l.qd, r.qd, 1e-7);
    EXPECT_NEAR(l.qdd, r.qdd, 1e-6);
  }
  // Derivatives are the derivatives of the value (central differences inside an interval).
  const double t = 0.537, h = 1e-5;
  const PrescribedSample m = spline.Evaluate(t - h), p = spline.Evaluate(t + h),
                         c = spline.Evaluate(t);
  EXPECT_NEAR((p.q - m.q) / (2 * h), c.qd, 1e-6);
  EXPECT_NEAR((p.qd - m.qd) / (2 * h), c.qdd, 1e-5);
}

TEST(QuinticHermiteSpline, HoldsEndValuesOutsideTheTable) {
  TablePrescription table{{0.0, 1.0}, {0.2, 0.7}, {0.0, 0.0}, {0.0, 0.0}};
  const QuinticHermiteSpline spline(table);
  EXPECT_EQ(spline.Evaluate(-1.0).q, 0.2);
  EXPECT_EQ(spline.Evaluate(5.0).q, 0.7);
  EXPECT_EQ(spline.Evaluate(5.0).qd, 0.0);
  // Rest-to-rest between two samples is the minimum-jerk quintic: half-way at the midpoint.
  EXPECT_NEAR(spline.Evaluate(0.5).q, 0.45, kSampleTol);
  EXPECT_NEAR(spline.Evaluate(0.5).qd, 0.5 * 1.875, kSampleTol);
}

TEST(QuinticHermiteSpline, RejectsBadTables) {
  EXPECT_THROW(QuinticHermiteSpline(TablePrescription{{0.0}, {0.0}, {0.0}, {0.0}}),
               std::invalid_argument);
  EXPECT_THROW(QuinticHermiteSpline(TablePrescription{{0.0, 1.0}, {0.0}, {0.0, 0.0}, {0.0, 0.0}}),
               std::invalid_argument);
  EXPECT_THROW(
      QuinticHermiteSpline(TablePrescription{{0.0, 0.0}, {0.0, 1.0}, {0.0, 0.0}, {0.0, 0.0}}),
      std::invalid_argument);
  EXPECT_THROW(QuinticHermiteSpline(
                   TablePrescription{{0.0, 1.0}, {0.0, std::nan("")}, {0.0, 0.0}, {0.0, 0.0}}),
               std::invalid_argument);
}

TEST(TableMotion, PrescribesTheCoordinateInTheModel) {
  ModelParams p = DefaultModelParams();
  CoordinateParams& elbow = p.coordinates[kElbowFlexion];
  elbow.mode = CoordinateMode::kPrescribed;
  elbow.table = Sampled(2.0, 0.01);
  const UpperLimbModel model(p);
  SimTK::State s = model.MakeInitialState();
  for (double t : {0.0, 0.333, 1.0, 1.777}) {
    s.setTime(t);
    model.system().prescribe(s);
    model.system().realize(s, SimTK::Stage::Acceleration);
    const auto& b = model.CoordinateBody(kElbowFlexion);
    const PrescribedSample a = Analytic(t);
    EXPECT_NEAR(b.getOneQ(s, 0), a.q, kValueTol);
    EXPECT_NEAR(b.getOneU(s, 0), a.qd, kRateTol);
    EXPECT_NEAR(b.getOneUDot(s, 0), a.qdd, kAccelerationTol);
  }
}

}  // namespace
}  // namespace fesim::sim
