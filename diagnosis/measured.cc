#include "diagnosis/measured.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <stdexcept>

namespace fesim::diagnosis {
namespace {

/// A trial's name in messages: its `source` metadata (the file) or "trial K".
std::string Label(const Trial& trial, std::size_t k) {
  const auto source = trial.metadata.find("source");
  return source != trial.metadata.end() ? source->second : "trial " + std::to_string(k);
}

/// " (step DT s after DT0 s; " for the non-uniform sampling message.
std::string Steps(double dt, double dt0) {
  char buf[96];
  std::snprintf(buf, sizeof buf, " (step %.6g s after %.6g s; ", dt, dt0);
  return buf;
}

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
    const double dt0 = tr.time[1] - tr.time[0];
    for (std::size_t i = 2; i < tr.size(); ++i) {
      const double dt = tr.time[i] - tr.time[i - 1];
      if (std::abs(dt - dt0) > 1e-3 * dt0) {
        throw std::runtime_error(label + ": column time: sampling is not uniform at row " +
                                 std::to_string(i) + Steps(dt, dt0) + "resample to one rate)");
      }
    }
  }
  for (const auto& ch : rig.channels) {
    if (stimulated.count(ch.name)) channels->push_back(ch.name);
  }
  if (channels->empty()) throw std::runtime_error("diagnose: no trial stimulates any channel");
}

/// The rows of `trial` on its outputs' sampling grid. A measured record's time column is the
/// union of its sensors' grids: rows that only carry inputs or other sensors are dropped. A row
/// on the grid at which every output is NaN is a tracker dropout: it stays (NaN samples do not
/// count in the fit), so that dropouts do not make the sampling look non-uniform. The grid is
/// the first sampled time plus multiples of the smallest step between sampled rows (within
/// 10⁻³ of a step, the tolerance of the uniformity check).
Trial OutputRows(const Trial& trial, const std::vector<std::string>& outputs) {
  std::vector<std::size_t> sampled;
  for (std::size_t i = 0; i < trial.size(); ++i) {
    bool any = false;
    for (const auto& o : outputs) any = any || std::isfinite(trial.Column(o)[i]);
    if (any) sampled.push_back(i);
  }
  if (sampled.size() == trial.size()) return trial;
  std::vector<std::size_t> rows = sampled;
  if (sampled.size() >= 2) {
    double step = INFINITY;
    for (std::size_t k = 1; k < sampled.size(); ++k) {
      step = std::min(step, trial.time[sampled[k]] - trial.time[sampled[k - 1]]);
    }
    const double t0 = trial.time[sampled.front()];
    rows.clear();
    for (std::size_t i = sampled.front(); i <= sampled.back(); ++i) {
      const double k = (trial.time[i] - t0) / step;
      if (std::abs(k - std::round(k)) <= 1e-3) rows.push_back(i);
    }
  }
  Trial out;
  out.metadata = trial.metadata;
  for (std::size_t i : rows) out.time.push_back(trial.time[i]);
  for (std::size_t k = 0; k < trial.names.size(); ++k) {
    std::vector<double> col;
    col.reserve(rows.size());
    for (std::size_t i : rows) col.push_back(trial.columns[k][i]);
    out.AddColumn(trial.names[k], std::move(col));
  }
  return out;
}

}  // namespace

MeasuredData PrepareMeasured(const sim::ModelParams& rig, const std::vector<Trial>& measured,
                             double holdout_fraction) {
  if (measured.empty()) throw std::runtime_error("diagnose: no measured trials");
  MeasuredData d;
  std::vector<Trial> trials;
  trials.reserve(measured.size());
  for (const auto& t : measured) trials.push_back(OutputRows(t, t.NamesWithPrefix("q.")));
  Validate(rig, trials, &d.outputs, &d.channels);
  SplitTrials(trials, d.outputs, holdout_fraction, &d.train, &d.heldout, &d.split);
  return d;
}

void SplitTrials(const std::vector<Trial>& measured, const std::vector<std::string>& outputs,
                 double holdout_fraction, DataView* train, DataView* heldout, std::string* how) {
  if (!(holdout_fraction > 0.0 && holdout_fraction <= 0.8)) {
    throw std::invalid_argument("holdout_fraction must be in (0, 0.8]");
  }
  train->outputs = heldout->outputs = outputs;
  train->trials.clear();
  heldout->trials.clear();
  train->use.clear();
  heldout->use.clear();
  if (measured.size() >= 2) {
    for (std::size_t t = 0; t + 1 < measured.size(); ++t) {
      train->trials.push_back(measured[t]);
      train->use.emplace_back(measured[t].size(), 1);
    }
    heldout->trials.push_back(measured.back());
    heldout->use.emplace_back(measured.back().size(), 1);
    *how = "trials 0-" + std::to_string(measured.size() - 2) + " train, trial " +
           std::to_string(measured.size() - 1) + " (the last) held out whole";
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
