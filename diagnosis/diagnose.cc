#include "diagnosis/diagnose.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <set>
#include <stdexcept>

#include "diagnosis/signatures.h"
#include "scenarios/parallel.h"

namespace fesim::diagnosis {
namespace {

using Clock = std::chrono::steady_clock;

/// Tremor band of PRODUCT.md / papers/001_* §2, Hz.
constexpr double kTremorLowHz = 3.0, kTremorHighHz = 12.0;
/// Coarse and fine spectrum grid steps, Hz.
constexpr double kCoarseDfHz = 0.01, kFineDfHz = 0.0005;
/// Largest input–residual lag examined, s.
constexpr double kMaxLagS = 0.5;
/// Fewest training samples per trial, and fewest samples in a held-out segment.
constexpr std::size_t kMinSamples = 50;
/// Relative spread of the sample steps below which a record counts as uniformly sampled.
constexpr double kUniformTolerance = 1e-3;

std::string Fmt(const char* format, double a, double b = 0.0, double c = 0.0) {
  char buf[320];
  std::snprintf(buf, sizeof buf, format, a, b, c);
  return buf;
}

Eigen::VectorXd Concat(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  Eigen::VectorXd x(a.size() + b.size());
  x << a, b;
  return x;
}

std::vector<ModelParameter> Join(const std::vector<ModelParameter>& a,
                                 const std::vector<ModelParameter>& b) {
  std::vector<ModelParameter> out = a;
  out.insert(out.end(), b.begin(), b.end());
  return out;
}

/// Columns of `view` (one output) as one series per trial, counted samples only (others NaN).
std::vector<double> Masked(const DataView& v, std::size_t t, const std::string& col,
                           const std::vector<double>& values) {
  std::vector<double> out(values.size(), NAN);
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (v.use[t][i]) out[i] = values[i];
  }
  (void)col;
  return out;
}

/// A trial's name in messages: its `source` metadata (the file) or "trial K".
std::string Label(const Trial& trial, std::size_t k) {
  const auto source = trial.metadata.find("source");
  return source != trial.metadata.end() ? source->second : "trial " + std::to_string(k);
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
  }
  for (const auto& ch : rig.channels) {
    if (stimulated.count(ch.name)) channels->push_back(ch.name);
  }
  if (channels->empty()) throw std::runtime_error("diagnose: no trial stimulates any channel");
}

/// Score test of one candidate at the baseline (see diagnose.h, step 3). Returns S, dof and θ
/// (zeros for dropped probes).
struct ScoreTest {
  double statistic = 0.0;
  int dof = 0;
  Eigen::VectorXd theta;
};

ScoreTest RunScoreTest(const Eigen::VectorXd& r, const Eigen::MatrixXd& D,
                       const Eigen::MatrixXd& Js, const std::vector<bool>& one_sided,
                       double sigma2) {
  // Project D onto the orthogonal complement of the subject Jacobian's columns.
  Eigen::MatrixXd Dt = D;
  if (Js.cols() > 0) {
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Js);
    Dt = D - Js * qr.solve(D);
  }
  std::vector<int> keep(D.cols());
  std::iota(keep.begin(), keep.end(), 0);
  ScoreTest out;
  out.theta = Eigen::VectorXd::Zero(D.cols());
  for (int pass = 0; pass < static_cast<int>(D.cols()) + 1 && !keep.empty(); ++pass) {
    Eigen::MatrixXd K(Dt.rows(), keep.size());
    for (std::size_t k = 0; k < keep.size(); ++k) K.col(k) = Dt.col(keep[k]);
    const Eigen::MatrixXd G = K.transpose() * K;
    const Eigen::VectorXd g = K.transpose() * r;
    const Eigen::VectorXd theta = -G.ldlt().solve(g);
    int worst = -1;
    for (std::size_t k = 0; k < keep.size(); ++k) {
      if (one_sided[keep[k]] && theta(k) < 0.0 && (worst < 0 || theta(k) < theta(worst))) {
        worst = static_cast<int>(k);
      }
    }
    if (worst >= 0) {
      keep.erase(keep.begin() + worst);
      continue;
    }
    out.statistic = std::max(0.0, g.dot(G.ldlt().solve(g)) / sigma2);
    out.dof = static_cast<int>(keep.size());
    for (std::size_t k = 0; k < keep.size(); ++k) out.theta(keep[k]) = theta(k);
    break;
  }
  return out;
}

