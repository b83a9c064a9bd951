#include "sim/anthropometry.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace fesim::sim {
namespace {

TEST(Anthropometry, PublishedFractions) {
  const auto s = ScaledSegments(1.75, 75.0);
  EXPECT_NEAR(s[kHumerus].mass_kg, 0.0271 * 75.0, 1e-12);  // de Leva 1996
  EXPECT_NEAR(s[kForearm].mass_kg, 0.0162 * 75.0, 1e-12);
  double hand_and_finger = 0.0;
  for (int k = kHand; k <= kDistalPhalanx; ++k) hand_and_finger += s[k].mass_kg;
  EXPECT_NEAR(hand_and_finger, 0.006 * 75.0, 1e-12);  // Winter 2009: whole hand
  EXPECT_NEAR(s[kHumerus].length_m, 0.186 * 1.75, 1e-12);
  EXPECT_NEAR(s[kForearm].com_in_body_m[1], -0.4574 * 0.146 * 1.75, 1e-12);
  EXPECT_GT(s[kHand].mass_kg, 0.3);
  EXPECT_LT(s[kDistalPhalanx].mass_kg, s[kProximalPhalanx].mass_kg);
}

TEST(Anthropometry, ScalesWithHeightAndMass) {
  const auto a = ScaledSegments(1.6, 60.0);
  const auto b = ScaledSegments(1.9, 90.0);
  EXPECT_NEAR(b[kForearm].length_m / a[kForearm].length_m, 1.9 / 1.6, 1e-12);
  EXPECT_NEAR(b[kHumerus].mass_kg / a[kHumerus].mass_kg, 1.5, 1e-12);
  // I = m (ρL)²: scales with mass × length².
  EXPECT_NEAR(b[kHumerus].inertia_about_com_kg_m2[0] / a[kHumerus].inertia_about_com_kg_m2[0],
              1.5 * (1.9 / 1.6) * (1.9 / 1.6), 1e-9);
  EXPECT_THROW(ScaledSegments(0.5, 60.0), std::invalid_argument);
  EXPECT_THROW(ScaledSegments(1.7, 500.0), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::sim
