// The dense direct linear solver of CVODES' Newton iteration, compiled with fesim.
//
// SUNDIALS' own (SUNLinSol_Dense: SUNDlsMat_denseGETRF / denseGETRS, column-oriented LU with
// partial pivoting) as Debian 12 ships it (libsundials-dev 6.4.1, static and shared) is compiled
// without optimisation: every local lives on the stack (objdump -d of SUNDlsMat_denseGETRS in
// libsundials_cvodes), and on the 20-component default model the factorisation and the solves
// were 17 % of a trial's instructions (docs/performance.md "Default model real-time factor").
// This solver is the same algorithm with the same operations in the same order, so its results
// are bit-identical (`fesim simulate` writes byte-identical files; test
// DenseLinearSolver.SameBitsAsSundials), at the cost of optimised code.
#pragma once

#include <sundials/sundials_linearsolver.h>
#include <sundials/sundials_matrix.h>
#include <sundials/sundials_nvector.h>

namespace fesim::sim {

/// A SUNDIALS direct linear solver for the n × n dense SUNMatrix `a` (SUNDenseMatrix) and
/// serial vectors like `y`, with SUNLinSol_Dense's interface and results: setup factors A = P L U
/// in place (SUNLS_LUFACT_FAIL, recoverable, at an exactly zero pivot), solve overwrites x with
/// A⁻¹ b. Null when `a` is not square. Free with SUNLinSolFree.
SUNLinearSolver NewDenseLinearSolver(N_Vector y, SUNMatrix a, SUNContext sunctx);

/// Points a dense SUNMatrix's copy, A ← cA + I and clone at compiled forms of
/// sunmatrix_dense's own loops (bit-identical; its clones, e.g. CVODES' saved Jacobian, inherit
/// them). CVODES copies and shifts the iteration matrix at every linear-solver setup.
void UseCompiledDenseMatrixOps(SUNMatrix a);

/// LU with partial pivoting of the n × n column-major `a` in place, pivots into p (row swapped
/// with row k at step k): 0, or k + 1 when the k-th pivot is exactly zero (SUNDlsMat_denseGETRF).
sunindextype DenseLuFactor(double* a, sunindextype n, sunindextype* p);
/// b ← A⁻¹ b from DenseLuFactor's a and p (SUNDlsMat_denseGETRS).
void DenseLuSolve(const double* a, sunindextype n, const sunindextype* p, double* b);

}  // namespace fesim::sim