/// Refined spectrum peak: coarse grid, then a fine grid ±2 coarse steps around the peak.
SpectrumPeak RefinedPeak(const std::vector<double>& r, double dt) {
  const double nyquist_margin = 0.5 / dt - kCoarseDfHz;
  const double hi = std::min(kTremorHighHz, nyquist_margin);
  if (hi <= kTremorLowHz) return {};
  SpectrumPeak coarse = ResidualSpectrumPeak(r, dt, kTremorLowHz, hi, kCoarseDfHz);
  std::vector<double> f;
  for (double x = coarse.frequency_hz - 2 * kCoarseDfHz; x <= coarse.frequency_hz + 2 * kCoarseDfHz;
       x += kFineDfHz) {
    f.push_back(x);
  }
  const std::vector<double> p = Periodogram(r, dt, f);
  const std::size_t best = std::max_element(p.begin(), p.end()) - p.begin();
  coarse.frequency_hz = f[best];
  return coarse;
}

/// The rows of `trial` at which some output was sampled (a measured record's time column is the
/// union of its sensors' grids; the other rows only carry inputs or other sensors).
Trial OutputRows(const Trial& trial, const std::vector<std::string>& outputs) {
  std::vector<std::size_t> rows;
  for (std::size_t i = 0; i < trial.size(); ++i) {
    bool any = false;
    for (const auto& o : outputs) any = any || std::isfinite(trial.Column(o)[i]);
    if (any) rows.push_back(i);
  }
  if (rows.size() == trial.size()) return trial;
  Trial out;
  out.metadata = trial.metadata;
  for (std::size_t i : rows) out.time.push_back(trial.time[i]);
  for (std::size_t k = 0; k < trial.names.size(); ++k) {
    std::vector<double> col;
    for (std::size_t i : rows) col.push_back(trial.columns[k][i]);
    out.AddColumn(trial.names[k], std::move(col));
  }
  return out;
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
                               Fmt(" (%.9g s after %.9g s)", trial.time[i], trial.time[i - 1]));
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
  out.metadata["resampled"] = Fmt("%.6g", dt);
  return out;
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
  *how = Fmt("one trial: t < %.1f s trains, t >= %.1f s held out (blocked segments)", t_cut, t_cut);
}

