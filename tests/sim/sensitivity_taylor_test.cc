#include "sim/sensitivity_taylor.h"

#include <cvodes/cvodes.h>
#include <gtest/gtest.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunmatrix/sunmatrix_dense.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "sim/dense_linear_solver.h"

namespace fesim::sim {
namespace {

// A damped, driven Duffing oscillator with two parameters (stiffness p0, damping p1):
// y0' = y1, y1' = −p0 y0 − p1 y1 − 0.5 y0³ + sin(3t). Nonlinear and driven, so CVODES varies
// its step and order.
int Rhs(sunrealtype t, N_Vector y, N_Vector ydot, void* user) {
  const double* p = static_cast<const double*>(user);
  const double* v = N_VGetArrayPointer(y);
  double* d = N_VGetArrayPointer(ydot);
  d[0] = v[1];
  d[1] = -p[0] * v[0] - p[1] * v[1] - 0.5 * v[0] * v[0] * v[0] + std::sin(3.0 * t);
  return 0;
}

TEST(SensitivityTaylor, ReportedSensitivitiesEqualCvodesInterpolation) {
  // At 400 report times over 8 s (about three reports per CVODES step, orders up to 5), the Taylor
  // polynomial read once per step gives the sensitivities CVodeGetSens interpolates from the
  // Nordsieck history, to round-off, for the components asked (both, or y1 alone).
  SUNContext ctx = nullptr;
  ASSERT_EQ(SUNContext_Create(nullptr, &ctx), 0);
  double p[2] = {4.0, 0.3};
  double pbar[2] = {4.0, 0.3};
  N_Vector y = N_VNew_Serial(2, ctx);
  NV_Ith_S(y, 0) = 1.0;
  NV_Ith_S(y, 1) = 0.0;
  void* mem = CVodeCreate(CV_BDF, ctx);
  ASSERT_EQ(CVodeInit(mem, Rhs, 0.0, y), CV_SUCCESS);
  ASSERT_EQ(CVodeSStolerances(mem, 1e-4, 1e-6), CV_SUCCESS);
  ASSERT_EQ(CVodeSetUserData(mem, p), CV_SUCCESS);
  SUNMatrix a = SUNDenseMatrix(2, 2, ctx);
  SUNLinearSolver ls = NewDenseLinearSolver(y, a, ctx);
  ASSERT_EQ(CVodeSetLinearSolver(mem, ls, a), CV_SUCCESS);
  N_Vector* yS = N_VCloneVectorArray(2, y);
  for (int k = 0; k < 2; ++k) N_VConst(0.0, yS[k]);
  ASSERT_EQ(CVodeSensInit(mem, 2, CV_STAGGERED, nullptr, yS), CV_SUCCESS);
  ASSERT_EQ(CVodeSetSensParams(mem, p, pbar, nullptr), CV_SUCCESS);
  ASSERT_EQ(CVodeSensEEtolerances(mem), CV_SUCCESS);

  SensitivityTaylor both({0, 1}, 2), second({1}, 2);
  std::vector<double> ours, ours1;
  int max_order = 0, compared = 0;
  double worst = 0.0;
  for (int i = 1; i <= 400; ++i) {
    const double t_out = 0.02 * i;
    double t = 0.0;
    ASSERT_GE(CVode(mem, t_out, y, &t, CV_NORMAL), 0);
    ASSERT_EQ(CVodeGetSens(mem, &t, yS), CV_SUCCESS);
    ASSERT_EQ(both.Evaluate(mem, y, t_out, &ours), 0);
    ASSERT_EQ(second.Evaluate(mem, y, t_out, &ours1), 0);
    int order = 0;
    CVodeGetLastOrder(mem, &order);
    max_order = std::max(max_order, order);
    for (int k = 0; k < 2; ++k) {
      for (int c = 0; c < 2; ++c) {
        const double ref = NV_Ith_S(yS[k], c);
        worst = std::max(worst, std::abs(ours[k * 2 + c] - ref) / (std::abs(ref) + 1e-3));
        ++compared;
      }
      EXPECT_EQ(ours1[k], ours[k * 2 + 1]);  // the same polynomial, component 1 alone
    }
  }
  long steps = 0;
  CVodeGetNumSteps(mem, &steps);
  EXPECT_LT(steps, 400 / 2);  // at least two reports per step on average
  EXPECT_GE(max_order, 3);
  EXPECT_EQ(compared, 1600);
  EXPECT_LT(worst, 1e-12);

  N_VDestroyVectorArray(yS, 2);
  CVodeFree(&mem);
  SUNLinSolFree(ls);
  SUNMatDestroy(a);
  N_VDestroy(y);
  SUNContext_Free(&ctx);
}

}  // namespace
}  // namespace fesim::sim
