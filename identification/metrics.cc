#include "identification/metrics.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace fesim::identification {
namespace {

struct Sums {
  double err2 = 0.0;
  double dev2 = 0.0;
  std::size_t n = 0;
};

Sums Accumulate(const std::vector<double>& y, const std::vector<double>& y_hat) {
  if (y.size() != y_hat.size()) {
    throw std::invalid_argument("fit measure: y has " + std::to_string(y.size()) +
                                " samples, prediction has " + std::to_string(y_hat.size()));
  }
  double mean = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < y.size(); ++i) {
    if (std::isnan(y[i]) || std::isnan(y_hat[i])) continue;
    mean += y[i];
    ++n;
  }
  if (n < 2) throw std::invalid_argument("fit measure: fewer than two valid samples");
  mean /= static_cast<double>(n);
  Sums s;
  s.n = n;
  for (std::size_t i = 0; i < y.size(); ++i) {
    if (std::isnan(y[i]) || std::isnan(y_hat[i])) continue;
    s.err2 += (y[i] - y_hat[i]) * (y[i] - y_hat[i]);
    s.dev2 += (y[i] - mean) * (y[i] - mean);
  }
  return s;
}

}  // namespace

double NormalisedError(const std::vector<double>& y, const std::vector<double>& y_hat) {
  const Sums s = Accumulate(y, y_hat);
  if (s.dev2 == 0.0) return s.err2 == 0.0 ? 0.0 : INFINITY;
  return std::sqrt(s.err2 / s.dev2);
}

double BestFitPercent(const std::vector<double>& y, const std::vector<double>& y_hat) {
  return 100.0 * (1.0 - NormalisedError(y, y_hat));
}

double Rms(const std::vector<double>& y, const std::vector<double>& y_hat) {
  const Sums s = Accumulate(y, y_hat);
  return std::sqrt(s.err2 / static_cast<double>(s.n));
}

}  // namespace fesim::identification
