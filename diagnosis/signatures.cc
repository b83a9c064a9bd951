#include "diagnosis/signatures.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "diagnosis/extended_model.h"

namespace fesim::diagnosis {
namespace {

constexpr double kTwoPi = 6.283185307179586;

bool Finite(double v) { return std::isfinite(v); }

/// r with its finite-sample mean removed and NaN set to 0.
std::vector<double> Centred(const std::vector<double>& r) {
  double sum = 0.0;
  int n = 0;
  for (double v : r) {
    if (Finite(v)) {
      sum += v;
      ++n;
    }
  }
  const double mean = n > 0 ? sum / n : 0.0;
  std::vector<double> out(r.size());
  for (std::size_t i = 0; i < r.size(); ++i) out[i] = Finite(r[i]) ? r[i] - mean : 0.0;
  return out;
}

/// log Γ-free series for P(a, x), x < a + 1.
double GammaPSeries(double a, double x) {
  double sum = 1.0 / a, term = sum, ap = a;
  for (int n = 0; n < 1000; ++n) {
    ap += 1.0;
    term *= x / ap;
    sum += term;
    if (std::abs(term) < std::abs(sum) * 1e-15) break;
  }
  return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
}

/// Continued fraction for Q(a, x), x ≥ a + 1 (modified Lentz).
double GammaQContinuedFraction(double a, double x) {
  constexpr double kTiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / kTiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < 1e-15) break;
  }
  return std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}

/// Coarse and fine spectrum grid steps, Hz.
constexpr double kCoarseDfHz = 0.01, kFineDfHz = 0.0005;
/// Largest input–residual lag examined, s.
constexpr double kMaxLagS = 0.5;

/// Refined spectrum peak: coarse grid, then a fine grid ±2 coarse steps around the peak.
SpectrumPeak RefinedPeak(const std::vector<double>& r, double dt) {
  const double hi = std::min(kTremorHighHz, 0.5 / dt - kCoarseDfHz);
  if (hi <= kTremorLowHz) return {};
  SpectrumPeak coarse = ResidualSpectrumPeak(r, dt, kTremorLowHz, hi, kCoarseDfHz);
  std::vector<double> f;
  for (double x = coarse.frequency_hz - 2 * kCoarseDfHz; x <= coarse.frequency_hz + 2 * kCoarseDfHz;
       x += kFineDfHz) {
    f.push_back(x);
  }
  const std::vector<double> p = Periodogram(r, dt, f);
  coarse.frequency_hz = f[std::max_element(p.begin(), p.end()) - p.begin()];
  return coarse;
}

}  // namespace

std::vector<OutputSignature> ResidualSignatures(const DataView& train,
                                                const std::vector<Trial>& predictions) {
  const Trial& tr0 = train.trials[0];
  // The record's mean step: a 60 Hz tracker written with 4-decimal time stamps has steps of
  // 0.0166 and 0.0167 s, and its first step alone scaled a spectrum peak by 0.2 % (an 8.52 Hz
  // tremor found at 8.50 Hz: one cycle off over 60 s, its score test blind;
  // Signatures.SpectrumPeakUsesTheMeanStepOfARoundedClock).
  const double dt = (tr0.time.back() - tr0.time.front()) / static_cast<double>(tr0.size() - 1);
  std::vector<std::vector<double>> inputs;
  const auto input_names = tr0.NamesWithPrefix("u.");
  inputs.reserve(input_names.size());
  for (const auto& u : input_names) inputs.push_back(tr0.Column(u));
  const std::vector<double> cumulative = CumulativeStimulation(tr0.time, inputs);
  std::vector<OutputSignature> out;
  for (const auto& o : train.outputs) {
    OutputSignature s;
    s.output = o;
    const auto& y = tr0.Column(o);
    const auto& yh = predictions[0].Column(o);
    std::vector<double> r(y.size(), NAN);
    double ss = 0;
    int cnt = 0;
    for (std::size_t i = 0; i < y.size(); ++i) {
      if (!train.use[0][i]) continue;
      r[i] = y[i] - yh[i];
      if (Finite(r[i])) {
        ss += r[i] * r[i];
        ++cnt;
      }
    }
    s.rms_rad = cnt ? std::sqrt(ss / cnt) : 0.0;
    const SpectrumPeak peak = RefinedPeak(r, dt);
    s.spectrum_peak_hz = peak.frequency_hz;
    s.spectrum_peak_ratio = peak.power_ratio;
    s.corr_time = Correlation(tr0.time, r);
    s.corr_cumulative_stimulation = Correlation(cumulative, r);
    const std::vector<double> v = Derivative(tr0.time, yh);
    std::vector<double> sgn(v.size());
    for (std::size_t i = 0; i < v.size(); ++i) sgn[i] = v[i] > 0 ? 1.0 : (v[i] < 0 ? -1.0 : 0.0);
    s.corr_velocity = Correlation(v, r);
    s.corr_velocity_sign = Correlation(sgn, r);
    s.corr_posture = Correlation(yh, r);
    for (std::size_t k = 0; k < inputs.size(); ++k) {
      const LagPeak lp = CrossCorrelationPeak(Derivative(tr0.time, inputs[k]), r, dt, kMaxLagS);
      if (std::abs(lp.correlation) > std::abs(s.input_lag_corr)) {
        s.input_lag_corr = lp.correlation;
        s.input_lag_s = lp.lag_s;
        s.input_lag_column = input_names[k];
      }
    }
    out.push_back(s);
  }
  return out;
}

