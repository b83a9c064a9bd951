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

// docs/diagnosis.md, Extension and acceptance: the candidate's own part of the gain (the fit
// against itself with the candidate switched off) passes when significant or above
// min_heldout_gain; not measured, it is no condition.
TEST(Extension, OwnGainAcceptedNeedsASignificantTestOrTheMinimumGain) {
  const DiagnoseSettings s;  // alpha 0.01, min_heldout_gain 2 %
  const auto p_adj = [](double z) { return 6.0 * 0.5 * std::erfc(z / std::sqrt(2.0)); };
  // A tremor's spectral line at the noise RMS (foreign 6008): all its own, 1.7 %, z 6.9.
  EXPECT_TRUE(OwnGainAccepted(0.017, p_adj(6.9), s));
  // A person's refit beside a mechanism near "off": small and not significant (foreign 1019).
  EXPECT_FALSE(OwnGainAccepted(0.003, p_adj(1.5), s));
  EXPECT_FALSE(OwnGainAccepted(0.019, 1.0, s));
  EXPECT_TRUE(OwnGainAccepted(0.021, 1.0, s));
  // A significant own loss or none is never accepted.
  EXPECT_FALSE(OwnGainAccepted(0.0, 1e-12, s));
  EXPECT_FALSE(OwnGainAccepted(-0.01, 1e-12, s));
  // Not measured (no ablation): no condition.
  EXPECT_TRUE(OwnGainAccepted(NAN, 1.0, s));
  DiagnoseSettings strict;
  strict.alpha = 1e-12;
  strict.min_heldout_gain = 0.05;
  EXPECT_FALSE(OwnGainAccepted(0.017, p_adj(6.9), strict));
  EXPECT_FALSE(OwnGainAccepted(0.04, 1.0, strict));
}

}  // namespace
}  // namespace fesim::diagnosis
