// Discrete Fourier transforms for the periodograms of the identification methods (the tremor
// frequency search of [Copur 2016]): a radix-2 FFT and a zoomed DFT on a fine frequency grid by
// Bluestein's chirp-z algorithm, O((N + K) log(N + K)) instead of the direct O(N K) sum.
// Written here rather than taken from FFTW so that identification/ keeps depending on Eigen only;
// the transforms are small and tested against the direct sums (tests/identification).
#pragma once

#include <Eigen/Dense>
#include <complex>
#include <cstdint>
#include <vector>

namespace fesim::identification {

/// In-place radix-2 FFT of `a` (size a power of two, else std::invalid_argument):
///   A_i = Σ_k a_k exp(∓2πj i k / L), '−' forward, '+' inverse (unscaled: the inverse of the
///   forward transform is inverse / L).
void Fft(std::vector<std::complex<double>>* a, bool inverse);

/// The DFT of the real signal x on K frequencies spaced 1/M cycles per sample from f0:
///   X_i = Σ_{k<N} x_k exp(−2πj (f0 + i/M) k),  i = 0 … K−1,
/// by the chirp-z transform over a zero-padded radix-2 FFT of length ≥ N + K − 1. The chirp
/// phases π n²/M are reduced exactly in integers (n² mod 2M), so long signals keep their
/// accuracy (N up to 2³¹, M up to 2³¹). f0 in cycles per sample; M ≥ 1.
std::vector<std::complex<double>> ZoomDft(const Eigen::VectorXd& x, double f0, std::uint64_t M,
                                          std::size_t K);

/// Summed periodogram P(f) = Σ_t |Σ_k e_t(k) exp(−2πj f T k)|² of `signals` (sample period T, s)
/// on the grid f = f_lo, f_lo + df, … while f ≤ f_hi, df = 1/(4 N T) with N the longest signal
/// (a 4× zero-padded frequency resolution). `f_hz` holds the grid as that running sum gives it;
/// the powers are evaluated at f_lo + i df.
struct Periodogram {
  std::vector<double> f_hz;
  std::vector<double> power;
};
Periodogram SummedPeriodogram(const std::vector<Eigen::VectorXd>& signals, double T, double f_lo,
                              double f_hi);

}  // namespace fesim::identification
