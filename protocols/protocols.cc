#include "protocols/protocols.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>

#include "protocols/filters.h"

namespace fesim::protocols {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kGridTolUs = 1e-9;  // µs: Σu ≤ u_max test on grid points
constexpr double kTimeTolS = 1e-9;   // s: rounding of counts of periods
constexpr double kMaxDurationS = 36000.0;

// --- deterministic random numbers (std distributions are implementation-defined) -------------

/// Uniform in the open interval (0, 1), 53 random bits.
double Uniform01(std::mt19937_64& rng) {
  return (static_cast<double>(rng() >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}

double UniformIn(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * Uniform01(rng);
}

/// Uniform integer in [0, n), n ≥ 1, unbiased (rejection).
std::uint64_t UniformIndex(std::mt19937_64& rng, std::uint64_t n) {
  const std::uint64_t limit =
      std::numeric_limits<std::uint64_t>::max() - std::numeric_limits<std::uint64_t>::max() % n;
  std::uint64_t x;
  do {
    x = rng();
  } while (x >= limit);
  return x % n;
}

/// Standard normal by Box–Muller.
double StandardNormal(std::mt19937_64& rng) {
  const double u1 = Uniform01(rng);
  const double u2 = Uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

template <typename T>
void Shuffle(std::vector<T>* v, std::mt19937_64& rng) {
  for (std::size_t i = v->size(); i > 1; --i) {
    std::swap((*v)[i - 1], (*v)[UniformIndex(rng, i)]);
  }
}

// --- validation ----------------------------------------------------------------------------------

std::string Num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

/// Throws std::invalid_argument "NAME = V is outside [lo, hi]" (brackets per openness).
void CheckRange(const std::string& name, double v, double lo, double hi, bool lo_open = false,
                bool hi_open = false) {
  const bool ok = std::isfinite(v) && (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
  if (!ok) {
    throw std::invalid_argument(name + " = " + Num(v) + " is outside " + (lo_open ? "(" : "[") +
                                Num(lo) + ", " + Num(hi) + (hi_open ? ")" : "]"));
  }
}

void CheckChannelName(const std::string& name, const std::string& value) {
  if (value.empty()) throw std::invalid_argument(name + " must be a non-empty channel name");
}

void CheckChannels(const std::string& name, const std::vector<std::string>& channels,
                   std::size_t min_count, std::size_t max_count) {
  if (channels.size() < min_count || channels.size() > max_count) {
    throw std::invalid_argument(name + " has " + std::to_string(channels.size()) +
                                " channels; allowed " + std::to_string(min_count) + "–" +
                                std::to_string(max_count));
  }
  for (std::size_t i = 0; i < channels.size(); ++i) {
    CheckChannelName(name + "[" + std::to_string(i) + "]", channels[i]);
    for (std::size_t j = 0; j < i; ++j) {
      if (channels[i] == channels[j]) {
        throw std::invalid_argument(name + " names channel '" + channels[i] + "' twice");
      }
    }
  }
}

void CheckLimit(const std::string& name, const StimulationLimit& limit) {
  if (!(limit.sum_max_us > 0.0)) {  // NaN fails too; +∞ allowed
    throw std::invalid_argument(name + ".sum_max_us = " + Num(limit.sum_max_us) +
                                " is outside (0, inf]");
  }
}

void CheckLevels(const std::string& prefix, const char* lo_name, double lo, const char* hi_name,
                 double hi) {
  CheckRange(prefix + "." + hi_name, hi, 0.0, kMaxPulseWidthUs, true, false);
  CheckRange(prefix + "." + lo_name, lo, 0.0, hi, false, true);
}

/// Number of pulse periods (or symbols) of length `step` that start inside [0, span).
std::size_t CountStarts(double span, double step) {
  return static_cast<std::size_t>(std::ceil(span / step - kTimeTolS));
}

// --- paper-002 single-channel framing -------------------------------------------------------

double ActiveWindow(const IsometricTestTiming& t) { return t.duration_s - 2.0 * t.rest_s; }

void CheckTiming(const std::string& prefix, const IsometricTestTiming& t) {
  CheckRange(prefix + ".pulse_rate_hz", t.pulse_rate_hz, 1.0, 1000.0);
  CheckRange(prefix + ".rest_s", t.rest_s, 0.0, kMaxDurationS / 2.0);
  CheckRange(prefix + ".duration_s", t.duration_s, 2.0 * t.rest_s + 2.0 / t.pulse_rate_hz,
             kMaxDurationS);
}

/// Rest (0) from t = 0, the active entries, rest (0) from duration − rest to the end; then the
/// limit. Active times (relative to the window start, increasing, at least one pulse period apart)
/// are snapped to the pulse grid k/pulse_rate_hz anchored at the window start — a stimulator can
/// change the pulse width only at a pulse — and entries snapped to the window's end are dropped.
StimulationProgram FrameSingleChannel(const std::string& channel, const IsometricTestTiming& t,
                                      const std::vector<double>& active_times_s,
                                      const std::vector<double>& active_values_us,
                                      const StimulationLimit& limit) {
  StimulationProgram p;
  p.channels = {channel};
  p.duration_s = t.duration_s;
  if (t.rest_s > 0.0) {
    p.times_s.push_back(0.0);
    p.values_us.push_back({0.0});
  }
  const double rate = t.pulse_rate_hz;
  const double active = ActiveWindow(t);
  double last = -1.0;
  for (std::size_t k = 0; k < active_times_s.size(); ++k) {
    const double snapped = std::round(active_times_s[k] * rate) / rate;
    if (snapped >= active - kTimeTolS) break;
    if (snapped <= last) {
      throw std::logic_error("FrameSingleChannel: active times closer than one pulse period");
    }
    last = snapped;
    p.times_s.push_back(t.rest_s + snapped);
    p.values_us.push_back({active_values_us[k]});
  }
  if (t.rest_s > 0.0) {
    p.times_s.push_back(t.duration_s - t.rest_s);
    p.values_us.push_back({0.0});
  }
  return ClipToLimits(std::move(p), limit);
}

// --- step grid ----------------------------------------------------------------------------------

void Sweep(std::size_t level, const std::vector<std::size_t>& dims, double spacing, double u_max,
           std::vector<double>* u, std::vector<char>* reversed,
           std::vector<std::vector<double>>* out) {
  double used = 0.0;
  for (std::size_t l = 0; l < level; ++l) used += (*u)[dims[l]];
  const double room = std::min(kMaxPulseWidthUs, u_max - used);
  const int m_max = static_cast<int>(std::floor((room + kGridTolUs) / spacing));
  const std::size_t d = dims[level];
  for (int i = 0; i <= m_max; ++i) {
    const int m = (*reversed)[level] ? m_max - i : i;
    (*u)[d] = m * spacing;
    if (level + 1 < dims.size()) {
      Sweep(level + 1, dims, spacing, u_max, u, reversed, out);
    } else {
      out->push_back(*u);
    }
  }
  (*u)[d] = 0.0;
  (*reversed)[level] = !(*reversed)[level];
}

void CheckStepGrid(const StepGridParams& p) {
  CheckChannels("StepGridParams.channels", p.channels, 1, 6);
  CheckRange("StepGridParams.u_max_us", p.u_max_us, 0.0, kMaxPulseWidthUs * p.channels.size(), true,
             false);
  CheckRange("StepGridParams.spacing_us", p.spacing_us, 1.0, kMaxPulseWidthUs);
  CheckRange("StepGridParams.step_duration_s", p.step_duration_s, 0.0, 600.0, true, false);
  CheckRange("StepGridParams.steady_state_lead_s", p.steady_state_lead_s, 0.0, p.step_duration_s,
             false, true);
}

// --- PRMS ---------------------------------------------------------------------------------------

bool IsPrime(int q) {
  if (q < 2) return false;
  for (int d = 2; d * d <= q; ++d) {
    if (q % d == 0) return false;
  }
  return true;
}

/// One step of s_{k+n} = −Σ c_i s_{k+i} (mod q) on the window `state` (oldest first).
void LfsrStep(const std::vector<int>& c, int q, std::vector<int>* state) {
  long long acc = 0;
  for (std::size_t i = 0; i < c.size(); ++i) acc += static_cast<long long>(c[i]) * (*state)[i];
  const int next = static_cast<int>((q - acc % q) % q);
  state->erase(state->begin());
  state->push_back(next);
}

/// True when x^n + c_{n−1}x^{n−1} + … + c_0 is primitive over GF(q): the recurrence from
/// (0, …, 0, 1) has period exactly q^n − 1.
bool IsPrimitive(const std::vector<int>& c, int q, long long period) {
  const std::size_t n = c.size();
  std::vector<int> start(n, 0);
  start[n - 1] = 1;
  std::vector<int> s = start;
  for (long long k = 1; k <= period; ++k) {
    LfsrStep(c, q, &s);
    if (s == start) return k == period;
  }
  return false;
}

void CheckPrms(const PrmsParams& p) {
  CheckChannelName("PrmsParams.channel", p.channel);
  CheckLevels("PrmsParams", "u_min_us", p.u_min_us, "u_max_us", p.u_max_us);
  if (!IsPrime(p.num_levels) || p.num_levels > 31) {
    throw std::invalid_argument("PrmsParams.num_levels = " + std::to_string(p.num_levels) +
                                " must be a prime in [2, 31]");
  }
  double period = 1.0;
  for (int i = 0; i < p.register_length && period < 1e7; ++i) period *= p.num_levels;
  if (p.register_length < 1 || period - 1.0 > 1048576.0) {
    throw std::invalid_argument(
        "PrmsParams.register_length = " + std::to_string(p.register_length) +
        " must be ≥ 1 with num_levels^register_length − 1 ≤ 2^20");
  }
  CheckTiming("PrmsParams.timing", p.timing);
  CheckRange("PrmsParams.symbol_duration_s", p.symbol_duration_s, 1.0 / p.timing.pulse_rate_hz,
             ActiveWindow(p.timing));
  CheckLimit("PrmsParams.limit", p.limit);
}

// --- multisine ----------------------------------------------------------------------------------

void CheckMultisine(const MultisineParams& p) {
  CheckChannels("MultisineParams.channels", p.channels, 2, 2);
  CheckRange("MultisineParams.pulse_rate_hz", p.pulse_rate_hz, 1.0, 1000.0);
  CheckRange("MultisineParams.f_max_hz", p.f_max_hz, 0.0, p.pulse_rate_hz / 2.0, true, true);
  CheckRange("MultisineParams.f_min_hz", p.f_min_hz, 0.0, p.f_max_hz, true, false);
  CheckRange("MultisineParams.frequency_step_hz", p.frequency_step_hz, 0.0, p.f_max_hz, true,
             false);
  CheckRange("MultisineParams.amplitude_us", p.amplitude_us, 0.0, kMaxPulseWidthUs, true, false);
  CheckRange("MultisineParams.coact_agonist_us", p.coact_agonist_us, 0.0, kMaxPulseWidthUs);
  CheckRange("MultisineParams.coact_antagonist_us", p.coact_antagonist_us, 0.0, kMaxPulseWidthUs);
  CheckRange("MultisineParams.duration_s", p.duration_s, 2.0 / p.pulse_rate_hz, kMaxDurationS);
  CheckLimit("MultisineParams.limit", p.limit);
  const double j_lo = std::ceil(p.f_min_hz / p.frequency_step_hz - 1e-9);
  const double j_hi = std::floor(p.f_max_hz / p.frequency_step_hz + 1e-9);
  if (j_hi < j_lo) {
    throw std::invalid_argument(
        "MultisineParams: no multiple of frequency_step_hz = " + Num(p.frequency_step_hz) +
        " lies in [f_min_hz, f_max_hz] = [" + Num(p.f_min_hz) + ", " + Num(p.f_max_hz) + "]");
  }
}

// --- reaching -----------------------------------------------------------------------------------

void CheckVec(const std::string& name, const Vec3& v) {
  for (double x : v) {
    if (!std::isfinite(x) || std::abs(x) > 100.0) {
      throw std::invalid_argument(name + " has a component " + Num(x) + " outside [-100, 100] m");
    }
  }
}

void CheckReaching(const ReachingParams& p) {
  if (p.homes_m.empty() || p.homes_m.size() > 16) {
    throw std::invalid_argument("ReachingParams.homes_m has " + std::to_string(p.homes_m.size()) +
                                " positions; allowed 1–16");
  }
  if (p.targets_m.empty() || p.targets_m.size() > 1000) {
    throw std::invalid_argument("ReachingParams.targets_m has " +
                                std::to_string(p.targets_m.size()) + " positions; allowed 1–1000");
  }
  for (std::size_t i = 0; i < p.homes_m.size(); ++i) {
    CheckVec("ReachingParams.homes_m[" + std::to_string(i) + "]", p.homes_m[i]);
  }
  for (std::size_t i = 0; i < p.targets_m.size(); ++i) {
    CheckVec("ReachingParams.targets_m[" + std::to_string(i) + "]", p.targets_m[i]);
  }
  CheckRange("ReachingParams.reach_duration_s", p.reach_duration_s, 0.0, 60.0, true, false);
  CheckRange("ReachingParams.hold_s", p.hold_s, 0.0, 60.0);
  CheckRange("ReachingParams.pause_s", p.pause_s, 0.0, 60.0);
  CheckRange("ReachingParams.transfer_duration_s", p.transfer_duration_s, 0.0, 60.0, true, false);
  if (p.repetitions < 1 || p.repetitions > 100) {
    throw std::invalid_argument("ReachingParams.repetitions = " + std::to_string(p.repetitions) +
                                " is outside [1, 100]");
  }
  CheckRange("ReachingParams.sample_rate_hz", p.sample_rate_hz, 0.0, 10000.0, true, false);
  for (std::size_t i = 0; i < p.paths.size(); ++i) {
    const std::string name = "ReachingParams.paths[" + std::to_string(i) + "]";
    const int h = p.paths[i][0], g = p.paths[i][1];
    if (h < 0 || h >= static_cast<int>(p.homes_m.size())) {
      throw std::invalid_argument(name + " home index " + std::to_string(h) + " is outside [0, " +
                                  std::to_string(p.homes_m.size() - 1) + "]");
    }
    if (g < 0 || g >= static_cast<int>(p.targets_m.size())) {
      throw std::invalid_argument(name + " target index " + std::to_string(g) + " is outside [0, " +
                                  std::to_string(p.targets_m.size() - 1) + "]");
    }
    for (std::size_t k = 0; k < i; ++k) {
      if (p.paths[k] == p.paths[i]) {
        throw std::invalid_argument(name + " repeats path [" + std::to_string(h) + ", " +
                                    std::to_string(g) + "]; each pair at most once");
      }
    }
  }
}

}  // namespace

// ==============================================================================================

std::vector<double> ValueAt(const StimulationProgram& program, double t_s) {
  if (program.times_s.empty()) {
    throw std::invalid_argument("ValueAt: program has no samples");
  }
  const auto it = std::upper_bound(program.times_s.begin(), program.times_s.end(), t_s);
  const std::size_t k = it == program.times_s.begin() ? 0 : (it - program.times_s.begin()) - 1;
  return program.values_us[k];
}

std::vector<double> ClipToLimits(std::vector<double> values_us, const StimulationLimit& limit) {
  CheckLimit("StimulationLimit", limit);
  double sum = 0.0;
  for (double& v : values_us) {
    if (!std::isfinite(v)) {
      throw std::invalid_argument("ClipToLimits: pulse width " + Num(v) + " is not finite");
    }
    v = std::clamp(v, 0.0, kMaxPulseWidthUs);
    sum += v;
  }
  if (sum > limit.sum_max_us) {
    const double scale = limit.sum_max_us / sum;
    for (double& v : values_us) v *= scale;
  }
  return values_us;
}

StimulationProgram ClipToLimits(StimulationProgram program, const StimulationLimit& limit) {
  for (auto& v : program.values_us) v = ClipToLimits(std::move(v), limit);
  return program;
}

// --- step grid ----------------------------------------------------------------------------------

std::vector<std::vector<double>> StepGridPoints(const StepGridParams& params) {
  CheckStepGrid(params);
  const std::size_t n = params.channels.size();
  std::vector<std::size_t> dims(n);  // slowest first
  for (std::size_t i = 0; i < n; ++i) {
    dims[i] = params.order == GridOrder::kFirstChannelFastest ? n - 1 - i : i;
  }
  std::vector<double> u(n, 0.0);
  std::vector<char> reversed(n, 0);
  std::vector<std::vector<double>> out;
  Sweep(0, dims, params.spacing_us, params.u_max_us, &u, &reversed, &out);
  return out;
}

StimulationProgram StepGrid(const StepGridParams& params) {
  const std::vector<std::vector<double>> points = StepGridPoints(params);
  StimulationProgram p;
  p.channels = params.channels;
  const double T = params.step_duration_s;
  for (std::size_t k = 0; k < points.size(); ++k) {
    p.times_s.push_back(k * T);
    p.values_us.push_back(points[k]);
    p.steady_state_times_s.push_back((k + 1) * T - params.steady_state_lead_s);
  }
  p.duration_s = points.size() * T;
  StimulationLimit limit;
  limit.sum_max_us = params.u_max_us;
  return ClipToLimits(std::move(p), limit);
}

std::vector<StimulationProgram> StepGridDataSets(const StepGridParams& params, int num_data_sets) {
  if (num_data_sets < 1 || num_data_sets > 100) {
    throw std::invalid_argument("StepGridDataSets num_data_sets = " +
                                std::to_string(num_data_sets) + " is outside [1, 100]");
  }
  const GridOrder other = params.order == GridOrder::kFirstChannelFastest
                              ? GridOrder::kLastChannelFastest
                              : GridOrder::kFirstChannelFastest;
  std::vector<StimulationProgram> sets;
  for (int i = 0; i < num_data_sets; ++i) {
    StepGridParams q = params;
    q.order = i % 2 == 0 ? params.order : other;
    sets.push_back(StepGrid(q));
  }
  return sets;
}

// --- [Le 2010] ----------------------------------------------------------------------------------

StimulationProgram TriangularRamp(const TriangularRampParams& params) {
  CheckChannelName("TriangularRampParams.channel", params.channel);
  CheckLevels("TriangularRampParams", "u_min_us", params.u_min_us, "u_peak_us", params.u_peak_us);
  if (params.num_triangles < 1 || params.num_triangles > 1000) {
    throw std::invalid_argument("TriangularRampParams.num_triangles = " +
                                std::to_string(params.num_triangles) + " is outside [1, 1000]");
  }
  CheckTiming("TriangularRampParams.timing", params.timing);
  CheckLimit("TriangularRampParams.limit", params.limit);
  const double active = ActiveWindow(params.timing);
  const double dt = 1.0 / params.timing.pulse_rate_hz;
  const std::size_t K = CountStarts(active, dt);
  std::vector<double> times(K), values(K);
  for (std::size_t k = 0; k < K; ++k) {
    times[k] = k * dt;
    const double phase = times[k] / active * params.num_triangles;
    const double frac = phase - std::floor(phase);
    const double tri = 1.0 - std::abs(2.0 * frac - 1.0);  // 0 → 1 → 0 over one triangle
    values[k] = params.u_min_us + (params.u_peak_us - params.u_min_us) * tri;
  }
  return FrameSingleChannel(params.channel, params.timing, times, values, params.limit);
}

StimulationProgram Staircase(const StaircaseParams& params) {
  CheckChannelName("StaircaseParams.channel", params.channel);
  CheckLevels("StaircaseParams", "u_min_us", params.u_min_us, "u_max_us", params.u_max_us);
  CheckTiming("StaircaseParams.timing", params.timing);
  CheckLimit("StaircaseParams.limit", params.limit);
  const double active = ActiveWindow(params.timing);
  // One step of each width (τ + 2τ + 3τ = 1.5 T_s) must fit, and τ must span ≥ 2 pulse periods
  // so that step boundaries snapped to the pulse grid stay distinct.
  CheckRange("StaircaseParams.settling_time_s", params.settling_time_s,
             8.0 / params.timing.pulse_rate_hz, active / 1.5);
  const double tau = params.settling_time_s / 4.0;
  std::vector<int> widths;  // in units of τ
  for (int w = 1; w <= 3; ++w) {
    const long n = std::max(1L, std::lround(active / (3.0 * w * tau)));
    if (n > 10000000L) {
      throw std::invalid_argument("StaircaseParams: " + std::to_string(n) +
                                  " steps is too many (settling_time_s too short)");
    }
    widths.insert(widths.end(), static_cast<std::size_t>(n), w);
  }
  std::mt19937_64 rng(params.seed);
  Shuffle(&widths, rng);
  double total = 0.0;
  for (int w : widths) total += w * tau;
  const double scale = active / total;
  std::vector<double> times, values;
  double t = 0.0;
  for (int w : widths) {
    times.push_back(t);
    values.push_back(UniformIn(rng, params.u_min_us, params.u_max_us));
    t += w * tau * scale;
  }
  return FrameSingleChannel(params.channel, params.timing, times, values, params.limit);
}

StimulationProgram FilteredRandomNoise(const FilteredRandomNoiseParams& params) {
  CheckChannelName("FilteredRandomNoiseParams.channel", params.channel);
  CheckLevels("FilteredRandomNoiseParams", "u_min_us", params.u_min_us, "u_max_us",
              params.u_max_us);
  CheckTiming("FilteredRandomNoiseParams.timing", params.timing);
  CheckLimit("FilteredRandomNoiseParams.limit", params.limit);
  const double rate = params.timing.pulse_rate_hz;
  CheckRange("FilteredRandomNoiseParams.cutoff_hz", params.cutoff_hz, 0.0, rate / 2.0, true, true);
  if (params.filter_order < 1 || params.filter_order > 10) {
    throw std::invalid_argument("FilteredRandomNoiseParams.filter_order = " +
                                std::to_string(params.filter_order) + " is outside [1, 10]");
  }
  CheckRange("FilteredRandomNoiseParams.warm_up_s", params.warm_up_s, 0.0, kMaxDurationS);
  const double dt = 1.0 / rate;
  const std::size_t K = CountStarts(ActiveWindow(params.timing), dt);
  const auto W = static_cast<std::size_t>(std::lround(params.warm_up_s * rate));
  std::mt19937_64 rng(params.seed);
  std::vector<double> noise(W + K);
  for (double& x : noise) x = StandardNormal(rng);
  const std::vector<double> filtered =
      FilterCascade(DesignButterworthLowPass(params.filter_order, params.cutoff_hz, rate), noise);
  const auto first = filtered.begin() + static_cast<std::ptrdiff_t>(W);
  const auto [lo_it, hi_it] = std::minmax_element(first, filtered.end());
  const double lo = *lo_it, span = *hi_it - *lo_it;
  std::vector<double> times(K), values(K);
  for (std::size_t k = 0; k < K; ++k) {
    times[k] = k * dt;
    const double x = first[static_cast<std::ptrdiff_t>(k)];
    values[k] = span > 0.0 ? params.u_min_us + (x - lo) / span * (params.u_max_us - params.u_min_us)
                           : params.u_min_us;
  }
  return FrameSingleChannel(params.channel, params.timing, times, values, params.limit);
}

std::vector<int> PrmsSymbols(const PrmsParams& params, std::size_t length) {
  CheckPrms(params);
  const int q = params.num_levels;
  const auto n = static_cast<std::size_t>(params.register_length);
  long long period = 1;
  for (std::size_t i = 0; i < n; ++i) period *= q;
  period -= 1;
  std::mt19937_64 rng(params.seed);
  constexpr int kMaxTries = 100000;
  std::vector<int> c(n);
  bool found = false;
  for (int attempt = 0; attempt < kMaxTries && !found; ++attempt) {
    c[0] = 1 + static_cast<int>(UniformIndex(rng, static_cast<std::uint64_t>(q - 1)));
    for (std::size_t i = 1; i < n; ++i) c[i] = static_cast<int>(UniformIndex(rng, q));
    found = IsPrimitive(c, q, period);
  }
  if (!found) throw std::runtime_error("PrmsSymbols: no primitive polynomial found");
  std::vector<int> state(n, 0);
  while (std::all_of(state.begin(), state.end(), [](int s) { return s == 0; })) {
    for (int& s : state) s = static_cast<int>(UniformIndex(rng, q));
  }
  std::vector<int> out;
  out.reserve(length);
  for (std::size_t k = 0; k < length; ++k) {
    out.push_back(state[0]);
    LfsrStep(c, q, &state);
  }
  return out;
}

StimulationProgram Prms(const PrmsParams& params) {
  CheckPrms(params);
  const std::size_t M = CountStarts(ActiveWindow(params.timing), params.symbol_duration_s);
  const std::vector<int> symbols = PrmsSymbols(params, M);
  const double step = (params.u_max_us - params.u_min_us) / (params.num_levels - 1);
  std::vector<double> times(M), values(M);
  for (std::size_t k = 0; k < M; ++k) {
    times[k] = k * params.symbol_duration_s;
    values[k] = params.u_min_us + symbols[k] * step;
  }
  return FrameSingleChannel(params.channel, params.timing, times, values, params.limit);
}

// --- [Copur 2016]
// ----------------------------------------------------------------------------------

CoactivatedPair CoactivationMap(double u_us, double coact_agonist_us, double coact_antagonist_us) {
  CoactivatedPair out;
  if (u_us >= 0.0) {
    out.agonist_us = u_us + coact_agonist_us;
    out.antagonist_us = coact_antagonist_us;
  } else {
    out.agonist_us = coact_agonist_us;
    out.antagonist_us = coact_antagonist_us - u_us;
  }
  return out;
}

std::vector<double> MultisineVirtualInput(const MultisineParams& params) {
  CheckMultisine(params);
  const int j_lo = static_cast<int>(std::ceil(params.f_min_hz / params.frequency_step_hz - 1e-9));
  const int j_hi = static_cast<int>(std::floor(params.f_max_hz / params.frequency_step_hz + 1e-9));
  std::mt19937_64 rng(params.seed);
  std::vector<double> freq, phase;
  for (int j = std::max(j_lo, 1); j <= j_hi; ++j) {
    freq.push_back(j * params.frequency_step_hz);
    phase.push_back(UniformIn(rng, 0.0, 2.0 * kPi));
  }
  const double dt = 1.0 / params.pulse_rate_hz;
  const std::size_t K = CountStarts(params.duration_s, dt);
  std::vector<double> u(K, 0.0);
  double peak = 0.0;
  for (std::size_t k = 0; k < K; ++k) {
    const double t = k * dt;
    double s = 0.0;
    for (std::size_t j = 0; j < freq.size(); ++j) s += std::sin(2.0 * kPi * freq[j] * t + phase[j]);
    u[k] = s;
    peak = std::max(peak, std::abs(s));
  }
  if (peak > 0.0) {
    for (double& v : u) v *= params.amplitude_us / peak;
  }
  return u;
}

StimulationProgram Multisine(const MultisineParams& params) {
  const std::vector<double> u = MultisineVirtualInput(params);
  StimulationProgram p;
  p.channels = params.channels;
  p.duration_s = params.duration_s;
  const double dt = 1.0 / params.pulse_rate_hz;
  for (std::size_t k = 0; k < u.size(); ++k) {
    const CoactivatedPair pair =
        CoactivationMap(u[k], params.coact_agonist_us, params.coact_antagonist_us);
    p.times_s.push_back(k * dt);
    p.values_us.push_back({pair.agonist_us, pair.antagonist_us});
  }
  return ClipToLimits(std::move(p), params.limit);
}

// --- [Spagnol 2013]
// ----------------------------------------------------------------------------------

StimulationProgram ShoulderPseudoRandomSteps(const ShoulderStepsParams& params) {
  const std::string n = "ShoulderStepsParams";
  CheckChannels(n + ".channels", params.channels, 2, 2);
  CheckRange(n + ".level_max_us", params.level_max_us, 0.0, kMaxPulseWidthUs, true, false);
  CheckRange(n + ".level_min_us", params.level_min_us, 0.0, params.level_max_us, true, false);
  CheckRange(n + ".step_max_s", params.step_max_s, 0.0, kMaxDurationS, true, false);
  CheckRange(n + ".step_min_s", params.step_min_s, 0.0, params.step_max_s, true, false);
  CheckRange(n + ".gap_max_s", params.gap_max_s, 0.0, kMaxDurationS);
  CheckRange(n + ".gap_min_s", params.gap_min_s, 0.0, params.gap_max_s);
  CheckRange(n + ".pulse_rate_hz", params.pulse_rate_hz, 1.0, 1000.0);
  CheckRange(n + ".rest_s", params.rest_s, 0.0, kMaxDurationS / 2.0);
  CheckRange(n + ".duration_s", params.duration_s, 2.0 * params.rest_s, kMaxDurationS, true, false);
  CheckLimit(n + ".limit", params.limit);
  const double dt = 1.0 / params.pulse_rate_hz;
  auto periods = [&](double s) { return std::max(1.0, std::round(s / dt)) * dt; };
  StimulationProgram p;
  p.channels = params.channels;
  p.duration_s = params.duration_s;
  p.times_s.push_back(0.0);
  p.values_us.push_back({0.0, 0.0});
  std::mt19937_64 rng(params.seed);
  const double end = params.duration_s - params.rest_s;
  double t = std::round(params.rest_s / dt) * dt;
  for (;;) {
    const std::size_t channel = Uniform01(rng) < 0.5 ? 0 : 1;
    const double level = UniformIn(rng, params.level_min_us, params.level_max_us);
    const double step = periods(UniformIn(rng, params.step_min_s, params.step_max_s));
    const double gap_raw = UniformIn(rng, params.gap_min_s, params.gap_max_s);
    const double gap = std::round(gap_raw / dt) * dt;
    if (t + step > end + kTimeTolS) break;
    std::vector<double> v(2, 0.0);
    v[channel] = level;
    if (p.times_s.back() >= t - kTimeTolS) {  // replaces the rest entry at the same instant
      p.times_s.back() = t;
      p.values_us.back() = v;
    } else {
      p.times_s.push_back(t);
      p.values_us.push_back(v);
    }
    t += step;
    p.times_s.push_back(t);
    p.values_us.push_back({0.0, 0.0});
    t += gap;
  }
  return ClipToLimits(std::move(p), params.limit);
}

// --- [Schearer 2014]
// ----------------------------------------------------------------------------------

QuinticTiming MinimumJerk(double tau) {
  QuinticTiming q;
  if (tau <= 0.0) return q;
  if (tau >= 1.0) {
    q.s = 1.0;
    return q;
  }
  const double t2 = tau * tau, t3 = t2 * tau;
  q.s = t3 * (10.0 - 15.0 * tau + 6.0 * t2);
  q.ds = 30.0 * t2 * (1.0 - 2.0 * tau + t2);          // 30τ²(1 − τ)²
  q.dds = 60.0 * tau * (1.0 - 3.0 * tau + 2.0 * t2);  // 60τ(1 − τ)(1 − 2τ)
  return q;
}

std::vector<Vec3> TargetGrid3x3(const Vec3& high_left_m, const Vec3& high_right_m,
                                const Vec3& low_left_m, const Vec3& low_right_m) {
  std::vector<Vec3> out;
  for (int row = 0; row < 3; ++row) {
    const double a = row / 2.0;  // 0 high … 1 low
    for (int col = 0; col < 3; ++col) {
      const double b = col / 2.0;  // 0 left … 1 right
      Vec3 p;
      for (int i = 0; i < 3; ++i) {
        p[i] = (1 - a) * ((1 - b) * high_left_m[i] + b * high_right_m[i]) +
               a * ((1 - b) * low_left_m[i] + b * low_right_m[i]);
      }
      out.push_back(p);
    }
  }
  return out;
}

std::vector<Vec3> DefaultReachingTargets() {
  return TargetGrid3x3({0.40, 1.50, 0.05}, {0.40, 1.50, 0.35}, {0.40, 1.20, 0.05},
                       {0.40, 1.20, 0.35});
}

HandPath ReachingProgram(const ReachingParams& params) {
  CheckReaching(params);
  HandPath path;
  double t = 0.0;
  Vec3 here = params.homes_m[0];
  auto add = [&](SegmentKind kind, double duration, const Vec3& to, int home, int target, int rep) {
    if (duration <= 0.0) return;
    HandSegment s;
    s.kind = kind;
    s.start_s = t;
    s.duration_s = duration;
    s.from_m = here;
    s.to_m = to;
    s.home_index = home;
    s.target_index = target;
    s.repetition = rep;
    path.segments.push_back(s);
    t += duration;
    here = to;
  };
  std::vector<std::array<int, 2>> pairs = params.paths;
  if (pairs.empty()) {
    for (std::size_t h = 0; h < params.homes_m.size(); ++h) {
      for (std::size_t g = 0; g < params.targets_m.size(); ++g) {
        pairs.push_back({static_cast<int>(h), static_cast<int>(g)});
      }
    }
  }
  for (const auto& [hi, gi] : pairs) {
    const Vec3& home = params.homes_m[static_cast<std::size_t>(hi)];
    const Vec3& target = params.targets_m[static_cast<std::size_t>(gi)];
    if (here != home) add(SegmentKind::kTransfer, params.transfer_duration_s, home, -1, -1, -1);
    for (int r = 0; r < params.repetitions; ++r) {
      add(SegmentKind::kReach, params.reach_duration_s, target, hi, gi, r);
      add(SegmentKind::kHold, params.hold_s, target, hi, gi, r);
      add(SegmentKind::kReturn, params.reach_duration_s, home, hi, gi, r);
      add(SegmentKind::kPause, params.pause_s, home, hi, -1, r);
    }
  }
  path.duration_s = t;
  const double dt = 1.0 / params.sample_rate_hz;
  const std::size_t K = static_cast<std::size_t>(std::floor(t / dt + kTimeTolS)) + 1;
  for (std::size_t k = 0; k < K; ++k) {
    const double tk = std::min(k * dt, t);
    const HandState s = EvaluateHandPath(path, tk);
    path.times_s.push_back(tk);
    path.position_m.push_back(s.position_m);
    path.velocity_m_s.push_back(s.velocity_m_s);
    path.acceleration_m_s2.push_back(s.acceleration_m_s2);
  }
  return path;
}

HandState EvaluateHandPath(const HandPath& path, double t_s) {
  if (path.segments.empty()) throw std::invalid_argument("EvaluateHandPath: path has no segments");
  const auto it = std::upper_bound(path.segments.begin(), path.segments.end(), t_s,
                                   [](double t, const HandSegment& s) { return t < s.start_s; });
  const HandSegment& s = it == path.segments.begin() ? path.segments.front() : *(it - 1);
  const double T = s.duration_s;
  const QuinticTiming q = MinimumJerk((t_s - s.start_s) / T);
  HandState out;
  for (int i = 0; i < 3; ++i) {
    const double d = s.to_m[i] - s.from_m[i];
    out.position_m[i] = s.from_m[i] + d * q.s;
    out.velocity_m_s[i] = d * q.ds / T;
    out.acceleration_m_s2[i] = d * q.dds / (T * T);
  }
  return out;
}

std::vector<double> JointTorquesFromEndEffectorForce(
    const Vec3& force_n, const Vec3& r_wrist_to_joint_m,
    const std::vector<std::array<double, 6>>& jacobian_columns) {
  const Vec3& f = force_n;
  const Vec3& r = r_wrist_to_joint_m;
  const std::array<double, 6> wrench = {f[0],
                                        f[1],
                                        f[2],
                                        r[1] * f[2] - r[2] * f[1],
                                        r[2] * f[0] - r[0] * f[2],
                                        r[0] * f[1] - r[1] * f[0]};
  std::vector<double> tau;
  tau.reserve(jacobian_columns.size());
  for (const auto& column : jacobian_columns) {
    double t = 0.0;
    for (int i = 0; i < 6; ++i) t += column[i] * wrench[i];
    tau.push_back(t);
  }
  return tau;
}

}  // namespace fesim::protocols
