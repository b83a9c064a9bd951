#include "sim/serial_vector.h"

#include <gtest/gtest.h>
#include <nvector/nvector_serial.h>

#include <algorithm>
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
  // aliasing x or y), N_VScale (c ∈ {±1, 0.3}, in place or not), N_VAbs, N_VInv, N_VAddConst,
  // N_VConst and N_VWrmsNorm, against
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
  // The element-wise operations of CVODES' error weights and zeroed corrections (Fill's values
  // cross zero; a −0 and a 0 entry give 1/x = ∓∞).
  reset();
  NV_Ith_S(ours[0], 3) = NV_Ith_S(theirs[0], 3) = -0.0;
  NV_Ith_S(ours[0], 4) = NV_Ith_S(theirs[0], 4) = 0.0;
  N_VAbs(ours[0], ours[2]);
  N_VAbs_Serial(theirs[0], theirs[2]);
  EXPECT_TRUE(SameBits(ours[2], theirs[2])) << "abs";
  N_VInv(ours[0], ours[1]);
  N_VInv_Serial(theirs[0], theirs[1]);
  EXPECT_TRUE(SameBits(ours[1], theirs[1])) << "inv";
  N_VAddConst(ours[0], -0.3, ours[0]);
  N_VAddConst_Serial(theirs[0], -0.3, theirs[0]);
  EXPECT_TRUE(SameBits(ours[0], theirs[0])) << "add const";
  N_VConst(-0.7, ours[2]);
  N_VConst_Serial(-0.7, theirs[2]);
  EXPECT_TRUE(SameBits(ours[2], theirs[2])) << "const";
  EXPECT_EQ(N_VGetArrayPointer(ours[2]), NV_DATA_S(ours[2]));
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

