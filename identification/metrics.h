// Fit measures shared by every identification method (PRODUCT.md "Identification", Metrics).
// Conventions follow MATLAB's System Identification Toolbox `compare`/`goodnessOfFit`.
#pragma once

#include <vector>

namespace fesim::identification {

/// Best Fit % = 100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖)   ([Le 2010] eq. 17, [Copur 2016] eq. 22).
/// NaN samples of y (dropouts) are skipped. Throws std::invalid_argument on size mismatch or
/// fewer than two valid samples. 100 is perfect, 0 equals predicting the mean, can be negative.
double BestFitPercent(const std::vector<double>& y, const std::vector<double>& y_hat);

/// Normalised error ‖y − ŷ‖ / ‖y − ȳ‖ = 1 − BestFit/100 ([Hand Hammerstein] Tables 1–2, "normalised
/// error"). 0 is perfect.
double NormalisedError(const std::vector<double>& y, const std::vector<double>& y_hat);

/// Root-mean-square of y − ŷ over the valid (non-NaN) samples.
double Rms(const std::vector<double>& y, const std::vector<double>& y_hat);

}  // namespace fesim::identification
