#include "identification/metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace fesim::identification {
namespace {

constexpr double kTol = 1e-12;

TEST(Metrics, BestFitKeyPoints) {
  const std::vector<double> y = {1, 2, 3, 4};
  EXPECT_NEAR(BestFitPercent(y, y), 100.0, kTol);
  EXPECT_NEAR(BestFitPercent(y, {2.5, 2.5, 2.5, 2.5}), 0.0, kTol);  // the mean predicts 0 %
  // ‖e‖ = 1, ‖y − ȳ‖ = √5  →  100 (1 − 1/√5)
  EXPECT_NEAR(BestFitPercent(y, {1, 2, 3, 5}), 100.0 * (1.0 - 1.0 / std::sqrt(5.0)), kTol);
  EXPECT_NEAR(NormalisedError(y, {1, 2, 3, 5}), 1.0 / std::sqrt(5.0), kTol);
  EXPECT_NEAR(Rms(y, {1, 2, 3, 5}), 0.5, kTol);
}

TEST(Metrics, NaNSamplesSkippedAndSizesChecked) {
  const std::vector<double> y = {1, NAN, 3, 4, 2};
  EXPECT_NEAR(BestFitPercent(y, {1, 100, 3, 4, 2}), 100.0, kTol);
  EXPECT_THROW(BestFitPercent({1, 2}, {1}), std::invalid_argument);
  EXPECT_THROW(BestFitPercent({1, NAN}, {1, 2}), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::identification
