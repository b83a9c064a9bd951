#include "sim/serial_vector.h"

#include <nvector/nvector_serial.h>

#include <cmath>
#include <stdexcept>

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

}  // namespace

void UseCompiledSerialOps(N_Vector v) {
  if (v == nullptr || N_VGetVectorID(v) != SUNDIALS_NVEC_SERIAL) {
    throw std::invalid_argument("UseCompiledSerialOps: not a serial N_Vector");
  }
  v->ops->nvlinearsum = LinearSum;
  v->ops->nvscale = Scale;
  v->ops->nvwrmsnorm = WrmsNorm;
  v->ops->nvwsqrsumlocal = WSqrSumLocal;
}

}  // namespace fesim::sim