double Correlation(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size()) {
    throw std::invalid_argument("Correlation: sizes " + std::to_string(x.size()) + " and " +
                                std::to_string(y.size()));
  }
  double sx = 0, sy = 0;
  int n = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (Finite(x[i]) && Finite(y[i])) {
      sx += x[i];
      sy += y[i];
      ++n;
    }
  }
  if (n < 3) return 0.0;
  const double mx = sx / n, my = sy / n;
  double sxx = 0, syy = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!(Finite(x[i]) && Finite(y[i]))) continue;
    sxx += (x[i] - mx) * (x[i] - mx);
    syy += (y[i] - my) * (y[i] - my);
    sxy += (x[i] - mx) * (y[i] - my);
  }
  if (sxx <= 0.0 || syy <= 0.0) return 0.0;
  return sxy / std::sqrt(sxx * syy);
}

std::vector<double> Periodogram(const std::vector<double>& r, double dt_s,
                                const std::vector<double>& frequencies_hz) {
  const std::vector<double> c = Centred(r);
  std::vector<double> out;
  out.reserve(frequencies_hz.size());
  for (double f : frequencies_hz) {
    // Rotating phasor recurrence (exact to rounding over ~1e5 samples).
    const double w = kTwoPi * f * dt_s;
    const double cw = std::cos(w), sw = std::sin(w);
    double re = 0, im = 0, pc = 1.0, ps = 0.0;
    for (double v : c) {
      re += v * pc;
      im -= v * ps;
      const double npc = pc * cw - ps * sw;
      ps = ps * cw + pc * sw;
      pc = npc;
    }
    out.push_back((re * re + im * im) / std::max<std::size_t>(1, c.size()));
  }
  return out;
}

SpectrumPeak ResidualSpectrumPeak(const std::vector<double>& r, double dt_s, double f_lo_hz,
                                  double f_hi_hz, double df_hz) {
  if (!(dt_s > 0.0) || !(df_hz > 0.0) || !(f_hi_hz > f_lo_hz) || f_hi_hz >= 0.5 / dt_s) {
    throw std::invalid_argument("ResidualSpectrumPeak: need dt > 0, df > 0, f_lo < f_hi < 1/(2dt)");
  }
  std::vector<double> f;
  for (double x = f_lo_hz; x <= f_hi_hz + 1e-12; x += df_hz) f.push_back(x);
  const std::vector<double> p = Periodogram(r, dt_s, f);
  SpectrumPeak peak;
  std::size_t best = 0;
  for (std::size_t i = 1; i < p.size(); ++i) {
    if (p[i] > p[best]) best = i;
  }
  std::vector<double> sorted = p;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median = sorted[sorted.size() / 2];
  peak.frequency_hz = f[best];
  peak.power_ratio = median > 0.0 ? p[best] / median : 0.0;
  return peak;
}

LagPeak CrossCorrelationPeak(const std::vector<double>& x, const std::vector<double>& r,
                             double dt_s, double max_lag_s) {
  if (x.size() != r.size()) throw std::invalid_argument("CrossCorrelationPeak: size mismatch");
  const int max_lag = static_cast<int>(std::round(max_lag_s / dt_s));
  const int n = static_cast<int>(x.size());
  LagPeak best;
  for (int lag = -max_lag; lag <= max_lag; ++lag) {
    std::vector<double> a, b;
    a.reserve(n);
    b.reserve(n);
    for (int i = std::max(0, -lag); i < n && i + lag < n; ++i) {
      a.push_back(x[i]);
      b.push_back(r[i + lag]);
    }
    const double c = Correlation(a, b);
    if (std::abs(c) > std::abs(best.correlation)) best = {lag * dt_s, c};
  }
  return best;
}

