#include "diagnosis/measured.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <stdexcept>

#include "identification/method_support.h"

namespace fesim::diagnosis {
namespace {

/// A trial's name in messages: its `source` metadata (the file) or "trial K".
std::string Label(const Trial& trial, std::size_t k) {
  const auto source = trial.metadata.find("source");
  return source != trial.metadata.end() ? source->second : "trial " + std::to_string(k);
}

/// " (T s after T0 s)" for the non-increasing time message.
std::string Fmt9(double t, double t0) {
  char buf[96];
  std::snprintf(buf, sizeof buf, " (%.9g s after %.9g s)", t, t0);
  return buf;
}

/// `v` as %.6g text.
std::string Fmt6(double v) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

/// Relative spread of the sample steps below which a record counts as uniformly sampled and is
/// used as it is: 1 %, so that a 60 Hz log written to 4 decimals (steps 0.0166 and 0.0167 s, 0.6 %)
/// is not resampled — interpolating between its samples would average its noise away (the noise
/// estimate of person.h fell from 0.010 to 0.006 rad on such a log) for no gain in timing.
constexpr double kUniformTolerance = 1e-2;

void Validate(const sim::ModelParams& rig, const std::vector<Trial>& measured,
              std::vector<std::string>* outputs, std::vector<std::string>* channels) {
  if (measured.empty()) throw std::runtime_error("diagnose: no measured trials");
  *outputs = measured[0].NamesWithPrefix("q.");
  if (outputs->empty()) throw std::runtime_error(Label(measured[0], 0) + ": no q.* output column");
  for (const auto& o : *outputs) {
    const int c = sim::CoordinateIndex(o.substr(2));
    if (c < 0)
      throw std::runtime_error(Label(measured[0], 0) + ": column " + o + ": unknown joint");
    if (rig.coordinates[c].mode != sim::CoordinateMode::kFree) {
      throw std::runtime_error(Label(measured[0], 0) + ": column " + o +
                               ": joint is not free in the scenario (locked or prescribed)");
    }
  }
  std::set<std::string> stimulated;
  for (std::size_t t = 0; t < measured.size(); ++t) {
    const Trial& tr = measured[t];
    const std::string label = Label(tr, t);
    if (tr.size() < 2 * kMinSamples) {
      throw std::runtime_error(label + ": " + std::to_string(tr.size()) +
                               " samples, need at least " + std::to_string(2 * kMinSamples));
    }
    if (tr.NamesWithPrefix("q.") != *outputs) {
      throw std::runtime_error(label + ": q.* columns differ from trial 0's");
    }
    const auto inputs = tr.NamesWithPrefix("u.");
    if (inputs.empty()) throw std::runtime_error(label + ": no u.* input column");
    for (const auto& u : inputs) {
      bool found = false;
      for (const auto& ch : rig.channels) found |= ch.name == u.substr(2);
      if (!found)
        throw std::runtime_error(label + ": column " + u + ": no such channel in the rig");
      bool active = false;
      for (double v : tr.Column(u)) {
        if (!std::isfinite(v)) throw std::runtime_error(label + ": column " + u + ": NaN input");
        active = active || v > 0.0;
      }
      if (active) stimulated.insert(u.substr(2));
    }
  }
  for (const auto& ch : rig.channels) {
    if (stimulated.count(ch.name)) channels->push_back(ch.name);
  }
  if (channels->empty()) throw std::runtime_error("diagnose: no trial stimulates any channel");
}

}  // namespace

bool IsUniformlySampled(const std::vector<double>& time) {
  if (time.size() < 2) return true;
  const double dt0 = time[1] - time[0];
  for (std::size_t i = 2; i < time.size(); ++i) {
    if (std::abs(time[i] - time[i - 1] - dt0) > kUniformTolerance * dt0) return false;
  }
  return dt0 > 0.0;
}

Trial ResampleToUniform(const Trial& trial, const std::string& label) {
  const std::size_t n = trial.size();
  std::vector<double> steps;
  for (std::size_t i = 1; i < n; ++i) {
    const double dt = trial.time[i] - trial.time[i - 1];
    if (!(dt > 0.0)) {
      throw std::runtime_error(label + ": column time: not increasing at row " + std::to_string(i) +
                               Fmt9(trial.time[i], trial.time[i - 1]));
    }
    steps.push_back(dt);
  }
  if (steps.empty()) return trial;
  std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
  const double dt = steps[steps.size() / 2];
  const double t0 = trial.time.front();
  const long m = static_cast<long>(std::floor((trial.time.back() - t0) / dt + 1e-9));
  Trial out;
  out.metadata = trial.metadata;
  for (long k = 0; k <= m; ++k) out.time.push_back(t0 + static_cast<double>(k) * dt);
  for (std::size_t c = 0; c < trial.names.size(); ++c) {
    const std::vector<double>& v = trial.columns[c];
    const bool input = trial.names[c].rfind("u.", 0) == 0;
    std::vector<double> col(out.time.size(), NAN);
    std::size_t j = 0;  // last source row with time ≤ t
    for (std::size_t f = 0; f < out.time.size(); ++f) {
      const double t = out.time[f];
      while (j + 1 < n && trial.time[j + 1] <= t + 1e-9 * dt) ++j;
      if (input) {  // the nearest row (ties: the earlier)
        const bool next = j + 1 < n && trial.time[j + 1] - t < t - trial.time[j];
        col[f] = v[next ? j + 1 : j];
      } else if (std::abs(trial.time[j] - t) <= 1e-9 * dt || j + 1 >= n) {
        col[f] = v[j];  // a sample at t
      } else if (std::isfinite(v[j]) && std::isfinite(v[j + 1])) {
        const double w = (t - trial.time[j]) / (trial.time[j + 1] - trial.time[j]);
        col[f] = (1.0 - w) * v[j] + w * v[j + 1];
      }
    }
    out.AddColumn(trial.names[c], std::move(col));
  }
  out.metadata["resampled"] = Fmt6(dt);
  return out;
}

MeasuredData PrepareMeasured(const sim::ModelParams& rig, const std::vector<Trial>& measured,
                             double holdout_fraction, int heldout_trials) {
  if (measured.empty()) throw std::runtime_error("diagnose: no measured trials");
  MeasuredData d;
  std::vector<Trial> trials;
  trials.reserve(measured.size());
  for (std::size_t k = 0; k < measured.size(); ++k) {
    // The rows of the outputs' sensor and its dropouts on its grid (a measured record's time
    // column is the union of its sensors' grids); the rule `fesim identify` uses.
    trials.push_back(identification::SensorRows(measured[k], measured[k].NamesWithPrefix("q.")));
    if (!IsUniformlySampled(trials.back().time)) {
      const std::size_t before = trials.back().size();
      trials.back() = ResampleToUniform(trials.back(), Label(measured[k], k));
      const Trial& r = trials.back();
      d.notes.push_back(Label(measured[k], k) + ": sampling not uniform; resampled to " +
                        std::to_string(r.size()) + " samples at " +
                        (r.size() > 1 ? Fmt6(r.time[1] - r.time[0]) : std::string("–")) +
                        " s (the median step; outputs linearly interpolated between finite "
                        "samples, gaps kept; inputs from the nearest row) from " +
                        std::to_string(before));
    }
  }
  Validate(rig, trials, &d.outputs, &d.channels);
  SplitTrials(trials, d.outputs, holdout_fraction, &d.train, &d.heldout, &d.split, heldout_trials);
  for (DataView* view : {&d.train, &d.heldout}) {
    view->initial_q.clear();
    for (const auto& tr : view->trials) view->initial_q.push_back(InitialPosture(tr, d.outputs));
  }
  return d;
}

std::vector<double> InitialPosture(const Trial& trial, const std::vector<std::string>& outputs) {
  std::vector<double> out;
  for (const auto& o : outputs) {
    std::vector<double> first;
    const auto& y = trial.Column(o);
    for (std::size_t i = 0; i < y.size() && first.size() < kInitialPostureSamples; ++i) {
      if (trial.time[i] - trial.time.front() > kInitialPostureWindowS) break;
      if (std::isfinite(y[i])) first.push_back(y[i]);
    }
    if (first.empty()) {
      out.push_back(NAN);
      continue;
    }
    std::sort(first.begin(), first.end());
    const std::size_t m = first.size();
    out.push_back(m % 2 ? first[m / 2] : 0.5 * (first[m / 2 - 1] + first[m / 2]));
  }
  return out;
}

void SplitTrials(const std::vector<Trial>& measured, const std::vector<std::string>& outputs,
                 double holdout_fraction, DataView* train, DataView* heldout, std::string* how,
                 int heldout_trials) {
  if (!(holdout_fraction > 0.0 && holdout_fraction <= 0.8)) {
    throw std::invalid_argument("holdout_fraction must be in (0, 0.8]");
  }
  train->outputs = heldout->outputs = outputs;
  train->trials.clear();
  heldout->trials.clear();
  train->use.clear();
  heldout->use.clear();
  if (measured.size() >= 2) {
    const auto n = static_cast<int>(measured.size());
    if (heldout_trials < 1 || heldout_trials >= n) {
      throw std::invalid_argument("heldout_trials " + std::to_string(heldout_trials) +
                                  " must be in [1, " + std::to_string(n - 1) + "] for " +
                                  std::to_string(n) + " trials");
    }
    const auto n_train = static_cast<std::size_t>(n - heldout_trials);
    for (std::size_t t = 0; t < measured.size(); ++t) {
      DataView* view = t < n_train ? train : heldout;
      view->trials.push_back(measured[t]);
      view->use.emplace_back(measured[t].size(), 1);
    }
    *how = "trials 0-" + std::to_string(n_train - 1) + " train, " +
           (heldout_trials == 1
                ? "trial " + std::to_string(n - 1) + " (the last) held out whole"
                : "trials " + std::to_string(n_train) + "-" + std::to_string(n - 1) +
                      " (the last " + std::to_string(heldout_trials) + ") held out whole");
    return;
  }
  const Trial& tr = measured[0];
  const double t_cut =
      tr.time.front() + (1.0 - holdout_fraction) * (tr.time.back() - tr.time.front());
  std::size_t n_train = 0;
  while (n_train < tr.size() && tr.time[n_train] < t_cut) ++n_train;
  if (n_train < kMinSamples || tr.size() - n_train < kMinSamples) {
    throw std::runtime_error(Label(tr, 0) + ": " + std::to_string(tr.size()) +
                             " samples are too few to split into training and held-out segments");
  }
  Trial head;
  head.metadata = tr.metadata;
  head.time.assign(tr.time.begin(), tr.time.begin() + n_train);
  for (std::size_t k = 0; k < tr.names.size(); ++k) {
    head.AddColumn(tr.names[k],
                   std::vector<double>(tr.columns[k].begin(), tr.columns[k].begin() + n_train));
  }
  train->trials.push_back(head);
  train->use.emplace_back(n_train, 1);
  heldout->trials.push_back(tr);
  std::vector<char> use(tr.size(), 0);
  for (std::size_t i = n_train; i < tr.size(); ++i) use[i] = 1;
  heldout->use.push_back(use);
  char buf[128];
  std::snprintf(buf, sizeof buf,
                "one trial: t < %.1f s trains, t >= %.1f s held out (blocked segments)", t_cut,
                t_cut);
  *how = buf;
}

}  // namespace fesim::diagnosis
