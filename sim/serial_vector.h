// The hot operations of SUNDIALS' serial N_Vector, compiled with fesim.
//
// Debian 12's libsundials 6.4.1 is compiled without optimisation (sim/dense_linear_solver.h);
// CVODES' vector arithmetic — N_VLinearSum (its axpy form above all), N_VWrmsNorm, N_VScale —
// was 10 % of a 60 s default-model trial's instructions (docs/performance.md "Default model
// real-time factor"); the error weights' N_VAbs, N_VInv and the zeroed corrections' N_VConst,
// recomputed for each of 29 sensitivities at every step, 3.7 % of the full-model fit's augmented
// simulations. These are nvector_serial's own cases and loops, the same operations in
// the same order, so results are bit-identical (SerialVector.SameBitsAsSundials).
#pragma once

#include <sundials/sundials_nvector.h>

namespace fesim::sim {

/// Points v's N_VLinearSum, N_VScale, N_VWrmsNorm, N_VWSqrSumLocal, the element-wise N_VConst,
/// N_VAbs, N_VInv, N_VAddConst, N_VGetArrayPointer and the fused and vector-array operations at
/// the compiled forms. `v` must be a serial vector (N_VNew_Serial); its clones (N_VClone: CVODES'
/// internal vectors) inherit the operations.
void UseCompiledSerialOps(N_Vector v);

}  // namespace fesim::sim
