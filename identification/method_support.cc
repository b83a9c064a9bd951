#include "identification/method_support.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <locale>
#include <sstream>
#include <stdexcept>

#include "identification/levenberg_marquardt.h"

namespace fesim::identification {

namespace {

/// `label` with the trial's file when known: "train trial 0 (t/p1/step_grid_r1.csv)".
std::string Named(const Trial& trial, const std::string& label) {
  const auto source = trial.metadata.find("source");
  return source == trial.metadata.end() ? label : label + " (" + source->second + ")";
}

}  // namespace

Eigen::MatrixXd RequireColumns(const Trial& trial, const std::vector<std::string>& names,
                               const std::string& label) {
  Eigen::MatrixXd out(static_cast<Eigen::Index>(trial.size()),
                      static_cast<Eigen::Index>(names.size()));
  for (std::size_t c = 0; c < names.size(); ++c) {
    if (!trial.Has(names[c])) {
      throw std::runtime_error(Named(trial, label) + ": column " + names[c] + " is missing");
    }
    const auto& col = trial.Column(names[c]);
    for (std::size_t i = 0; i < col.size(); ++i) {
      if (!std::isfinite(col[i])) {
        throw std::runtime_error(Named(trial, label) + ": column " + names[c] +
                                 " is not finite at t = " + Num(trial.time[i]) +
                                 " s (NaN/dropouts must be removed first)");
      }
      out(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(c)) = col[i];
    }
  }
  return out;
}

Eigen::VectorXd OutputColumn(const Trial& trial, const std::string& name, const std::string& label,
                             std::size_t* missing) {
  if (!trial.Has(name)) {
    throw std::runtime_error(Named(trial, label) + ": column " + name + " is missing");
  }
  const auto& col = trial.Column(name);
  Eigen::VectorXd y(static_cast<Eigen::Index>(col.size()));
  *missing = 0;
  for (std::size_t i = 0; i < col.size(); ++i) {
    y(static_cast<Eigen::Index>(i)) = col[i];
    if (!std::isfinite(col[i])) ++*missing;
  }
  return y;
}

void KeepMeasuredPairs(std::vector<double>* y, std::vector<double>* yhat) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < y->size(); ++i) {
    if (!std::isfinite((*y)[i])) continue;
    (*y)[n] = (*y)[i];
    (*yhat)[n] = (*yhat)[i];
    ++n;
  }
  y->resize(n);
  yhat->resize(n);
}

Trial SensorRows(const Trial& trial, const std::vector<std::string>& needed) {
  const std::size_t n = trial.size();
  std::vector<char> mine(n, 0), other(n, 0);
  for (std::size_t k = 0; k < trial.names.size(); ++k) {
    const bool is_needed = std::find(needed.begin(), needed.end(), trial.names[k]) != needed.end();
    if (!is_needed && trial.names[k].rfind("u.", 0) == 0) continue;
    std::vector<char>& flag = is_needed ? mine : other;
    for (std::size_t i = 0; i < n; ++i) flag[i] |= std::isfinite(trial.columns[k][i]) ? 1 : 0;
  }
  // The sensor's step: the median step between its rows (dropouts are the minority).
  std::vector<double> steps;
  long last = -1;
  for (std::size_t i = 0; i < n; ++i) {
    if (!mine[i]) continue;
    if (last >= 0) steps.push_back(trial.time[i] - trial.time[static_cast<std::size_t>(last)]);
    last = static_cast<long>(i);
  }
  double step = 0.0;
  if (!steps.empty()) {
    std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
    step = steps[steps.size() / 2];
  }
  // A row where nothing was measured is a dropout of this sensor when it lies on its grid,
  // continued from the last kept row (so rounded time stamps do not drift off it).
  std::vector<std::size_t> rows;
  rows.reserve(n);
  double last_time = NAN;
  for (std::size_t i = 0; i < n; ++i) {
    bool keep = mine[i] != 0;
    if (!keep && !other[i]) {
      const double k =
          step > 0.0 && std::isfinite(last_time) ? (trial.time[i] - last_time) / step : 1.0;
      keep = std::round(k) >= 1.0 && std::abs(k - std::round(k)) <= kTimeStampTolerance;
    }
    if (!keep) continue;
    rows.push_back(i);
    last_time = trial.time[i];
  }
  if (rows.size() == n) return trial;
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

std::vector<Trial> SensorRows(const std::vector<Trial>& trials,
                              const std::vector<std::string>& needed) {
  std::vector<Trial> out;
  out.reserve(trials.size());
  for (const Trial& t : trials) out.push_back(SensorRows(t, needed));
  return out;
}

double UniformSamplePeriod(const Trial& trial, const std::string& label) {
  if (trial.size() < 2) throw std::runtime_error(Named(trial, label) + ": fewer than 2 samples");
  const double t0 = trial.time.front();
  const double T = (trial.time.back() - t0) / static_cast<double>(trial.size() - 1);
  if (!(T >= kMinSamplePeriodS && T <= kMaxSamplePeriodS)) {
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  ": column time: sample period %.6g s (%.6g Hz) is implausible for a measured "
                  "trial (allowed: %g to %g s; time in ms?)",
                  T, 1.0 / T, kMinSamplePeriodS, kMaxSamplePeriodS);
    throw std::runtime_error(Named(trial, label) + buf);
  }
  for (std::size_t i = 1; i < trial.size(); ++i) {
    const double grid = t0 + static_cast<double>(i) * T;
    if (std::abs(trial.time[i] - grid) > kTimeStampTolerance * T) {
      throw std::runtime_error(
          Named(trial, label) + ": column time is not uniformly sampled (near t = " +
          Num(trial.time[i]) + " s, more than " + Num(100.0 * kTimeStampTolerance) + " % of the " +
          Num(T) + " s step off its grid point); resample first");
    }
  }
  return T;
}

