// Digital low-pass filters for the protocol generators (protocols/protocols.h).
//
// A Butterworth low-pass of order N is designed from its analogue prototype, whose poles are
//   p_k = ω_a · exp(jπ(2k + N + 1)/(2N)),  k = 0 … N−1,   ω_a = 2 f_s · tan(π f_c / f_s),
// mapped by the bilinear transform z = (1 + p/(2 f_s)) / (1 − p/(2 f_s)) (frequency pre-warped so
// that |H(e^{j2π f_c/f_s})|² = 1/2 exactly), with all N zeros at z = −1 and unit gain at DC. It is
// realised as a cascade of second-order sections (one first-order section when N is odd), each in
// transposed direct form II. Used for the filtered random noise test of [Le 2010]
// ([Le 2010] §5, "FRN test": "lowpass filtering white noise").
#pragma once

#include <vector>

namespace fesim::protocols {

/// One section H(z) = (b0 + b1 z⁻¹ + b2 z⁻²) / (1 + a1 z⁻¹ + a2 z⁻²); a first-order section has
/// b2 = a2 = 0.
struct Biquad {
  double b0 = 1.0, b1 = 0.0, b2 = 0.0;
  double a1 = 0.0, a2 = 0.0;
};

/// Designs a Butterworth low-pass as a cascade of sections (see the file comment).
/// order: 1–10; cutoff_hz: −3 dB frequency, Hz, in (0, sample_rate_hz/2); sample_rate_hz: > 0.
/// Throws std::invalid_argument naming the parameter and its allowed range.
std::vector<Biquad> DesignButterworthLowPass(int order, double cutoff_hz, double sample_rate_hz);

/// Runs `x` through the cascade from zero initial state; returns y with y.size() == x.size().
std::vector<double> FilterCascade(const std::vector<Biquad>& sections,
                                  const std::vector<double>& x);

/// Zero-phase filtering (forward–backward, as MATLAB's filtfilt): `x` is extended at each end by
/// min(padding, n − 1) samples of its odd reflection about the end value (2x₀ − x_k), run through
/// the cascade forward and then backward, each pass started from its first value (subtracted and
/// added back, so that a constant passes without a transient), then trimmed to x's samples.
/// Magnitude response |H|², phase zero. Returns y with y.size() == x.size(); a signal of fewer
/// than 2 samples is returned unchanged.
std::vector<double> FilterZeroPhase(const std::vector<Biquad>& sections,
                                    const std::vector<double>& x, std::size_t padding);

/// |H(e^{j2πf/f_s})| of the cascade at frequency_hz (for tests and documentation).
double CascadeGain(const std::vector<Biquad>& sections, double frequency_hz, double sample_rate_hz);

}  // namespace fesim::protocols
