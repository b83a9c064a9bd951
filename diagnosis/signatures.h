// Residual signatures for `fesim diagnose` (PRODUCT.md "Diagnosis" step 2, issue 7): small pure
// functions on residual series r(t) = y(t) − ŷ(t) (rad) that show what a calibrated simulation
// gets wrong and which mechanism it points to:
//   spectrum peak in 3–12 Hz            → tremor (papers/001_* §2: tremor is a 3–12 Hz torque)
//   trend versus time / cumulative u    → fatigue, potentiation, sensor drift
//   input–residual cross-correlation lag → electromechanical delay
//   correlation with velocity / posture → stiction, spasticity / passive stiffness, moment arms
// and two whiteness measures used to decide `unexplained`. NaN samples (tracker dropouts) are
// skipped everywhere. Also the χ² survival function used by the score tests (diagnose.h).
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "base/trial.h"

namespace fesim::diagnosis {

struct DataView;

/// Residual summaries of one output (training part unless stated).
struct OutputSignature {
  std::string output;
  double rms_rad = 0.0;
  double spectrum_peak_hz = 0.0, spectrum_peak_ratio = 0.0;  ///< 3–12 Hz.
  double corr_time = 0.0, corr_cumulative_stimulation = 0.0;
  double corr_velocity = 0.0, corr_velocity_sign = 0.0, corr_posture = 0.0;
  double input_lag_s = 0.0, input_lag_corr = 0.0;  ///< strongest input–residual lag.
  std::string input_lag_column;
  double structure_heldout_baseline = 0.0, structure_heldout_extended = 0.0;
};

/// Tremor band of PRODUCT.md / papers/001_* §2, Hz.
inline constexpr double kTremorLowHz = 3.0, kTremorHighHz = 12.0;

/// The signatures of every output of `train` from the residual y − ŷ of its first trial
/// (`predictions`: the calibrated model's, same order): RMS, 3–12 Hz spectrum peak (coarse
/// 0.01 Hz grid, then 0.0005 Hz around the peak), correlations with time, cumulative
/// stimulation, predicted velocity and its sign and predicted posture, and the strongest lag
/// (≤ 0.5 s) between an input's rate of change and the residual.
std::vector<OutputSignature> ResidualSignatures(const DataView& train,
                                                const std::vector<Trial>& predictions);

/// Pearson correlation of x and y over the indices where both are finite; 0 when fewer than 3
/// such pairs or either is constant. Sizes must match (std::invalid_argument).
double Correlation(const std::vector<double>& x, const std::vector<double>& y);

/// Largest periodogram value of r (mean removed, NaN → 0) on the grid f_lo, f_lo + df, … ≤ f_hi
/// relative to the median periodogram value on that grid.
struct SpectrumPeak {
  double frequency_hz = 0.0;  ///< f at the peak, Hz.
  double power_ratio = 0.0;   ///< peak / median periodogram value, dimensionless, ≥ 0.
};
/// `dt_s` the sample period, s, > 0; f_hi < 1/(2 dt). Throws std::invalid_argument otherwise.
SpectrumPeak ResidualSpectrumPeak(const std::vector<double>& r, double dt_s, double f_lo_hz,
                                  double f_hi_hz, double df_hz);

/// Periodogram |Σ r_k e^{−2πi f k dt}|² / N at each frequency of `frequencies_hz` (NaN → 0,
/// mean removed), rad².
std::vector<double> Periodogram(const std::vector<double>& r, double dt_s,
                                const std::vector<double>& frequencies_hz);

/// Lag (s) in [−max_lag, max_lag] at which corr(x(t), r(t + lag)) is largest in magnitude, and
/// that correlation; positive lag = r follows x.
struct LagPeak {
  double lag_s = 0.0;
  double correlation = 0.0;
};
LagPeak CrossCorrelationPeak(const std::vector<double>& x, const std::vector<double>& r,
                             double dt_s, double max_lag_s);

/// Share of the residual variance that is not white: 1 − var(Δr) / (2 var(r)), from pairs of
/// consecutive finite samples; 0 for white noise, → 1 for a slow structured residual. Clamped to
/// [0, 1]; 0 when fewer than 10 pairs.
double StructuredVarianceFraction(const std::vector<double>& r);

/// The shape of a slow offset in a residual r(t): a trend a + b·t or a step a + d·H(t − τ) (a
/// sensor drifting vs. a sensor or glove slipping once). With SSR_X the least-squares Σr² of
/// model X over the finite samples and τ searched over every sample with at least
/// `min_fraction` of them on either side:
///   trend_beyond_step = min_τ SSR_step − min_τ SSR_trend+step (what the trend adds to a step),
///   step_beyond_trend = SSR_trend − min_τ SSR_trend+step (what a step adds to a trend),
/// both rad² and ≥ 0. A pure trend gives step_beyond_trend ≈ 0 and trend_beyond_step ≈ ¼ of its
/// variance·N (a step at mid-recording removes 3/4 of a line's); a pure step the reverse.
struct TrendShape {
  double trend_beyond_step = 0.0, step_beyond_trend = 0.0;  ///< rad².
  double step_time_s = NAN;  ///< τ of the best trend+step fit, s (NaN: too few samples).
  double step_rad = 0.0;     ///< its d, rad (of series `step_series`).
  int step_series = 0;       ///< the series of largest |d| (the overload of several series).
};
/// Sizes of time_s and r must match (std::invalid_argument); min_fraction in (0, 0.5).
TrendShape TrendOrStep(const std::vector<double>& time_s, const std::vector<double>& r,
                       double min_fraction = 0.1);
/// The same for several series of one recording (its outputs) with one step time τ for all — a
/// slipping glove or marker moves every reading at once, while a model's misfit steps each output
/// where its own dynamics go wrong — and a trend and step height of their own: the Σr² figures
/// are sums over the series, τ searched over the first series' samples with at least
/// `min_fraction` of every series' samples on either side (series with too few samples are left
/// out); step_rad is the d of the series whose |d| is largest. Sizes must match pairwise.
TrendShape TrendOrStep(const std::vector<std::vector<double>>& time_s,
                       const std::vector<std::vector<double>>& r, double min_fraction = 0.1);

/// Cumulative stimulation C(t_i) = Σ_k ∫₀^{t_i} u_k dt (trapezoid), µs·s, for input columns u_k
/// sampled at `time_s`.
std::vector<double> CumulativeStimulation(const std::vector<double>& time_s,
                                          const std::vector<std::vector<double>>& inputs_us);

/// Central-difference derivative of y over t (one-sided at the ends; NaN where a neighbour is
/// NaN), unit of y per s.
std::vector<double> Derivative(const std::vector<double>& time_s, const std::vector<double>& y);

/// Survival function of the χ² distribution with k degrees of freedom, P(X > x), via the
/// regularised upper incomplete gamma Q(k/2, x/2) (series / Lentz continued fraction, Numerical
/// Recipes 3rd ed. §6.2). k ≥ 1; x ≤ 0 gives 1.
double ChiSquareSurvival(double x, int k);

}  // namespace fesim::diagnosis
