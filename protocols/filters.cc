#include "protocols/filters.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <stdexcept>
#include <string>

namespace fesim::protocols {
namespace {

constexpr double kPi = 3.14159265358979323846;

}  // namespace

std::vector<Biquad> DesignButterworthLowPass(int order, double cutoff_hz, double sample_rate_hz) {
  if (order < 1 || order > 10) {
    throw std::invalid_argument("butterworth order " + std::to_string(order) +
                                " is outside [1, 10]");
  }
  if (!(sample_rate_hz > 0.0) || !std::isfinite(sample_rate_hz)) {
    throw std::invalid_argument("butterworth sample_rate_hz " + std::to_string(sample_rate_hz) +
                                " must be finite and > 0");
  }
  if (!(cutoff_hz > 0.0) || !(cutoff_hz < 0.5 * sample_rate_hz)) {
    throw std::invalid_argument(
        "butterworth cutoff_hz " + std::to_string(cutoff_hz) +
        " is outside (0, sample_rate_hz/2 = " + std::to_string(0.5 * sample_rate_hz) + ")");
  }
  const double fs2 = 2.0 * sample_rate_hz;
  const double omega_a = fs2 * std::tan(kPi * cutoff_hz / sample_rate_hz);
  std::vector<Biquad> sections;
  // Poles in the upper half plane, k = 0 … ⌊N/2⌋−1, each with its conjugate.
  for (int k = 0; k < order / 2; ++k) {
    const double angle = kPi * (2.0 * k + order + 1.0) / (2.0 * order);
    const std::complex<double> p = omega_a * std::polar(1.0, angle);
    const std::complex<double> z = (1.0 + p / fs2) / (1.0 - p / fs2);
    Biquad s;
    s.a1 = -2.0 * z.real();
    s.a2 = std::norm(z);
    const double g = (1.0 + s.a1 + s.a2) / 4.0;  // unit DC gain: numerator (1 + z⁻¹)² = 4 at z = 1
    s.b0 = g;
    s.b1 = 2.0 * g;
    s.b2 = g;
    sections.push_back(s);
  }
  if (order % 2 == 1) {
    const double p = -omega_a;
    const double z = (1.0 + p / fs2) / (1.0 - p / fs2);
    Biquad s;
    s.a1 = -z;
    const double g = (1.0 - z) / 2.0;
    s.b0 = g;
    s.b1 = g;
    sections.push_back(s);
  }
  return sections;
}

std::vector<double> FilterCascade(const std::vector<Biquad>& sections,
                                  const std::vector<double>& x) {
  std::vector<double> y = x;
  for (const Biquad& s : sections) {
    double w1 = 0.0, w2 = 0.0;  // transposed direct form II state
    for (double& v : y) {
      const double in = v;
      const double out = s.b0 * in + w1;
      w1 = s.b1 * in - s.a1 * out + w2;
      w2 = s.b2 * in - s.a2 * out;
      v = out;
    }
  }
  return y;
}

std::vector<double> FilterZeroPhase(const std::vector<Biquad>& sections,
                                    const std::vector<double>& x, std::size_t padding) {
  const std::size_t n = x.size();
  if (n < 2) return x;
  const std::size_t pad = std::min(n - 1, padding);
  std::vector<double> e;
  e.reserve(n + 2 * pad);
  for (std::size_t k = pad; k >= 1; --k) e.push_back(2.0 * x.front() - x[k]);
  e.insert(e.end(), x.begin(), x.end());
  for (std::size_t k = 1; k <= pad; ++k) e.push_back(2.0 * x.back() - x[n - 1 - k]);
  // Forward from the first value, backward from the last (unit DC gain: a constant passes).
  double ref = e.front();
  for (double& v : e) v -= ref;
  e = FilterCascade(sections, e);
  for (double& v : e) v += ref;
  std::reverse(e.begin(), e.end());
  ref = e.front();
  for (double& v : e) v -= ref;
  e = FilterCascade(sections, e);
  for (double& v : e) v += ref;
  std::reverse(e.begin(), e.end());
  return std::vector<double>(e.begin() + static_cast<std::ptrdiff_t>(pad),
                             e.begin() + static_cast<std::ptrdiff_t>(pad + n));
}

double CascadeGain(const std::vector<Biquad>& sections, double frequency_hz,
                   double sample_rate_hz) {
  const std::complex<double> zi = std::polar(1.0, -2.0 * kPi * frequency_hz / sample_rate_hz);
  std::complex<double> h = 1.0;
  for (const Biquad& s : sections) {
    h *= (s.b0 + zi * (s.b1 + zi * s.b2)) / (1.0 + zi * (s.a1 + zi * s.a2));
  }
  return std::abs(h);
}

}  // namespace fesim::protocols
