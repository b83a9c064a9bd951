#include "sim/serial_vector.h"

#include <nvector/nvector_serial.h>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace fesim::sim {
namespace {

// nvector_serial.c's cases of N_VLinearSum, each with its own loop (VSum, VDiff, VLin1, VLin2,
// VScaleSum, VScaleDiff, Vaxpy): the operations differ between them (c (x + y) is not
// c x + c y), so the dispatch is kept as it is.
void Axpy(double a, const double* x, double* y, sunindextype n) {
  if (a == 1.0) {
    for (sunindextype i = 0; i < n; ++i) y[i] += x[i];
  } else if (a == -1.0) {
    for (sunindextype i = 0; i < n; ++i) y[i] -= x[i];
  } else {
    for (sunindextype i = 0; i < n; ++i) y[i] += a * x[i];
  }
}

void LinearSum(sunrealtype a, N_Vector x, sunrealtype b, N_Vector y, N_Vector z) {
  const sunindextype n = NV_LENGTH_S(x);
  const double* xd = NV_DATA_S(x);
  const double* yd = NV_DATA_S(y);
  double* zd = NV_DATA_S(z);
  if (b == 1.0 && z == y) return Axpy(a, xd, zd, n);  // y ← a x + y
  if (a == 1.0 && z == x) return Axpy(b, yd, zd, n);  // x ← b y + x
  if (a == 1.0 && b == 1.0) {
    for (sunindextype i = 0; i < n; ++i) zd[i] = xd[i] + yd[i];
    return;
  }
  bool test = a == 1.0 && b == -1.0;
  if (test || (a == -1.0 && b == 1.0)) {  // z = v2 − v1
    const double* v1 = test ? yd : xd;
    const double* v2 = test ? xd : yd;
    for (sunindextype i = 0; i < n; ++i) zd[i] = v2[i] - v1[i];
    return;
  }
  test = a == 1.0;
  if (test || b == 1.0) {  // z = c v1 + v2
    const double c = test ? b : a;
    const double* v1 = test ? yd : xd;
    const double* v2 = test ? xd : yd;
    for (sunindextype i = 0; i < n; ++i) zd[i] = (c * v1[i]) + v2[i];
    return;
  }
  test = a == -1.0;
  if (test || b == -1.0) {  // z = c v1 − v2
    const double c = test ? b : a;
    const double* v1 = test ? yd : xd;
    const double* v2 = test ? xd : yd;
    for (sunindextype i = 0; i < n; ++i) zd[i] = (c * v1[i]) - v2[i];
    return;
  }
  if (a == b) {
    for (sunindextype i = 0; i < n; ++i) zd[i] = a * (xd[i] + yd[i]);
    return;
  }
  if (a == -b) {
    for (sunindextype i = 0; i < n; ++i) zd[i] = a * (xd[i] - yd[i]);
    return;
  }
  for (sunindextype i = 0; i < n; ++i) zd[i] = (a * xd[i]) + (b * yd[i]);
}

void Scale(sunrealtype c, N_Vector x, N_Vector z) {
  const sunindextype n = NV_LENGTH_S(x);
  const double* xd = NV_DATA_S(x);
  double* zd = NV_DATA_S(z);
  if (z == x) {
    for (sunindextype i = 0; i < n; ++i) zd[i] *= c;
  } else if (c == 1.0) {
    for (sunindextype i = 0; i < n; ++i) zd[i] = xd[i];
  } else if (c == -1.0) {
    for (sunindextype i = 0; i < n; ++i) zd[i] = -xd[i];
  } else {
    for (sunindextype i = 0; i < n; ++i) zd[i] = c * xd[i];
  }
}

// The element-wise operations of the error weights (cvEwtSet: |y|, then 1 / (rtol |y| + atol)) and
// of CVODES' zeroed corrections, for every sensitivity at every step of an augmented integration.
void Const(sunrealtype c, N_Vector z) {
  double* zd = NV_DATA_S(z);
  for (sunindextype i = 0; i < NV_LENGTH_S(z); ++i) zd[i] = c;
}

void Abs(N_Vector x, N_Vector z) {
  const double* xd = NV_DATA_S(x);
  double* zd = NV_DATA_S(z);
  for (sunindextype i = 0; i < NV_LENGTH_S(x); ++i) zd[i] = std::abs(xd[i]);
}

void Inv(N_Vector x, N_Vector z) {
  const double* xd = NV_DATA_S(x);
  double* zd = NV_DATA_S(z);
  for (sunindextype i = 0; i < NV_LENGTH_S(x); ++i) zd[i] = 1.0 / xd[i];
}

void AddConst(N_Vector x, sunrealtype b, N_Vector z) {
  const double* xd = NV_DATA_S(x);
  double* zd = NV_DATA_S(z);
  for (sunindextype i = 0; i < NV_LENGTH_S(x); ++i) zd[i] = xd[i] + b;
}

sunrealtype* ArrayPointer(N_Vector v) { return NV_DATA_S(v); }

sunrealtype WSqrSumLocal(N_Vector x, N_Vector w) {
  const sunindextype n = NV_LENGTH_S(x);
  const double* xd = NV_DATA_S(x);
  const double* wd = NV_DATA_S(w);
  double sum = 0.0;
  for (sunindextype i = 0; i < n; ++i) {
    const double prod = xd[i] * wd[i];
    sum += prod * prod;
  }
  return sum;
}

sunrealtype WrmsNorm(N_Vector x, N_Vector w) {
  const double mean = WSqrSumLocal(x, w) / static_cast<double>(NV_LENGTH_S(x));
  return mean <= 0.0 ? 0.0 : std::sqrt(mean);
}

// The fused and vector-array operations, each the arithmetic of the generic fallback in
// sundials_nvector.c that CVODES runs when a serial vector leaves them unset (the default of
// N_VNew_Serial): N_VLinearCombination is N_VScale(c₀, X₀, z) followed by N_VLinearSum(cᵢ, Xᵢ, 1,
// z, z) for i ≥ 1, i.e. per element z = ((c₀x₀ + c₁x₁) + c₂x₂) + …; the array forms apply the
// single-vector operation to each member. With c = ±1 these products are exact, so the special
// cases of LinearSum and Scale (x + y, y − x, −x) give the same bits as the products written out.
// One loop over the elements instead of one call through the operation table per vector.

/// z = Σ cᵢ Xᵢ in the fallback's order (X₀ may alias z; Xᵢ for i ≥ 1 may too, element-wise the
/// same).
void CombineInto(int nvec, const sunrealtype* c, N_Vector* X, double* zd, sunindextype n) {
  const double* x0 = NV_DATA_S(X[0]);
  for (sunindextype j = 0; j < n; ++j) zd[j] = c[0] * x0[j];
  for (int i = 1; i < nvec; ++i) {
    const double* xi = NV_DATA_S(X[i]);
    const double ci = c[i];
    for (sunindextype j = 0; j < n; ++j) zd[j] += ci * xi[j];
  }
}

int LinearCombination(int nvec, sunrealtype* c, N_Vector* X, N_Vector z) {
  if (nvec < 1) return -1;
  CombineInto(nvec, c, X, NV_DATA_S(z), NV_LENGTH_S(z));
  return 0;
}

/// Z[i] = a[i] x + Y[i] (the fallback: N_VLinearSum(a[i], x, 1, Y[i], Z[i])).
int ScaleAddMulti(int nvec, sunrealtype* a, N_Vector x, N_Vector* Y, N_Vector* Z) {
  if (nvec < 1) return -1;
  const sunindextype n = NV_LENGTH_S(x);
  const double* xd = NV_DATA_S(x);
  for (int i = 0; i < nvec; ++i) {
    const double* yd = NV_DATA_S(Y[i]);
    double* zd = NV_DATA_S(Z[i]);
    const double ai = a[i];
    for (sunindextype j = 0; j < n; ++j) zd[j] = (ai * xd[j]) + yd[j];
  }
  return 0;
}

int LinearSumVectorArray(int nvec, sunrealtype a, N_Vector* X, sunrealtype b, N_Vector* Y,
                         N_Vector* Z) {
  if (nvec < 1) return -1;
  for (int i = 0; i < nvec; ++i) LinearSum(a, X[i], b, Y[i], Z[i]);
  return 0;
}

int ScaleVectorArray(int nvec, sunrealtype* c, N_Vector* X, N_Vector* Z) {
  if (nvec < 1) return -1;
  for (int i = 0; i < nvec; ++i) Scale(c[i], X[i], Z[i]);
  return 0;
}

int ConstVectorArray(int nvec, sunrealtype c, N_Vector* Z) {
  if (nvec < 1) return -1;
  for (int i = 0; i < nvec; ++i) {
    double* zd = NV_DATA_S(Z[i]);
    for (sunindextype j = 0; j < NV_LENGTH_S(Z[i]); ++j) zd[j] = c;
  }
  return 0;
}

int WrmsNormVectorArray(int nvec, N_Vector* X, N_Vector* W, sunrealtype* norms) {
  if (nvec < 1) return -1;
  for (int i = 0; i < nvec; ++i) norms[i] = WrmsNorm(X[i], W[i]);
  return 0;
}

/// Z[k][i] = a[k] X[i] + Y[k][i] (the fallback: N_VScaleAddMulti of each X[i]).
int ScaleAddMultiVectorArray(int nvec, int nsum, sunrealtype* a, N_Vector* X, N_Vector** Y,
                             N_Vector** Z) {
  if (nvec < 1 || nsum < 1) return -1;
  for (int i = 0; i < nvec; ++i) {
    const sunindextype n = NV_LENGTH_S(X[i]);
    const double* xd = NV_DATA_S(X[i]);
    for (int k = 0; k < nsum; ++k) {
      const double* yd = NV_DATA_S(Y[k][i]);
      double* zd = NV_DATA_S(Z[k][i]);
      const double ak = a[k];
      for (sunindextype j = 0; j < n; ++j) zd[j] = (ak * xd[j]) + yd[j];
    }
  }
  return 0;
}

/// Z[i] = Σₖ c[k] X[k][i] (the fallback: N_VLinearCombination of each member).
int LinearCombinationVectorArray(int nvec, int nsum, sunrealtype* c, N_Vector** X, N_Vector* Z) {
  if (nvec < 1 || nsum < 1) return -1;
  constexpr int kStack = 16;
  N_Vector stack[kStack];
  std::vector<N_Vector> heap;
  N_Vector* column = stack;
  if (nsum > kStack) {
    heap.resize(static_cast<std::size_t>(nsum));
    column = heap.data();
  }
  for (int i = 0; i < nvec; ++i) {
    for (int k = 0; k < nsum; ++k) column[k] = X[k][i];
    CombineInto(nsum, c, column, NV_DATA_S(Z[i]), NV_LENGTH_S(Z[i]));
  }
  return 0;
}

}  // namespace

