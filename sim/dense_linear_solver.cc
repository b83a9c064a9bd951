#include "sim/dense_linear_solver.h"

#include <sunmatrix/sunmatrix_dense.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "sim/compiled_size.h"

namespace fesim::sim {

sunindextype DenseLuFactor(double* a, sunindextype n, sunindextype* p) {
  for (sunindextype k = 0; k < n; ++k) {
    double* col_k = a + k * n;
    sunindextype l = k;  // the pivot row: the largest |a(i, k)|, the first of equals
    for (sunindextype i = k + 1; i < n; ++i) {
      if (std::abs(col_k[i]) > std::abs(col_k[l])) l = i;
    }
    p[k] = l;
    if (col_k[l] == 0.0) return k + 1;
    if (l != k) {  // swap rows k and l over every column
      for (sunindextype j = 0; j < n; ++j) {
        double* col_j = a + j * n;
        const double t = col_j[l];
        col_j[l] = col_j[k];
        col_j[k] = t;
      }
    }
    // The multipliers a(i, k) / a(k, k) below the diagonal (as a product with the reciprocal),
    // then each later column j: a(i, j) −= a(k, j) · multiplier_i, skipped where a(k, j) = 0.
    const double mult = 1.0 / col_k[k];
    for (sunindextype i = k + 1; i < n; ++i) col_k[i] *= mult;
    for (sunindextype j = k + 1; j < n; ++j) {
      double* col_j = a + j * n;
      const double a_kj = col_j[k];
      if (a_kj == 0.0) continue;
      for (sunindextype i = k + 1; i < n; ++i) col_j[i] -= a_kj * col_k[i];
    }
  }
  return 0;
}

namespace {

/// DenseLuSolve's substitutions for an n known when compiled (N > 0) or not (N = 0, n given):
/// the same operations in the same order either way; a known n lets the compiler unroll the short
/// loops of the models' systems (10 components on the hand rig, 20 on the default arm: −24 % of
/// the solves' instructions on the hand rig, docs/performance.md "Full-model fit local step").
struct LuSolveKernel {
  template <std::size_t N>
  static void Run(std::size_t n_runtime, const double* __restrict__ a,
                  const sunindextype* __restrict__ p, double* __restrict__ b) {
    const auto n = static_cast<sunindextype>(N > 0 ? N : n_runtime);
    for (sunindextype k = 0; k < n; ++k) {  // b ← P b
      const sunindextype pk = p[k];
      if (pk != k) {
        const double t = b[k];
        b[k] = b[pk];
        b[pk] = t;
      }
    }
    for (sunindextype k = 0; k + 1 < n; ++k) {  // L y = b (unit diagonal)
      const double* col_k = a + k * n;
      for (sunindextype i = k + 1; i < n; ++i) b[i] -= col_k[i] * b[k];
    }
    for (sunindextype k = n - 1; k > 0; --k) {  // U x = y
      const double* col_k = a + k * n;
      b[k] /= col_k[k];
      for (sunindextype i = 0; i < k; ++i) b[i] -= col_k[i] * b[k];
    }
    if (n > 0) b[0] /= a[0];
  }
};

}  // namespace

void DenseLuSolve(const double* a, sunindextype n, const sunindextype* p, double* b) {
  RunForSize<LuSolveKernel>(static_cast<std::size_t>(std::max<sunindextype>(n, 0)), a, p, b);
}

namespace {

struct Content {
  std::vector<sunindextype> pivots;
  sunindextype last_flag = 0;
};

Content* ContentOf(SUNLinearSolver s) { return static_cast<Content*>(s->content); }

SUNLinearSolver_Type GetType(SUNLinearSolver) { return SUNLINEARSOLVER_DIRECT; }
SUNLinearSolver_ID GetId(SUNLinearSolver) { return SUNLINEARSOLVER_CUSTOM; }
int Initialize(SUNLinearSolver s) {
  ContentOf(s)->last_flag = SUNLS_SUCCESS;
  return SUNLS_SUCCESS;
}

int Setup(SUNLinearSolver s, SUNMatrix a) {
  Content* c = ContentOf(s);
  const auto n = static_cast<sunindextype>(c->pivots.size());
  if (a == nullptr || SUNMatGetID(a) != SUNMATRIX_DENSE || SUNDenseMatrix_Rows(a) != n ||
      SUNDenseMatrix_Columns(a) != n) {
    c->last_flag = SUNLS_ILL_INPUT;
    return SUNLS_ILL_INPUT;
  }
  c->last_flag = DenseLuFactor(SUNDenseMatrix_Data(a), n, c->pivots.data());
  return c->last_flag > 0 ? SUNLS_LUFACT_FAIL : SUNLS_SUCCESS;
}

int Solve(SUNLinearSolver s, SUNMatrix a, N_Vector x, N_Vector b, sunrealtype /*tol*/) {
  Content* c = ContentOf(s);
  const auto n = static_cast<sunindextype>(c->pivots.size());
  double* xd = N_VGetArrayPointer(x);
  const double* bd = N_VGetArrayPointer(b);
  if (xd != bd) std::copy(bd, bd + n, xd);
  DenseLuSolve(SUNDenseMatrix_Data(a), n, c->pivots.data(), xd);
  c->last_flag = SUNLS_SUCCESS;
  return SUNLS_SUCCESS;
}

sunindextype LastFlag(SUNLinearSolver s) { return ContentOf(s)->last_flag; }

int Space(SUNLinearSolver s, long* real_words, long* int_words) {
  *real_words = 0;
  *int_words = 2 + static_cast<long>(ContentOf(s)->pivots.size());
  return SUNLS_SUCCESS;
}

int Free(SUNLinearSolver s) {
  if (s == nullptr) return SUNLS_SUCCESS;
  delete ContentOf(s);
  s->content = nullptr;
  SUNLinSolFreeEmpty(s);
  return SUNLS_SUCCESS;
}

int CopyMatrix(SUNMatrix a, SUNMatrix b) {
  if (SUNMatGetID(b) != SUNMATRIX_DENSE || SUNDenseMatrix_Rows(a) != SUNDenseMatrix_Rows(b) ||
      SUNDenseMatrix_Columns(a) != SUNDenseMatrix_Columns(b)) {
    return SUNMAT_ILL_INPUT;
  }
  const double* from = SUNDenseMatrix_Data(a);
  std::copy(from, from + SUNDenseMatrix_LData(a), SUNDenseMatrix_Data(b));
  return SUNMAT_SUCCESS;
}

int ScaleAddIdentity(sunrealtype c, SUNMatrix a) {  // A ← c A + I, element by element
  const sunindextype rows = SUNDenseMatrix_Rows(a), cols = SUNDenseMatrix_Columns(a);
  double* d = SUNDenseMatrix_Data(a);
  for (sunindextype j = 0; j < cols; ++j) {
    for (sunindextype i = 0; i < rows; ++i) {
      double& x = d[j * rows + i];
      x *= c;
      if (i == j) x += 1.0;
    }
  }
  return SUNMAT_SUCCESS;
}

SUNMatrix CloneMatrix(SUNMatrix a) {
  SUNMatrix b = SUNDenseMatrix(SUNDenseMatrix_Rows(a), SUNDenseMatrix_Columns(a), a->sunctx);
  if (b != nullptr) UseCompiledDenseMatrixOps(b);
  return b;
}

}  // namespace

void UseCompiledDenseMatrixOps(SUNMatrix a) {
  if (a == nullptr || SUNMatGetID(a) != SUNMATRIX_DENSE) {
    throw std::invalid_argument("UseCompiledDenseMatrixOps: not a dense SUNMatrix");
  }
  a->ops->copy = CopyMatrix;
  a->ops->scaleaddi = ScaleAddIdentity;
  a->ops->clone = CloneMatrix;
}

SUNLinearSolver NewDenseLinearSolver(N_Vector y, SUNMatrix a, SUNContext sunctx) {
  if (y == nullptr || a == nullptr || SUNMatGetID(a) != SUNMATRIX_DENSE ||
      SUNDenseMatrix_Rows(a) != SUNDenseMatrix_Columns(a) ||
      N_VGetLength(y) != SUNDenseMatrix_Rows(a)) {
    return nullptr;
  }
  SUNLinearSolver s = SUNLinSolNewEmpty(sunctx);
  if (s == nullptr) return nullptr;
  s->ops->gettype = GetType;
  s->ops->getid = GetId;
  s->ops->initialize = Initialize;
  s->ops->setup = Setup;
  s->ops->solve = Solve;
  s->ops->lastflag = LastFlag;
  s->ops->space = Space;
  s->ops->free = Free;
  auto* content = new Content;
  content->pivots.assign(static_cast<std::size_t>(SUNDenseMatrix_Rows(a)), 0);
  s->content = content;
  return s;
}

}  // namespace fesim::sim