double StructuredVarianceFraction(const std::vector<double>& r) {
  double s = 0, s2 = 0, d2 = 0;
  int n = 0, pairs = 0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    if (!Finite(r[i])) continue;
    s += r[i];
    s2 += r[i] * r[i];
    ++n;
    if (i > 0 && Finite(r[i - 1])) {
      d2 += (r[i] - r[i - 1]) * (r[i] - r[i - 1]);
      ++pairs;
    }
  }
  if (pairs < 10 || n < 10) return 0.0;
  const double var = s2 / n - (s / n) * (s / n);
  if (var <= 0.0) return 0.0;
  return std::clamp(1.0 - (d2 / pairs) / (2.0 * var), 0.0, 1.0);
}

namespace {

/// One series of TrendOrStep: its finite samples in centred, scaled time x and the sums of the
/// trend's normal equations; suffix sums over the samples from k on (H = 1) give every step's.
struct StepSeries {
  std::vector<double> t, y;
  std::vector<double> h_x, h_y;  ///< Σ_{i ≥ k} x_i, y_i (size n + 1).
  double n = 0, sx = 0, sxx = 0, sy = 0, sxy = 0, syy = 0, ssr_trend = 0;
  long margin = 0;
};

StepSeries PrepareStepSeries(const std::vector<double>& time_s, const std::vector<double>& r,
                             double min_fraction) {
  if (time_s.size() != r.size()) throw std::invalid_argument("TrendOrStep: sizes differ");
  StepSeries s;
  for (std::size_t i = 0; i < r.size(); ++i) {
    if (Finite(r[i]) && Finite(time_s[i])) {
      s.t.push_back(time_s[i]);
      s.y.push_back(r[i]);
    }
  }
  const auto n = static_cast<long>(s.t.size());
  s.n = static_cast<double>(n);
  s.margin = std::max(2L, static_cast<long>(std::ceil(min_fraction * s.n)));
  if (n < 2 * s.margin + 2) return s;
  // Centred and scaled time for the normal equations.
  double mean_t = 0.0;
  for (double v : s.t) mean_t += v;
  mean_t /= s.n;
  const double span = std::max(s.t.back() - s.t.front(), 1e-12);
  s.h_x.assign(n + 1, 0.0);
  s.h_y.assign(n + 1, 0.0);
  for (long i = n - 1; i >= 0; --i) {
    const double x = (s.t[i] - mean_t) / span;
    s.sx += x, s.sxx += x * x, s.sy += s.y[i], s.sxy += x * s.y[i], s.syy += s.y[i] * s.y[i];
    s.h_x[i] = s.h_x[i + 1] + x;
    s.h_y[i] = s.h_y[i + 1] + s.y[i];
  }
  const double cxy = s.sxy - s.sx * s.sy / s.n;
  s.ssr_trend = s.syy - s.sy * s.sy / s.n - cxy * cxy / std::max(s.sxx - s.sx * s.sx / s.n, 1e-300);
  return s;
}

bool Usable(const StepSeries& s) { return !s.h_x.empty(); }

/// Σr² of the step (two means) and of trend + step ([1, x, H] least squares) with H = 1 from
/// sample k on, and the step's d in the latter.
struct StepFit {
  double ssr_step, ssr_full, d;
};
StepFit FitStepAt(const StepSeries& s, long k) {
  const auto n = static_cast<long>(s.t.size());
  const double h1 = static_cast<double>(n - k), hx = s.h_x[k], hy = s.h_y[k];
  const double n0 = s.n - h1, s0 = s.sy - hy;
  StepFit f;
  f.ssr_step = s.syy - s0 * s0 / n0 - hy * hy / h1;
  Eigen::Matrix3d a;
  a << s.n, s.sx, h1, s.sx, s.sxx, hx, h1, hx, h1;
  const Eigen::Vector3d b(s.sy, s.sxy, hy);
  const Eigen::Vector3d beta = a.ldlt().solve(b);
  f.ssr_full = s.syy - beta.dot(b);
  f.d = beta(2);
  return f;
}

}  // namespace

