#include "identification/spectrum.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace fesim::identification {
namespace {

constexpr double kPi = 3.14159265358979323846;

using Complex = std::complex<double>;

std::size_t NextPowerOfTwo(std::size_t n) {
  std::size_t p = 1;
  while (p < n) p <<= 1;
  return p;
}

}  // namespace

void Fft(std::vector<Complex>* a_ptr, bool inverse) {
  std::vector<Complex>& a = *a_ptr;
  const std::size_t n = a.size();
  if (n == 0 || (n & (n - 1)) != 0) {
    throw std::invalid_argument("Fft: size " + std::to_string(n) + " is not a power of two");
  }
  for (std::size_t i = 1, j = 0; i < n; ++i) {  // bit-reversal permutation
    std::size_t bit = n >> 1;
    for (; j & bit; bit >>= 1) j ^= bit;
    j ^= bit;
    if (i < j) std::swap(a[i], a[j]);
  }
  // Twiddles exp(∓2πj k/n), each from its own cosine and sine (no recurrence, no drift).
  std::vector<Complex> w(n / 2);
  const double sign = inverse ? 1.0 : -1.0;
  for (std::size_t k = 0; k < n / 2; ++k) {
    const double angle = sign * 2.0 * kPi * static_cast<double>(k) / static_cast<double>(n);
    w[k] = Complex(std::cos(angle), std::sin(angle));
  }
  for (std::size_t len = 2; len <= n; len <<= 1) {
    const std::size_t half = len / 2, stride = n / len;
    for (std::size_t start = 0; start < n; start += len) {
      for (std::size_t k = 0; k < half; ++k) {
        const Complex u = a[start + k];
        const Complex v = a[start + k + half] * w[k * stride];
        a[start + k] = u + v;
        a[start + k + half] = u - v;
      }
    }
  }
}

std::vector<Complex> ZoomDft(const Eigen::VectorXd& x, double f0, std::uint64_t M, std::size_t K) {
  const auto N = static_cast<std::size_t>(x.size());
  if (M == 0) throw std::invalid_argument("ZoomDft: M must be >= 1");
  if (N == 0 || K == 0) return std::vector<Complex>(K);
  if (N > (std::size_t{1} << 31) || K > (std::size_t{1} << 31) || M > (std::uint64_t{1} << 31)) {
    throw std::invalid_argument("ZoomDft: N, K and M must be at most 2^31");
  }
  // Chirp c(n) = exp(−jπ n²/M), its phase reduced exactly: n² mod 2M (n² < 2⁶² fits).
  const std::size_t chirp_len = std::max(N, K);
  std::vector<Complex> chirp(chirp_len);
  for (std::size_t n = 0; n < chirp_len; ++n) {
    const std::uint64_t r = (static_cast<std::uint64_t>(n) * n) % (2 * M);
    const double angle = -kPi * static_cast<double>(r) / static_cast<double>(M);
    chirp[n] = Complex(std::cos(angle), std::sin(angle));
  }
  const std::size_t L = NextPowerOfTwo(N + K - 1);
  std::vector<Complex> a(L), b(L);
  for (std::size_t k = 0; k < N; ++k) {
    // exp(−2πj f0 k) from the fractional part of f0 k (the whole turns drop out).
    double cycles = f0 * static_cast<double>(k);
    cycles -= std::floor(cycles);
    const double angle = -2.0 * kPi * cycles;
    a[k] = x(static_cast<Eigen::Index>(k)) * Complex(std::cos(angle), std::sin(angle)) * chirp[k];
  }
  // b(m) = conj(c(m)) for m = −(N−1) … K−1, negative m wrapped to L + m.
  for (std::size_t m = 0; m < K; ++m) b[m] = std::conj(chirp[m]);
  for (std::size_t m = 1; m < N; ++m) b[L - m] = std::conj(chirp[m]);
  Fft(&a, false);
  Fft(&b, false);
  for (std::size_t i = 0; i < L; ++i) a[i] *= b[i];
  Fft(&a, true);
  std::vector<Complex> out(K);
  const double scale = 1.0 / static_cast<double>(L);
  for (std::size_t i = 0; i < K; ++i) out[i] = chirp[i] * a[i] * scale;
  return out;
}

Periodogram SummedPeriodogram(const std::vector<Eigen::VectorXd>& signals, double T, double f_lo,
                              double f_hi) {
  Periodogram p;
  Eigen::Index n_max = 0;
  for (const auto& e : signals) n_max = std::max(n_max, e.size());
  if (n_max == 0 || !(T > 0.0)) return p;
  const double df = 1.0 / (4.0 * static_cast<double>(n_max) * T);
  for (double f = f_lo; f <= f_hi; f += df) p.f_hz.push_back(f);
  p.power.assign(p.f_hz.size(), 0.0);
  if (p.f_hz.empty()) return p;
  // f_lo + i df in cycles per sample is f_lo T + i / (4 n_max).
  const auto M = static_cast<std::uint64_t>(4 * n_max);
  for (const auto& e : signals) {
    const std::vector<Complex> X = ZoomDft(e, f_lo * T, M, p.f_hz.size());
    for (std::size_t i = 0; i < X.size(); ++i) p.power[i] += std::norm(X[i]);
  }
  return p;
}

}  // namespace fesim::identification