Diagnosis Diagnose(const sim::ModelParams& rig, const std::vector<Trial>& measured,
                   const DiagnoseOptions& options, const DiagnoseProgress& progress) {
  const auto t0 = Clock::now();
  auto report = [&](double f, const std::string& s) {
    if (progress) progress(f, s);
  };
  Diagnosis out;
  LibraryContext ctx;
  if (measured.empty()) throw std::runtime_error("diagnose: no measured trials");
  std::vector<Trial> trials;
  for (std::size_t k = 0; k < measured.size(); ++k) {
    trials.push_back(OutputRows(measured[k], measured[k].NamesWithPrefix("q.")));
    if (!IsUniformlySampled(trials.back().time)) {
      const double before = trials.back().size();
      trials.back() = ResampleToUniform(trials.back(), Label(measured[k], k));
      out.notes.push_back(Label(measured[k], k) + ": sampling not uniform; resampled to " +
                          Fmt("%.0f samples at %.6g s (the median step; outputs linearly "
                              "interpolated between finite samples, gaps kept; inputs from the "
                              "nearest row) from %.0f",
                              trials.back().size(), trials.back().time[1] - trials.back().time[0],
                              before));
    }
  }
  Validate(rig, trials, &ctx.outputs, &ctx.channels);
  DataView train, held;
  SplitTrials(trials, ctx.outputs, options.holdout_fraction, &train, &held, &out.split);
  const FitOptions& fo = options.fit;

  // 2. Baseline calibration of the subject parameters.
  report(0.0, "calibrating subject parameters");
  const std::vector<ModelParameter> subject = SubjectParameters(rig, ctx);
  Eigen::VectorXd xs0(subject.size());
  for (std::size_t k = 0; k < subject.size(); ++k) xs0(k) = subject[k].start;
  const FitResult base_fit =
      FitParameters(rig, subject, xs0, train, fo, 0, options.baseline_iterations);
  out.simulations += base_fit.simulations;
  for (std::size_t k = 0; k < subject.size(); ++k) {
    out.subject_parameters.push_back(
        {subject[k].name, subject[k].unit, base_fit.x(k), base_fit.ci95(k)});
  }
  const std::vector<Trial> train_base =
      Predict(rig, subject, base_fit.x, train, fo.tolerance, fo.threads);
  const Eigen::VectorXd r0 = StackResiduals(train, train_base);
  const double rss0 = r0.squaredNorm();
  const long n = r0.size();
  const double sigma2 = rss0 / static_cast<double>(std::max<long>(1, n - base_fit.x.size()));
  out.heldout = held;
  out.heldout_baseline = Predict(rig, subject, base_fit.x, held, fo.tolerance, fo.threads);
  out.baseline_heldout_nrmse = ViewNrmse(held, out.heldout_baseline);
  out.simulations += static_cast<int>(train.trials.size() + held.trials.size());
  Eigen::MatrixXd Js = base_fit.jacobian;
  if (Js.rows() != n) {
    Js = ResidualJacobian(rig, subject, base_fit.x, r0, train, fo, &out.simulations);
  }

  // Descriptive signatures on the first training trial.
  report(0.3, "residual signatures");
  const Trial& tr0 = train.trials[0];
  const double dt = tr0.time[1] - tr0.time[0];
  std::vector<std::vector<double>> inputs;
  const auto input_names = tr0.NamesWithPrefix("u.");
  for (const auto& u : input_names) inputs.push_back(tr0.Column(u));
  const std::vector<double> cumulative = CumulativeStimulation(tr0.time, inputs);
  for (const auto& o : ctx.outputs) {
    OutputSignature s;
    s.output = o;
    const auto& y = tr0.Column(o);
    const auto& yh = train_base[0].Column(o);
    std::vector<double> r(y.size());
    double ss = 0;
    int cnt = 0;
    for (std::size_t i = 0; i < y.size(); ++i) {
      r[i] = y[i] - yh[i];
      if (std::isfinite(r[i])) {
        ss += r[i] * r[i];
        ++cnt;
      }
    }
    s.rms_rad = cnt ? std::sqrt(ss / cnt) : 0.0;
    const SpectrumPeak peak = RefinedPeak(r, dt);
    s.spectrum_peak_hz = peak.frequency_hz;
    s.spectrum_peak_ratio = peak.power_ratio;
    ctx.tremor_frequency_hz.push_back(peak.frequency_hz > 0 ? peak.frequency_hz : 6.0);
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
    out.signatures.push_back(s);
  }

  // 3. Score tests.
  std::vector<Candidate> library = CandidateLibrary(rig, ctx);
  int applicable = 0;
  for (const auto& c : library) applicable += c.applicable ? 1 : 0;
  std::vector<ScoreTest> tests(library.size());
  {
    // All probe simulations in one parallel batch.
    struct Job {
      int cand, probe, trial;
    };
    std::vector<Job> jobs;
    for (std::size_t c = 0; c < library.size(); ++c) {
      if (!library[c].applicable) continue;
      for (std::size_t p = 0; p < library[c].probes.size(); ++p) {
        for (std::size_t t = 0; t < train.trials.size(); ++t) {
          jobs.push_back({static_cast<int>(c), static_cast<int>(p), static_cast<int>(t)});
        }
      }
    }
    std::vector<Trial> sims(jobs.size());
    std::vector<char> ok(jobs.size(), 1);
    ParallelFor(static_cast<int>(jobs.size()), fo.threads, [&](int j) {
      const Candidate& c = library[jobs[j].cand];
      const std::vector<ModelParameter> params = Join(subject, c.params);
      const Eigen::VectorXd x = Concat(base_fit.x, c.probes[jobs[j].probe]);
      DataView one;
      one.trials = {train.trials[jobs[j].trial]};
      one.use = {train.use[jobs[j].trial]};
      one.outputs = train.outputs;
      try {
        sims[j] = Predict(rig, params, x, one, fo.tolerance, 1)[0];
      } catch (const std::exception&) {
        ok[j] = 0;
      }
    });
    out.simulations += static_cast<int>(jobs.size());
    std::size_t j = 0;
    for (std::size_t c = 0; c < library.size(); ++c) {
      if (!library[c].applicable) continue;
      const int np = static_cast<int>(library[c].probes.size());
      Eigen::MatrixXd D = Eigen::MatrixXd::Zero(n, np);
      for (int p = 0; p < np; ++p) {
        std::vector<Trial> pred;
        bool all_ok = true;
        for (std::size_t t = 0; t < train.trials.size(); ++t, ++j) {
          pred.push_back(sims[j]);
          all_ok = all_ok && ok[j];
        }
        if (all_ok) D.col(p) = StackResiduals(train, pred) - r0;
      }
      tests[c] = RunScoreTest(r0, D, Js, library[c].one_sided, sigma2);
    }
  }
  for (std::size_t c = 0; c < library.size(); ++c) {
    CandidateResult cr;
    cr.id = library[c].id;
    cr.joint = library[c].joint;
    cr.label = library[c].label;
    cr.applicable = library[c].applicable;
    cr.not_applicable_reason = library[c].not_applicable_reason;
    if (cr.applicable && tests[c].dof > 0) {
      cr.score_statistic = tests[c].statistic;
      cr.dof = tests[c].dof;
      cr.p_adjusted = std::min(1.0, applicable * ChiSquareSurvival(cr.score_statistic, cr.dof));
      cr.score = std::max(0.0, -std::log10(std::max(cr.p_adjusted, 1e-300)));
    }
    out.candidates.push_back(cr);
  }

  // Evidence lines from the signatures of the output the candidate acts on (or the strongest).
  auto signature_for = [&](const CandidateResult& cr) -> const OutputSignature& {
    if (!cr.joint.empty()) {
      for (const auto& s : out.signatures) {
        if (s.output == "q." + cr.joint) return s;
      }
    }
    std::size_t best = 0;
    for (std::size_t k = 1; k < out.signatures.size(); ++k) {
      if (out.signatures[k].rms_rad > out.signatures[best].rms_rad) best = k;
    }
    return out.signatures[best];
  };
  for (auto& cr : out.candidates) {
    if (!cr.applicable) {
      cr.evidence = "not tested: " + cr.not_applicable_reason;
      continue;
    }
    const OutputSignature& s = signature_for(cr);
    std::string e =
        Fmt("score chi2 %.1f (dof %.0f, p_adj %.2g); ", cr.score_statistic, cr.dof, cr.p_adjusted) +
        s.output + ": ";
    if (cr.id == "tremor") {
      e += Fmt("residual spectrum peak %.3f Hz at %.1fx the median (3-12 Hz)", s.spectrum_peak_hz,
               s.spectrum_peak_ratio);
    } else if (cr.id == "fatigue" || cr.id == "potentiation") {
      e += Fmt("corr(residual, cumulative stimulation) %.2f, corr(residual, time) %.2f",
               s.corr_cumulative_stimulation, s.corr_time);
    } else if (cr.id == "sensor_drift") {
      e += Fmt("corr(residual, time) %.2f, corr(residual, cumulative stimulation) %.2f",
               s.corr_time, s.corr_cumulative_stimulation);
    } else if (cr.id == "delay" || cr.id == "crosstalk" || cr.id == "unequal_muscle_dynamics" ||
               cr.id == "force_length_velocity") {
      e += Fmt("input-residual cross-correlation peak %.2f at lag %.3f s (", s.input_lag_corr,
               s.input_lag_s) +
           s.input_lag_column + " rate)";
    } else if (cr.id == "stiction" || cr.id == "spasticity") {
      e += Fmt("corr(residual, velocity) %.2f, corr(residual, sign velocity) %.2f", s.corr_velocity,
               s.corr_velocity_sign);
    } else {
      e += Fmt("corr(residual, posture) %.2f", s.corr_posture);
    }
    cr.evidence = e;
  }

  // 4. Fit the most plausible candidates.
  std::vector<int> order;
  for (std::size_t c = 0; c < library.size(); ++c) {
    if (out.candidates[c].applicable && out.candidates[c].p_adjusted < options.alpha) {
      order.push_back(static_cast<int>(c));
    }
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return out.candidates[a].score_statistic > out.candidates[b].score_statistic;
  });
  // Keep one candidate per id in the first round (the best-scoring joint).
  {
    std::vector<int> unique;
    std::set<std::string> seen;
    for (int c : order) {
      if (seen.insert(library[c].id).second) unique.push_back(c);
    }
    order = unique;
  }
  if (static_cast<int>(order.size()) > options.max_fitted) order.resize(options.max_fitted);

  struct Fitted {
    std::vector<int> cands;
    FitResult fit;
    double heldout_nrmse = NAN;
    std::vector<Trial> heldout_pred;
  };
  auto lr_p_adj = [&](double rss_before, double rss_after, int p) {
    const double lr = static_cast<double>(n) * std::log(rss_before / std::max(rss_after, 1e-300));
    return std::min(1.0, applicable * ChiSquareSurvival(lr, p));
  };
  // Fits `cands`' parameters on top of the subject parameters. With first_free > 0 the first
  // `first_free` entries of x0 (subject ⊕ earlier mechanisms) are profiled: re-optimised to
  // first order through their Jacobian `held_jacobian` at x0 (FitParameters), and moved by
  // their linearised step (within bounds) before the held-out prediction.
  auto fit_extension = [&](const std::vector<int>& cands, const Eigen::VectorXd& x0, int first_free,
                           int iterations, const Eigen::MatrixXd* held_jacobian = nullptr,
                           double rss_held = 0.0) {
    std::vector<ModelParameter> params = subject;
    for (int c : cands) params = Join(params, library[c].params);
    Fitted f;
    f.cands = cands;
    const bool profiled = first_free > 0 && held_jacobian && held_jacobian->cols() == first_free;
    f.fit = FitParameters(rig, params, x0, train, fo, first_free, iterations,
                          profiled ? held_jacobian : nullptr);
    // Polish only a profiled fit that explains something (its training LR test against the
    // fit without it, RSS `rss_held`, passes on the profiled cost); the others keep their
    // profiled fit, which fails the LR test anyway.
    if (profiled && lr_p_adj(rss_held, f.fit.cost, static_cast<int>(params.size()) - first_free) <
                        options.alpha) {
      out.simulations += f.fit.simulations;
      Eigen::VectorXd x1 = f.fit.x;
      for (int k = 0; k < first_free; ++k) {
        x1(k) = std::clamp(x1(k) + f.fit.nuisance_step(k), params[k].lower, params[k].upper);
      }
      // The linearised step is poor when the held parameters must move far (a strong mechanism
      // the baseline absorbed): polish everything together from there.
      f.fit = FitParameters(rig, params, x1, train, fo, 0, options.refit_iterations);
    }
    out.simulations += f.fit.simulations;
    out.simulations += static_cast<int>(held.trials.size());
    try {
      f.heldout_pred = Predict(rig, params, f.fit.x, held, fo.tolerance, fo.threads);
      f.heldout_nrmse = ViewNrmse(held, f.heldout_pred);
    } catch (const std::runtime_error&) {
      // The extended model fails to simulate the held-out data (e.g. driven past a joint's
      // range): it predicts nothing there, so its held-out gain is −∞ and it is not accepted.
      f.heldout_pred = out.heldout_baseline;
      f.heldout_nrmse = INFINITY;
    }
    return f;
  };
  const int ns = static_cast<int>(subject.size());

  // Screening: each plausible candidate alone, subject parameters held at the baseline.
  std::vector<Fitted> round1;
  for (std::size_t k = 0; k < order.size(); ++k) {
    const int c = order[k];
    report(0.35 + 0.4 * k / order.size(), "fitting extension " + library[c].label);
    Fitted f = fit_extension({c}, Concat(base_fit.x, library[c].start_from_step(tests[c].theta)),
                             ns, options.screen_iterations, &Js, rss0);
    CandidateResult& cr = out.candidates[c];
    cr.fitted = true;
    cr.lr_p_adjusted = lr_p_adj(rss0, f.fit.cost, static_cast<int>(library[c].params.size()));
    cr.heldout_nrmse = f.heldout_nrmse;
    cr.heldout_gain = (out.baseline_heldout_nrmse - f.heldout_nrmse) / out.baseline_heldout_nrmse;
    for (std::size_t p = 0; p < library[c].params.size(); ++p) {
      cr.parameters.push_back({library[c].params[p].name, library[c].params[p].unit,
                               f.fit.x(ns + p), f.fit.ci95(ns + p)});
    }
    round1.push_back(std::move(f));
  }
  auto passes = [&](const CandidateResult& cr) {
    return cr.fitted && cr.lr_p_adjusted < options.alpha &&
           cr.heldout_gain > options.min_heldout_gain;
  };
  int best = -1;
  for (std::size_t k = 0; k < round1.size(); ++k) {
    const CandidateResult& cr = out.candidates[round1[k].cands[0]];
    if (passes(cr) &&
        (best < 0 || cr.heldout_gain > out.candidates[round1[best].cands[0]].heldout_gain)) {
      best = static_cast<int>(k);
    }
  }
  std::vector<int> accepted;
  Fitted current;
  double first_lr_p = 1.0, first_gain = 0.0;
  if (best >= 0) {
    const int c1 = round1[best].cands[0];
    accepted.push_back(c1);
    out.candidates[c1].accepted = true;
    first_lr_p = out.candidates[c1].lr_p_adjusted;
    first_gain = out.candidates[c1].heldout_gain;
    report(0.78, "refitting " + library[c1].label + " with the subject parameters");
    current = fit_extension({c1}, round1[best].fit.x, 0, options.refit_iterations);
    // A second mechanism on top, among the other ids that passed on their own.
    std::vector<int> second;
    for (std::size_t k = 0; k < round1.size(); ++k) {
      const int c = round1[k].cands[0];
      // Its own held-out gain is not required: the first mechanism may mask it.
      if (static_cast<int>(k) != best && out.candidates[c].fitted &&
          out.candidates[c].lr_p_adjusted < options.alpha && library[c].id != library[c1].id) {
        second.push_back(static_cast<int>(k));
      }
    }
    std::sort(second.begin(), second.end(), [&](int a, int b) {
      return out.candidates[round1[a].cands[0]].heldout_gain >
             out.candidates[round1[b].cands[0]].heldout_gain;
    });
    for (int k : second) {
      if (static_cast<int>(accepted.size()) >= options.max_accepted) break;
      const int c = round1[k].cands[0];
      report(0.85, "fitting extension " + library[c1].label + " + " + library[c].label);
      std::vector<int> both_c = accepted;
      both_c.push_back(c);
      const Eigen::VectorXd x0 =
          Concat(current.fit.x, round1[k].fit.x.tail(library[c].params.size()));
      Fitted both =
          fit_extension(both_c, x0, static_cast<int>(current.fit.x.size()),
                        options.screen_iterations, &current.fit.jacobian, current.fit.cost);
      const double g = (current.heldout_nrmse - both.heldout_nrmse) / current.heldout_nrmse;
      const double p =
          lr_p_adj(current.fit.cost, both.fit.cost, static_cast<int>(library[c].params.size()));
      if (p < options.alpha && g > options.min_heldout_gain) {
        accepted.push_back(c);
        out.candidates[c].accepted = true;
        report(0.9, "refitting the extended model with the subject parameters");
        current = fit_extension(both_c, both.fit.x, 0, options.refit_iterations);
      }
    }
  }

  // 5. Verdict.
  report(0.95, "verdict");
  auto structure_of = [&](const std::vector<Trial>& pred, std::vector<double>* per_output) {
    double worst = 0.0;
    for (const auto& o : ctx.outputs) {
      double s_out = 0.0;
      for (std::size_t t = 0; t < held.trials.size(); ++t) {
        const auto& y = held.trials[t].Column(o);
        const auto& yh = pred[t].Column(o);
        std::vector<double> r(y.size());
        for (std::size_t i = 0; i < y.size(); ++i) r[i] = y[i] - yh[i];
        s_out = std::max(s_out, StructuredVarianceFraction(Masked(held, t, o, r)));
      }
      per_output->push_back(s_out);
      worst = std::max(worst, s_out);
    }
    return worst;
  };
  std::vector<double> s_base, s_ext;
  const double structure_base = structure_of(out.heldout_baseline, &s_base);
  if (accepted.empty()) {
    out.heldout_extended = out.heldout_baseline;
    out.extended_heldout_nrmse = out.baseline_heldout_nrmse;
  } else {
    out.heldout_extended = current.heldout_pred;
    out.extended_heldout_nrmse = current.heldout_nrmse;
  }
  const double structure_ext = structure_of(out.heldout_extended, &s_ext);
  for (std::size_t k = 0; k < out.signatures.size(); ++k) {
    out.signatures[k].structure_heldout_baseline = s_base[k];
    out.signatures[k].structure_heldout_extended = s_ext[k];
  }
  out.gain = (out.baseline_heldout_nrmse - out.extended_heldout_nrmse) / out.baseline_heldout_nrmse;
  double best_gain = 0.0;
  for (const auto& cr : out.candidates) {
    if (cr.fitted && std::isfinite(cr.heldout_gain))
      best_gain = std::max(best_gain, cr.heldout_gain);
  }
  if (accepted.empty()) {
    if (structure_base > options.max_structure) {
      out.cause = "unexplained";
      out.confidence = std::min(1.0, 0.5 + 0.5 * structure_base / options.max_structure);
    } else {
      out.cause = "none";
      out.confidence = 1.0 - 0.5 * std::min(1.0, best_gain / options.min_heldout_gain);
    }
  } else {
    const std::string& id = library[accepted[0]].id;
    out.cause = id;
    double g_alt = 0.0;
    for (const auto& cr : out.candidates) {
      if (cr.fitted && cr.id != id && std::isfinite(cr.heldout_gain) && !cr.accepted) {
        g_alt = std::max(g_alt, cr.heldout_gain);
      }
    }
    out.confidence = std::clamp((1.0 - first_lr_p) * (1.0 - g_alt / first_gain), 0.0, 1.0);
    if (structure_ext > options.max_structure) out.confidence = std::min(out.confidence, 0.4);
    std::size_t at = subject.size();
    for (int c : accepted) {
      out.mechanisms.push_back(library[c].label);
      out.mechanism_ids.push_back(library[c].id);
      for (const auto& p : library[c].params) {
        out.extension_parameters.push_back(
            {library[c].label + ":" + p.name, p.unit, current.fit.x(at), current.fit.ci95(at)});
        ++at;
      }
    }
  }
  // Ranking: accepted first, then score, then held-out gain.
  std::stable_sort(out.candidates.begin(), out.candidates.end(),
                   [](const CandidateResult& a, const CandidateResult& b) {
                     if (a.accepted != b.accepted) return a.accepted;
                     return a.score > b.score;
                   });
  out.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  report(1.0, "done");
  return out;
}

}  // namespace fesim::diagnosis