TrendShape TrendOrStep(const std::vector<std::vector<double>>& time_s,
                       const std::vector<std::vector<double>>& r, double min_fraction) {
  if (time_s.size() != r.size()) throw std::invalid_argument("TrendOrStep: sizes differ");
  if (!(min_fraction > 0.0 && min_fraction < 0.5))
    throw std::invalid_argument("TrendOrStep: min_fraction must be in (0, 0.5)");
  std::vector<StepSeries> series;
  std::vector<int> index;  // of each usable series in the arguments
  for (std::size_t j = 0; j < r.size(); ++j) {
    StepSeries s = PrepareStepSeries(time_s[j], r[j], min_fraction);
    if (!Usable(s)) continue;
    series.push_back(std::move(s));
    index.push_back(static_cast<int>(j));
  }
  TrendShape shape;
  if (series.empty()) return shape;
  double ssr_trend = 0.0;
  for (const StepSeries& s : series) ssr_trend += s.ssr_trend;
  double best_step = INFINITY, best_full = INFINITY;
  const std::vector<double>& grid = series.front().t;
  std::vector<StepFit> fits(series.size());
  for (std::size_t g = 1; g < grid.size(); ++g) {
    const double tau = 0.5 * (grid[g - 1] + grid[g]);
    double step = 0.0, full = 0.0;
    bool inside = true;
    for (std::size_t j = 0; j < series.size() && inside; ++j) {
      const StepSeries& s = series[j];
      const auto k = static_cast<long>(std::lower_bound(s.t.begin(), s.t.end(), tau) - s.t.begin());
      const auto n = static_cast<long>(s.t.size());
      inside = k >= s.margin && n - k >= s.margin;
      if (!inside) break;
      fits[j] = FitStepAt(s, k);
      step += fits[j].ssr_step;
      full += fits[j].ssr_full;
    }
    if (!inside) continue;
    best_step = std::min(best_step, step);
    if (full < best_full) {
      best_full = full;
      shape.step_time_s = tau;
      std::size_t largest = 0;
      for (std::size_t j = 1; j < fits.size(); ++j) {
        if (std::abs(fits[j].d) > std::abs(fits[largest].d)) largest = j;
      }
      shape.step_rad = fits[largest].d;
      shape.step_series = index[largest];
    }
  }
  if (!std::isfinite(best_full)) return shape;
  best_full = std::max(0.0, best_full);
  shape.trend_beyond_step = std::max(0.0, best_step - best_full);
  shape.step_beyond_trend = std::max(0.0, ssr_trend - best_full);
  return shape;
}

TrendShape TrendOrStep(const std::vector<double>& time_s, const std::vector<double>& r,
                       double min_fraction) {
  return TrendOrStep(std::vector<std::vector<double>>{time_s}, std::vector<std::vector<double>>{r},
                     min_fraction);
}

std::vector<double> CumulativeStimulation(const std::vector<double>& time_s,
                                          const std::vector<std::vector<double>>& inputs_us) {
  std::vector<double> c(time_s.size(), 0.0);
  for (std::size_t i = 1; i < time_s.size(); ++i) {
    double sum = 0.0;
    for (const auto& u : inputs_us) {
      if (u.size() != time_s.size()) {
        throw std::invalid_argument("CumulativeStimulation: input length differs from time");
      }
      const double a = Finite(u[i - 1]) ? u[i - 1] : 0.0, b = Finite(u[i]) ? u[i] : 0.0;
      sum += 0.5 * (a + b);
    }
    c[i] = c[i - 1] + sum * (time_s[i] - time_s[i - 1]);
  }
  return c;
}

std::vector<double> Derivative(const std::vector<double>& time_s, const std::vector<double>& y) {
  const std::size_t n = y.size();
  std::vector<double> d(n, NAN);
  if (n < 2 || time_s.size() != n) return d;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t a = i == 0 ? 0 : i - 1, b = i + 1 == n ? n - 1 : i + 1;
    if (Finite(y[a]) && Finite(y[b]) && time_s[b] > time_s[a]) {
      d[i] = (y[b] - y[a]) / (time_s[b] - time_s[a]);
    }
  }
  return d;
}

double ChiSquareSurvival(double x, int k) {
  if (k < 1) throw std::invalid_argument("ChiSquareSurvival: k must be >= 1");
  if (!(x > 0.0)) return 1.0;
  const double a = 0.5 * k, xx = 0.5 * x;
  if (xx < a + 1.0) return std::clamp(1.0 - GammaPSeries(a, xx), 0.0, 1.0);
  return std::clamp(GammaQContinuedFraction(a, xx), 0.0, 1.0);
}

}  // namespace fesim::diagnosis
