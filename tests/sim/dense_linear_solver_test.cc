#include "sim/dense_linear_solver.h"

#include <gtest/gtest.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include <algorithm>
#include <cstring>
#include <random>
#include <vector>

namespace fesim::sim {
namespace {

/// A random n × n column-major matrix, with zeros in places (the skipped updates) and,
/// when `tie`, two equal candidates for the first pivot.
std::vector<double> RandomMatrix(int n, unsigned seed, bool tie) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  std::vector<double> a(static_cast<std::size_t>(n) * n);
  for (double& x : a) x = u(rng);
  for (int k = 0; n > 1 && k < n; k += 3) a[static_cast<std::size_t>(k) * n + (k + 1) % n] = 0.0;
  if (tie && n > 2) a[1] = -a[2];  // |a(1,0)| = |a(2,0)|
  return a;
}

bool SameBits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

TEST(DenseLinearSolver, SameBitsAsSundials) {
  // The factors, pivots and solutions of SUNDIALS' SUNDlsMat_denseGETRF / denseGETRS, bit for
  // bit, on a pivot tie and on every size up to past the compiled solves' (DenseLuSolve).
  for (int n = 1; n <= 40; ++n) {
    for (unsigned seed : {1u, 2u, 3u}) {
      std::vector<double> ours = RandomMatrix(n, seed, seed == 3u);
      std::vector<double> theirs = ours;
      std::vector<double*> cols(static_cast<std::size_t>(n));
      for (int j = 0; j < n; ++j) cols[j] = theirs.data() + static_cast<std::size_t>(j) * n;
      std::vector<sunindextype> p_ours(n), p_theirs(n);
      ASSERT_EQ(DenseLuFactor(ours.data(), n, p_ours.data()), 0);
      ASSERT_EQ(SUNDlsMat_denseGETRF(cols.data(), n, n, p_theirs.data()), 0);
      EXPECT_TRUE(SameBits(ours, theirs)) << "n " << n << " seed " << seed;
      EXPECT_EQ(p_ours, p_theirs);
      std::vector<double> b_ours(n), b_theirs;
      for (int i = 0; i < n; ++i) b_ours[i] = 0.7 * i - 1.3;
      b_theirs = b_ours;
      DenseLuSolve(ours.data(), n, p_ours.data(), b_ours.data());
      SUNDlsMat_denseGETRS(cols.data(), n, p_theirs.data(), b_theirs.data());
      EXPECT_TRUE(SameBits(b_ours, b_theirs)) << "n " << n << " seed " << seed;
    }
  }
}

TEST(DenseLinearSolver, SolvesThroughTheSundialsInterfaceAndReportsAZeroPivot) {
  SUNContext ctx = nullptr;
  ASSERT_EQ(SUNContext_Create(nullptr, &ctx), 0);
  const int n = 4;
  N_Vector x = N_VNew_Serial(n, ctx), b = N_VNew_Serial(n, ctx);
  SUNMatrix a = SUNDenseMatrix(n, n, ctx);
  SUNLinearSolver ls = NewDenseLinearSolver(x, a, ctx);
  ASSERT_NE(ls, nullptr);
  EXPECT_EQ(SUNLinSolGetType(ls), SUNLINEARSOLVER_DIRECT);
  EXPECT_EQ(SUNLinSolInitialize(ls), SUNLS_SUCCESS);
  // A = diag(1..4) + the all-ones matrix; b = A · (1, −2, 3, −4).
  const double want[n] = {1.0, -2.0, 3.0, -4.0};
  double* ad = SUNDenseMatrix_Data(a);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) ad[j * n + i] = 1.0 + (i == j ? i + 1.0 : 0.0);
  }
  for (int i = 0; i < n; ++i) {
    double s = 0.0;
    for (int j = 0; j < n; ++j) s += ad[j * n + i] * want[j];
    NV_Ith_S(b, i) = s;
  }
  ASSERT_EQ(SUNLinSolSetup(ls, a), SUNLS_SUCCESS);
  ASSERT_EQ(SUNLinSolSolve(ls, a, x, b, 0.0), SUNLS_SUCCESS);
  for (int i = 0; i < n; ++i) EXPECT_NEAR(NV_Ith_S(x, i), want[i], 1e-14);
  // A singular matrix: the factorisation fails recoverably at its zero pivot (column 2).
  for (int i = 0; i < n; ++i) ad[1 * n + i] = 0.0;
  EXPECT_EQ(SUNLinSolSetup(ls, a), SUNLS_LUFACT_FAIL);
  EXPECT_EQ(SUNLinSolLastFlag(ls), 2);
  // A non-square matrix is refused.
  SUNMatrix wide = SUNDenseMatrix(n, n + 1, ctx);
  EXPECT_EQ(NewDenseLinearSolver(x, wide, ctx), nullptr);
  SUNMatDestroy(wide);
  SUNLinSolFree(ls);
  SUNMatDestroy(a);
  N_VDestroy(x);
  N_VDestroy(b);
  SUNContext_Free(&ctx);
}

TEST(DenseLinearSolver, MatrixOperationsGiveSundialsBits) {
  // A ← c A + I, copy and clone against sunmatrix_dense's own functions, bit for bit.
  SUNContext ctx = nullptr;
  ASSERT_EQ(SUNContext_Create(nullptr, &ctx), 0);
  const int n = 7;
  SUNMatrix ours = SUNDenseMatrix(n, n, ctx), theirs = SUNDenseMatrix(n, n, ctx);
  UseCompiledDenseMatrixOps(ours);
  const std::vector<double> a = RandomMatrix(n, 5u, false);
  std::copy(a.begin(), a.end(), SUNDenseMatrix_Data(ours));
  std::copy(a.begin(), a.end(), SUNDenseMatrix_Data(theirs));
  ASSERT_EQ(SUNMatScaleAddI(-0.37, ours), SUNMAT_SUCCESS);
  ASSERT_EQ(SUNMatScaleAddI_Dense(-0.37, theirs), SUNMAT_SUCCESS);
  EXPECT_EQ(
      std::memcmp(SUNDenseMatrix_Data(ours), SUNDenseMatrix_Data(theirs), sizeof(double) * n * n),
      0);
  SUNMatrix clone = SUNMatClone(ours);  // CVODES' saved Jacobian: the same operations
  ASSERT_NE(clone, nullptr);
  EXPECT_EQ(clone->ops->scaleaddi, ours->ops->scaleaddi);
  ASSERT_EQ(SUNMatCopy(ours, clone), SUNMAT_SUCCESS);
  EXPECT_EQ(
      std::memcmp(SUNDenseMatrix_Data(clone), SUNDenseMatrix_Data(theirs), sizeof(double) * n * n),
      0);
  SUNMatrix wrong = SUNDenseMatrix(n, n + 1, ctx);
  EXPECT_EQ(SUNMatCopy(ours, wrong), SUNMAT_ILL_INPUT);
  SUNMatDestroy(wrong);
  SUNMatDestroy(clone);
  SUNMatDestroy(ours);
  SUNMatDestroy(theirs);
  SUNContext_Free(&ctx);
}

}  // namespace
}  // namespace fesim::sim