TEST(SerialVector, FusedAndArrayOperationsGiveTheFallbacksBits) {
  // The fused and vector-array operations against SUNDIALS' generic fallbacks (what CVODES runs on
  // a serial vector whose table leaves them unset: loops of N_VScale and N_VLinearSum), bit for
  // bit: coefficients ±1, 0 and others, the result aliasing the first vector or not.
  SUNContext ctx = nullptr;
  ASSERT_EQ(SUNContext_Create(nullptr, &ctx), 0);
  constexpr int kVectors = 5;
  const sunindextype n = 11;
  std::vector<N_Vector> ours, theirs;
  for (int k = 0; k < 2 * kVectors; ++k) {
    ours.push_back(N_VNew_Serial(n, ctx));
    theirs.push_back(N_VNew_Serial(n, ctx));
    UseCompiledSerialOps(ours.back());
  }
  ASSERT_EQ(theirs[0]->ops->nvlinearcombination, nullptr);  // the fallback is what CVODES ran
  ASSERT_NE(ours[0]->ops->nvlinearcombination, nullptr);
  const auto reset = [&] {
    for (int k = 0; k < 2 * kVectors; ++k) {
      Fill(ours[k], 0.29 * k);
      Fill(theirs[k], 0.29 * k);
    }
  };
  const auto same = [&](int from, int count) {
    for (int k = from; k < from + count; ++k) {
      if (!SameBits(ours[k], theirs[k])) return false;
    }
    return true;
  };
  std::vector<double> c = {1.0, -0.3, -1.0, 0.7, 0.0};
  for (double c0 : {1.0, -1.0, 0.45}) {
    c[0] = c0;
    for (int nvec : {1, 2, 3, kVectors}) {
      for (bool alias : {false, true}) {  // z = X[0] or a vector outside X
        reset();
        N_Vector* xo = ours.data();
        N_Vector* xt = theirs.data();
        N_Vector zo = alias ? ours[0] : ours[kVectors];
        N_Vector zt = alias ? theirs[0] : theirs[kVectors];
        ASSERT_EQ(N_VLinearCombination(nvec, c.data(), xo, zo), 0);
        ASSERT_EQ(N_VLinearCombination(nvec, c.data(), xt, zt), 0);
        EXPECT_TRUE(same(0, 2 * kVectors)) << "c0 " << c0 << " nvec " << nvec << " " << alias;
      }
      reset();  // Z[i] = c[i] x + Y[i], in place (Z = Y) and not
      N_VScaleAddMulti(nvec, c.data(), ours[0], ours.data() + 1, ours.data() + 1);
      N_VScaleAddMulti(nvec, c.data(), theirs[0], theirs.data() + 1, theirs.data() + 1);
      EXPECT_TRUE(same(0, 2 * kVectors)) << "ScaleAddMulti in place, nvec " << nvec;
      reset();
      N_VScaleAddMulti(nvec, c.data(), ours[0], ours.data(), ours.data() + kVectors);
      N_VScaleAddMulti(nvec, c.data(), theirs[0], theirs.data(), theirs.data() + kVectors);
      EXPECT_TRUE(same(0, 2 * kVectors)) << "ScaleAddMulti, nvec " << nvec;
      reset();
      N_VLinearSumVectorArray(nvec, c0, ours.data(), -0.3, ours.data() + kVectors, ours.data());
      N_VLinearSumVectorArray(nvec, c0, theirs.data(), -0.3, theirs.data() + kVectors,
                              theirs.data());
      EXPECT_TRUE(same(0, 2 * kVectors)) << "LinearSumVectorArray, nvec " << nvec;
      reset();
      N_VScaleVectorArray(nvec, c.data(), ours.data(), ours.data() + kVectors);
      N_VScaleVectorArray(nvec, c.data(), theirs.data(), theirs.data() + kVectors);
      EXPECT_TRUE(same(0, 2 * kVectors)) << "ScaleVectorArray, nvec " << nvec;
      reset();
      N_VConstVectorArray(nvec, c0, ours.data());
      N_VConstVectorArray(nvec, c0, theirs.data());
      EXPECT_TRUE(same(0, 2 * kVectors)) << "ConstVectorArray, nvec " << nvec;
      reset();
      std::vector<double> norm_o(nvec), norm_t(nvec);
      N_VWrmsNormVectorArray(nvec, ours.data(), ours.data() + kVectors, norm_o.data());
      N_VWrmsNormVectorArray(nvec, theirs.data(), theirs.data() + kVectors, norm_t.data());
      EXPECT_EQ(std::memcmp(norm_o.data(), norm_t.data(), nvec * sizeof(double)), 0);
      // Two sums of arrays of two vectors: X[k] = {v[2k], v[2k+1]}, Y, Z likewise.
      for (bool in_place : {false, true}) {
        reset();
        N_Vector* yo[2] = {ours.data() + 4, ours.data() + 6};
        N_Vector* yt[2] = {theirs.data() + 4, theirs.data() + 6};
        N_Vector* zo[2] = {ours.data() + 6, ours.data() + 8};
        N_Vector* zt[2] = {theirs.data() + 6, theirs.data() + 8};
        N_VScaleAddMultiVectorArray(2, 2, c.data(), ours.data(), yo, in_place ? yo : zo);
        N_VScaleAddMultiVectorArray(2, 2, c.data(), theirs.data(), yt, in_place ? yt : zt);
        EXPECT_TRUE(same(0, 2 * kVectors)) << "ScaleAddMultiVectorArray " << in_place;
      }
      const int nsum = std::min(nvec, 4);
      for (bool alias : {false, true}) {
        reset();
        N_Vector* xo[4] = {ours.data(), ours.data() + 2, ours.data() + 4, ours.data() + 6};
        N_Vector* xt[4] = {theirs.data(), theirs.data() + 2, theirs.data() + 4, theirs.data() + 6};
        N_Vector* zo = alias ? ours.data() : ours.data() + 8;
        N_Vector* zt = alias ? theirs.data() : theirs.data() + 8;
        N_VLinearCombinationVectorArray(2, nsum, c.data(), xo, zo);
        N_VLinearCombinationVectorArray(2, nsum, c.data(), xt, zt);
        EXPECT_TRUE(same(0, 2 * kVectors)) << "LinearCombinationVectorArray " << nsum << alias;
      }
    }
  }
  for (int k = 0; k < 2 * kVectors; ++k) {
    N_VDestroy(ours[k]);
    N_VDestroy(theirs[k]);
  }
  SUNContext_Free(&ctx);
}

}  // namespace
}  // namespace fesim::sim