void RequireVaryingOutput(const std::vector<Trial>& trials, const std::string& column,
                          const std::string& what) {
  double first = NAN;
  for (const Trial& t : trials) {
    if (!t.Has(column)) return;  // missing columns are reported where they are read
    for (double v : t.Column(column)) {
      if (!std::isfinite(v)) continue;
      if (std::isnan(first)) first = v;
      if (v != first) return;
    }
  }
  if (std::isnan(first)) return;
  throw std::runtime_error(what + ": output column " + column + " is constant (" + Num(first) +
                           " in every sample): nothing to identify (the regressor matrix would "
                           "be rank deficient)");
}

void RequireSamples(const Trial& trial, std::size_t min_samples, const std::string& label,
                    const std::string& why) {
  if (trial.size() < min_samples) {
    throw std::runtime_error(Named(trial, label) + ": " + std::to_string(trial.size()) +
                             " samples, need at least " + std::to_string(min_samples) + " (" + why +
                             ")");
  }
}

MetadataOptions::MetadataOptions(const std::map<std::string, std::string>& metadata,
                                 std::string prefix)
    : metadata_(metadata), prefix_(std::move(prefix)) {}

int MetadataOptions::Int(const std::string& key, int fallback, int min, int max) {
  const std::string full = prefix_ + "." + key;
  used_.insert(full);
  const auto it = metadata_.find(full);
  if (it == metadata_.end()) return fallback;
  std::istringstream in(it->second);
  in.imbue(std::locale::classic());
  long v = 0;
  if (!(in >> v) || !(in >> std::ws).eof() || v < min || v > max) {
    throw std::runtime_error("metadata " + full + ": '" + it->second + "' must be an integer in [" +
                             std::to_string(min) + ", " + std::to_string(max) + "]");
  }
  return static_cast<int>(v);
}

double MetadataOptions::Real(const std::string& key, double fallback, double min, double max) {
  const std::string full = prefix_ + "." + key;
  used_.insert(full);
  const auto it = metadata_.find(full);
  if (it == metadata_.end()) return fallback;
  std::istringstream in(it->second);
  in.imbue(std::locale::classic());
  double v = 0;
  if (!(in >> v) || !(in >> std::ws).eof() || !(v >= min && v <= max)) {
    throw std::runtime_error("metadata " + full + ": '" + it->second + "' must be a number in [" +
                             Num(min) + ", " + Num(max) + "]");
  }
  return v;
}

void MetadataOptions::RejectUnknown() const {
  for (const auto& [key, value] : metadata_) {
    if (key.rfind(prefix_ + ".", 0) == 0 && used_.count(key) == 0) {
      std::string allowed;
      for (const auto& u : used_) allowed += (allowed.empty() ? "" : ", ") + u;
      throw std::runtime_error("metadata " + key + ": unknown option (allowed: " + allowed + ")");
    }
  }
}

