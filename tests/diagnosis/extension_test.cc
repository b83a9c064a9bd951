// The acceptance rules of diagnosis/extension.h that are pure functions of a fit's figures.
#include "diagnosis/extension.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fesim::diagnosis {
namespace {

// docs/diagnosis.md, Extension and acceptance: a significant held-out gain needs no size, an
// insignificant one must exceed clear_heldout_gain.
TEST(Extension, HeldoutGainAcceptedNeedsASignificantTestOrAClearGain) {
  const DiagnoseSettings s;  // alpha 0.01, clear gain 10 %
  // The in-family crosstalk at 4.4 × noise (docs/diagnosis_results/family.md): 1.6 %, z 6.3.
  EXPECT_TRUE(HeldoutGainAccepted(0.016, 6.0 * 0.5 * std::erfc(6.29 / std::sqrt(2.0)), s));
  // A clean person's absorbed misfit: a few per cent, not significant.
  EXPECT_FALSE(HeldoutGainAccepted(0.05, 0.05, s));
  EXPECT_FALSE(HeldoutGainAccepted(0.099, 1.0, s));
  // A slow effect's clear gain without a significant test (one held-out trial).
  EXPECT_TRUE(HeldoutGainAccepted(0.101, 1.0, s));
  // A significant loss or no gain is never accepted.
  EXPECT_FALSE(HeldoutGainAccepted(0.0, 1e-12, s));
  EXPECT_FALSE(HeldoutGainAccepted(-0.02, 1e-12, s));
  // Not measured.
  EXPECT_FALSE(HeldoutGainAccepted(NAN, 1e-12, s));
  EXPECT_FALSE(HeldoutGainAccepted(0.05, NAN, s));
  // The thresholds are the settings'.
  DiagnoseSettings strict;
  strict.alpha = 1e-6;
  strict.clear_heldout_gain = 0.2;
  EXPECT_FALSE(HeldoutGainAccepted(0.016, 1e-5, strict));
  EXPECT_FALSE(HeldoutGainAccepted(0.15, 1.0, strict));
  EXPECT_TRUE(HeldoutGainAccepted(0.016, 1e-7, strict));
}

}  // namespace
}  // namespace fesim::diagnosis