void UseCompiledSerialOps(N_Vector v) {
  if (v == nullptr || N_VGetVectorID(v) != SUNDIALS_NVEC_SERIAL) {
    throw std::invalid_argument("UseCompiledSerialOps: not a serial N_Vector");
  }
  v->ops->nvlinearsum = LinearSum;
  v->ops->nvscale = Scale;
  v->ops->nvwrmsnorm = WrmsNorm;
  v->ops->nvconst = Const;
  v->ops->nvabs = Abs;
  v->ops->nvinv = Inv;
  v->ops->nvaddconst = AddConst;
  v->ops->nvgetarraypointer = ArrayPointer;
  v->ops->nvwsqrsumlocal = WSqrSumLocal;
  v->ops->nvlinearcombination = LinearCombination;
  v->ops->nvscaleaddmulti = ScaleAddMulti;
  v->ops->nvlinearsumvectorarray = LinearSumVectorArray;
  v->ops->nvscalevectorarray = ScaleVectorArray;
  v->ops->nvconstvectorarray = ConstVectorArray;
  v->ops->nvwrmsnormvectorarray = WrmsNormVectorArray;
  v->ops->nvscaleaddmultivectorarray = ScaleAddMultiVectorArray;
  v->ops->nvlinearcombinationvectorarray = LinearCombinationVectorArray;
}

}  // namespace fesim::sim
