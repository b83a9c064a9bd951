#include "sim/serial_vector.h"

#include <gtest/gtest.h>
#include <nvector/nvector_serial.h>

#include <cstring>
#include <vector>

namespace fesim::sim {
namespace {

bool SameBits(N_Vector a, N_Vector b) {
  return NV_LENGTH_S(a) == NV_LENGTH_S(b) &&
         std::memcmp(NV_DATA_S(a), NV_DATA_S(b), NV_LENGTH_S(a) * sizeof(double)) == 0;
}

void Fill(N_Vector v, double phase) {
  for (sunindextype i = 0; i < NV_LENGTH_S(v); ++i) NV_Ith_S(v, i) = 1.7 * (i + phase) / 3.0 - 2.1;
}

TEST(SerialVector, SameBitsAsSundials) {
  // Every case of nvector_serial's N_VLinearSum (a, b ∈ {±1, ±0.3, 0.7, 0}, z a third vector or
  // aliasing x or y), N_VScale (c ∈ {±1, 0.3}, in place or not) and N_VWrmsNorm, against
  // SUNDIALS' own functions, bit for bit.
  SUNContext ctx = nullptr;
  ASSERT_EQ(SUNContext_Create(nullptr, &ctx), 0);
  const sunindextype n = 23;
  N_Vector ours[3], theirs[3];
  for (int k = 0; k < 3; ++k) {
    ours[k] = N_VNew_Serial(n, ctx);
    theirs[k] = N_VNew_Serial(n, ctx);
  }
  UseCompiledSerialOps(ours[0]);
  N_Vector clone = N_VClone(ours[0]);  // clones inherit the operations
  EXPECT_EQ(clone->ops->nvlinearsum, ours[0]->ops->nvlinearsum);
  N_VDestroy(clone);
  UseCompiledSerialOps(ours[1]);
  UseCompiledSerialOps(ours[2]);
  const std::vector<double> values = {1.0, -1.0, 0.3, -0.3, 0.7, 0.0};
  const auto reset = [&] {
    for (int k = 0; k < 3; ++k) {
      Fill(ours[k], 0.37 * k);
      Fill(theirs[k], 0.37 * k);
    }
  };
  for (double a : values) {
    for (double b : values) {
      for (int z = 0; z < 3; ++z) {  // z = x, y or a third vector
        reset();
        N_VLinearSum(a, ours[0], b, ours[1], ours[z]);
        N_VLinearSum_Serial(a, theirs[0], b, theirs[1], theirs[z]);
        EXPECT_TRUE(SameBits(ours[z], theirs[z])) << "a " << a << " b " << b << " z " << z;
      }
    }
    for (int z : {0, 2}) {
      reset();
      N_VScale(a, ours[0], ours[z]);
      N_VScale_Serial(a, theirs[0], theirs[z]);
      EXPECT_TRUE(SameBits(ours[z], theirs[z])) << "c " << a << " z " << z;
    }
  }
  reset();
  const double want = N_VWrmsNorm_Serial(theirs[0], theirs[1]);
  const double got = N_VWrmsNorm(ours[0], ours[1]);
  EXPECT_EQ(std::memcmp(&want, &got, sizeof want), 0) << want << " " << got;
  N_VConst(0.0, ours[0]);
  EXPECT_EQ(N_VWrmsNorm(ours[0], ours[1]), 0.0);
  for (int k = 0; k < 3; ++k) {
    N_VDestroy(ours[k]);
    N_VDestroy(theirs[k]);
  }
  SUNContext_Free(&ctx);
}

}  // namespace
}  // namespace fesim::sim