Json ConvergenceJson(const std::vector<Convergence>& runs, std::size_t best) {
  if (best >= runs.size()) throw std::invalid_argument("ConvergenceJson: best run out of range");
  Json j = Json::Object();
  j.Set("best_run", static_cast<int>(best));
  j.Set("converged", runs[best].converged);
  j.Set("stop_reason", runs[best].stop_reason);
  Json all = Json::Array();
  for (const auto& r : runs) {
    Json o = Json::Object();
    o.Set("converged", r.converged);
    o.Set("stop_reason", r.stop_reason);
    o.Set("iterations", r.iterations);
    all.Push(o);
  }
  j.Set("runs", all);
  return j;
}

std::string ConvergenceYaml(const std::string& key, const std::vector<Convergence>& runs,
                            std::size_t best, int indent) {
  if (best >= runs.size()) throw std::invalid_argument("ConvergenceYaml: best run out of range");
  const std::string pad(static_cast<std::size_t>(indent), ' ');
  std::string s = pad + key + ":\n";
  s += pad + "  best_run: " + std::to_string(best) + "\n";
  s += pad + "  converged: " + (runs[best].converged ? "true" : "false") + "\n";
  s += pad + "  stop_reason: " + runs[best].stop_reason + "\n";
  s += pad + "  runs:\n";
  for (const auto& r : runs) {
    s += pad + "    - {converged: " + (r.converged ? "true" : "false") +
         ", stop_reason: " + r.stop_reason + ", iterations: " + std::to_string(r.iterations) +
         "}\n";
  }
  return s;
}

std::string NotConvergedWarning(const std::string& what, const std::vector<Convergence>& runs,
                                std::size_t best) {
  if (best >= runs.size() || runs[best].converged) return "";
  return what + ": the best local run (" + std::to_string(best + 1) + " of " +
         std::to_string(runs.size()) + ") did not converge (" + runs[best].stop_reason + " after " +
         std::to_string(runs[best].iterations) + " iterations)";
}

std::string Num(double v) {
  if (std::isnan(v)) return ".nan";
  if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

std::string YamlParam(const std::string& name, double value, const std::string& unit,
                      double ci_half_width, int indent) {
  std::string s = std::string(static_cast<std::size_t>(indent), ' ') + name +
                  ": {value: " + Num(value) + ", unit: \"" + unit + "\"";
  if (std::isfinite(ci_half_width)) {
    s += ", ci95: [" + Num(value - ci_half_width) + ", " + Num(value + ci_half_width) + "]";
  }
  return s + "}\n";
}

Eigen::VectorXd FilterBA(const Eigen::VectorXd& b, const Eigen::VectorXd& a, int delay,
                         const Eigen::VectorXd& x) {
  const Eigen::Index N = x.size();
  Eigen::VectorXd y = Eigen::VectorXd::Zero(N);
  for (Eigen::Index k = 0; k < N; ++k) {
    double acc = 0.0;
    for (Eigen::Index j = 0; j < b.size(); ++j) {
      const Eigen::Index i = k - delay - j;
      if (i >= 0) acc += b(j) * x(i);
    }
    for (Eigen::Index i = 1; i <= a.size(); ++i) {
      if (k - i >= 0) acc -= a(i - 1) * y(k - i);
    }
    y(k) = acc;
  }
  return y;
}

LinearLsResult SolveLinearLs(const Eigen::MatrixXd& Phi, const Eigen::VectorXd& Y) {
  if (Phi.rows() != Y.size()) throw std::invalid_argument("SolveLinearLs: size mismatch");
  if (!Phi.allFinite() || !Y.allFinite()) {
    // Rows that touch a missing sample (NaN: a tracker dropout in an output or its lags) are
    // dropped: the equation-error fit uses the complete rows only.
    std::vector<Eigen::Index> keep;
    for (Eigen::Index i = 0; i < Phi.rows(); ++i) {
      if (std::isfinite(Y(i)) && Phi.row(i).allFinite()) keep.push_back(i);
    }
    Eigen::MatrixXd P(static_cast<Eigen::Index>(keep.size()), Phi.cols());
    Eigen::VectorXd y(static_cast<Eigen::Index>(keep.size()));
    for (std::size_t k = 0; k < keep.size(); ++k) {
      P.row(static_cast<Eigen::Index>(k)) = Phi.row(keep[k]);
      y(static_cast<Eigen::Index>(k)) = Y(keep[k]);
    }
    return SolveLinearLs(P, y);
  }
  LinearLsResult r;
  r.theta = Phi.colPivHouseholderQr().solve(Y);
  r.cost = (Phi * r.theta - Y).squaredNorm();
  r.ci95_half_width = ConfidenceHalfWidths95(Phi.transpose() * Phi, r.cost, Phi.rows());
  return r;
}

}  // namespace fesim::identification
