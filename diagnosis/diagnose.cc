#include "diagnosis/diagnose.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <mutex>
#include <numeric>
#include <set>
#include <stdexcept>

#include "diagnosis/measured.h"
#include "diagnosis/reduced_model.h"
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

/// The options that change results, as cache-key text (not fit.threads).
std::string OptionsText(const DiagnoseOptions& o) {
  std::string s;
  for (const double v :
       {o.holdout_fraction, o.alpha, o.min_heldout_gain, o.max_structure, o.fit.relative_tolerance,
        o.fit.fd_step, o.fit.tolerance, o.fit.speed_time_scale_s, o.fit.max_steps_per_s}) {
    s += ExactNumberText(v) + ",";
  }
  s += o.batches_while_structured ? "bs," : "b,";
  for (const int v : {o.max_fitted, o.max_screened, o.max_accepted, o.baseline_iterations,
                      o.screen_iterations, o.refit_iterations, o.fit.max_iterations}) {
    s += std::to_string(v) + ",";
  }
  for (const double v : o.baseline_fd_steps) s += "h" + ExactNumberText(v) + ",";
  return s + o.model;
}

const Json& Member(const Json& j, const std::string& key) {
  const Json* m = j.Find(key);
  if (m == nullptr) throw std::runtime_error("diagnose: cached result without '" + key + "'");
  return *m;
}

Json VectorJson(const Eigen::VectorXd& v) {
  return {std::vector<double>(v.data(), v.data() + v.size())};
}

Eigen::VectorXd VectorFromJson(const Json& j) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(j.Items().size()));
  for (Eigen::Index k = 0; k < v.size(); ++k) v(k) = j.Items()[k].AsNumber();
  return v;
}

Json MatrixJson(const Eigen::MatrixXd& m) {
  Json j = Json::Object();
  j.Set("rows", static_cast<long>(m.rows())).Set("cols", static_cast<long>(m.cols()));
  j.Set("column_major", std::vector<double>(m.data(), m.data() + m.size()));
  return j;
}

Eigen::MatrixXd MatrixFromJson(const Json& j) {
  const auto rows = static_cast<Eigen::Index>(Member(j, "rows").AsNumber());
  const auto cols = static_cast<Eigen::Index>(Member(j, "cols").AsNumber());
  const Eigen::VectorXd data = VectorFromJson(Member(j, "column_major"));
  if (rows < 0 || cols < 0 || data.size() != rows * cols) {
    throw std::runtime_error("diagnose: cached matrix has the wrong size");
  }
  return Eigen::Map<const Eigen::MatrixXd>(data.data(), rows, cols);
}

/// A fit without its Jacobian (cached separately where it is needed).
Json FitJson(const FitResult& f) {
  Json j = Json::Object();
  j.Set("x", VectorJson(f.x)).Set("ci95", VectorJson(f.ci95)).Set("cost", f.cost);
  j.Set("residuals", f.residuals).Set("simulations", f.simulations);
  j.Set("converged", f.converged);
  return j;
}

FitResult FitFromJson(const Json& j) {
  FitResult f;
  f.x = VectorFromJson(Member(j, "x"));
  f.ci95 = VectorFromJson(Member(j, "ci95"));
  f.cost = Member(j, "cost").AsNumber();
  f.residuals = static_cast<long>(Member(j, "residuals").AsNumber());
  f.simulations = static_cast<int>(Member(j, "simulations").AsNumber());
  const Json* converged = j.Find("converged");  // absent in caches written before it was kept
  f.converged = converged && converged->AsBool();
  return f;
}

/// A candidate made of output drifts only (sensor_drift) leaves the simulation as it is: its
/// probes are the model's predictions plus the drifts, without simulating.
bool DriftOnly(const Candidate& c) {
  return std::all_of(c.params.begin(), c.params.end(), [](const ModelParameter& p) {
    return p.target == ModelParameter::Target::kOutputDrift;
  });
}

/// Largest structured variance share (StructuredVarianceFraction) of the held-out residual
/// y − ŷ over the outputs; per output (appended in the order of `outputs`) when per_output is
/// given. NaN gaps of the held-out data are masked.
double HeldoutStructure(const DataView& held, const std::vector<std::string>& outputs,
                        const std::vector<Trial>& pred, std::vector<double>* per_output) {
  double worst = 0.0;
  for (const auto& o : outputs) {
    double s_out = 0.0;
    for (std::size_t t = 0; t < held.trials.size(); ++t) {
      const auto& y = held.trials[t].Column(o);
      const auto& yh = pred[t].Column(o);
      std::vector<double> r(y.size());
      for (std::size_t i = 0; i < y.size(); ++i) r[i] = y[i] - yh[i];
      s_out = std::max(s_out, StructuredVarianceFraction(Masked(held, t, o, r)));
    }
    if (per_output) per_output->push_back(s_out);
    worst = std::max(worst, s_out);
  }
  return worst;
}

/// What the probe simulations of the score tests need.
struct ProbeContext {
  const sim::ModelParams& rig;
  const std::vector<Candidate>& library;
  const DataView& train;
  const FitOptions& fit;
  /// DiagnoseOptions::map (empty: fit.threads threads here).
  const std::function<std::vector<std::string>(
      std::size_t, const std::function<std::string(std::size_t)>&)>& map;
};

/// Probe directions D_c = r(probe) − r (N × probes; a failed probe's column 0) of the candidates
/// `cands` (library indices) on top of the model (base_params, base_x) with training predictions
/// `base_pred` and residual r. All probe simulations in one parallel batch (on the MPI ranks with
/// `map`); adds them to *simulations.
std::map<int, Eigen::MatrixXd> ProbeDirections(const ProbeContext& ctx,
                                               const std::vector<ModelParameter>& base_params,
                                               const Eigen::VectorXd& base_x,
                                               const std::vector<Trial>& base_pred,
                                               const Eigen::VectorXd& r,
                                               const std::vector<int>& cands, int* simulations) {
  const DataView& train = ctx.train;
  struct Job {
    int cand, probe, trial;
  };
  std::vector<Job> jobs;
  for (int c : cands) {
    for (std::size_t p = 0; p < ctx.library[c].probes.size(); ++p) {
      for (std::size_t t = 0; t < train.trials.size(); ++t) {
        jobs.push_back({c, static_cast<int>(p), static_cast<int>(t)});
      }
    }
  }
  std::vector<Trial> sims(jobs.size());
  std::vector<char> ok(jobs.size(), 1);
  std::vector<std::size_t> simulated;
  for (std::size_t j = 0; j < jobs.size(); ++j) {
    const Candidate& c = ctx.library[jobs[j].cand];
    if (!DriftOnly(c)) {
      simulated.push_back(j);
      continue;
    }
    sims[j] = base_pred[jobs[j].trial];
    AddOutputDrift(c.params, c.probes[jobs[j].probe], &sims[j]);
  }
  const auto probe = [&](std::size_t j) {
    const Candidate& c = ctx.library[jobs[j].cand];
    const std::vector<ModelParameter> params = Join(base_params, c.params);
    const Eigen::VectorXd x = Concat(base_x, c.probes[jobs[j].probe]);
    DataView one;
    one.trials = {train.trials[jobs[j].trial]};
    one.use = {train.use[jobs[j].trial]};
    one.outputs = train.outputs;
    try {
      sims[j] = Predict(ctx.rig, params, x, one, ctx.fit, 1)[0];
    } catch (const std::exception&) {
      ok[j] = 0;
    }
  };
  if (ctx.map) {
    // Elsewhere (MPI ranks): each probe's simulation comes back as JSON; "" = it failed.
    const std::vector<std::string> texts = ctx.map(simulated.size(), [&](std::size_t i) {
      const std::size_t j = simulated[i];
      probe(j);
      return ok[j] ? TrialsToJson({sims[j]}).Dump(0) : std::string();
    });
    for (std::size_t i = 0; i < simulated.size(); ++i) {
      const std::size_t j = simulated[i];
      ok[j] = texts[i].empty() ? 0 : 1;
      if (ok[j]) sims[j] = TrialsFromJson(Json::Parse(texts[i], "probe"), "probe")[0];
    }
  } else {
    ParallelFor(simulated.size(), ctx.fit.threads, [&](std::size_t i) { probe(simulated[i]); });
  }
  *simulations += static_cast<int>(simulated.size());
  std::map<int, Eigen::MatrixXd> directions;
  std::size_t j = 0;
  for (int c : cands) {
    const int np = static_cast<int>(ctx.library[c].probes.size());
    Eigen::MatrixXd D = Eigen::MatrixXd::Zero(r.size(), np);
    for (int p = 0; p < np; ++p) {
      std::vector<Trial> pred;
      bool all_ok = true;
      for (std::size_t t = 0; t < train.trials.size(); ++t, ++j) {
        pred.push_back(sims[j]);
        all_ok = all_ok && ok[j];
      }
      if (all_ok) D.col(p) = StackResiduals(train, pred) - r;
    }
    directions[c] = std::move(D);
  }
  return directions;
}

Json ScoreTestJson(const ScoreTest& st) {
  Json e = Json::Object();
  e.Set("statistic", st.statistic).Set("dof", st.dof).Set("theta", VectorJson(st.theta));
  return e;
}

/// The diagnosis' stages through DiagnoseOptions::cache: Get returns the cached value of a stage
/// or computes, stores and returns it. A computed value goes through the cache's text either way
/// (Parse(Dump)), so a fresh and a resumed run continue from the same numbers.
class StageCache {
 public:
  StageCache(const DiagnoseOptions& o, int* cached)
      : cache_(o.cache), prefix_{"diagnose", o.cache_inputs, OptionsText(o)}, cached_(cached) {}

  Json Get(const std::vector<std::string>& stage, const std::function<Json()>& compute) const {
    std::vector<std::string> parts = prefix_;
    parts.insert(parts.end(), stage.begin(), stage.end());
    Json value;
    if (cache_ != nullptr && cache_->Load(parts, &value)) {
      const std::lock_guard<std::mutex> lock(mutex_);  // stages may run on several threads
      ++*cached_;
      return value;
    }
    value = Json::Parse(compute().Dump(0));
    if (cache_ != nullptr) cache_->Store(parts, value);
    return value;
  }

 private:
  ResultCache* cache_;
  std::vector<std::string> prefix_;
  int* cached_;
  mutable std::mutex mutex_;
};

/// Step 4's last refit (diagnose.h): its difference steps (Candidate::refit_fd_steps of the
/// accepted candidates) and starts — the fit `fit` itself, then the scanned point
/// (Candidate::refit_scan_*) of lowest training Σr², whatever its Σr² against the fit's. The scan's
/// costs are a stage of `stages`; `text` (empty without a scan) lists them for the progress report.
struct RefitPlan {
  std::set<double> steps;
  std::vector<Eigen::VectorXd> starts;
  std::string text;
};
RefitPlan PlanRefit(const sim::ModelParams& rig, const std::vector<Candidate>& library,
                    const std::vector<ModelParameter>& subject, const std::vector<int>& accepted,
                    const FitResult& fit, const DataView& train, const FitOptions& fo,
                    const StageCache& stages, int* simulations) {
  RefitPlan plan;
  plan.starts = {fit.x};
  std::vector<Eigen::VectorXd> scan;
  std::vector<ModelParameter> ext_params = subject;
  std::vector<std::string> stage = {"refit_scan"};
  auto at = static_cast<Eigen::Index>(subject.size());
  for (int c : accepted) {
    const Candidate& cand = library[c];
    ext_params = Join(ext_params, cand.params);
    stage.push_back(std::to_string(c) + ":" + cand.label);
    plan.steps.insert(cand.refit_fd_steps.begin(), cand.refit_fd_steps.end());
    if (cand.refit_scan_param >= 0) {
      const auto k = at + cand.refit_scan_param;
      const ModelParameter& par = cand.params[static_cast<std::size_t>(cand.refit_scan_param)];
      for (const double factor : cand.refit_scan_factors) {
        Eigen::VectorXd x = fit.x;
        x(k) = std::clamp(x(k) * factor, par.lower, par.upper);
        scan.push_back(x);
      }
    }
    at += static_cast<Eigen::Index>(cand.params.size());
  }
  if (scan.empty()) return plan;
  std::string x_text = "x=";
  for (Eigen::Index k = 0; k < fit.x.size(); ++k) x_text += ExactNumberText(fit.x(k)) + ",";
  stage.push_back(x_text);
  const Json costs = stages.Get(stage, [&] {
    Json j = Json::Array();
    for (const auto& x : scan) {
      double cost = INFINITY;
      try {
        cost = StackResiduals(train, Predict(rig, ext_params, x, train, fo)).squaredNorm();
      } catch (const std::runtime_error&) {
        // not simulable there: not a start
      }
      *simulations += static_cast<int>(train.trials.size());
      j.Push(std::isfinite(cost) ? Json(cost) : Json());
    }
    return j;
  });
  std::size_t lowest = scan.size();
  double lowest_cost = INFINITY;
  plan.text = "refit starts scanned: Σr² " + ExactNumberText(fit.cost) + " at the fit;";
  for (std::size_t k = 0; k < scan.size(); ++k) {
    const Json& v = costs.Items()[k];
    plan.text += " " + (v.IsNull() ? std::string("-") : ExactNumberText(v.AsNumber()));
    if (!v.IsNull() && v.AsNumber() < lowest_cost) {
      lowest = k;
      lowest_cost = v.AsNumber();
    }
  }
  if (lowest < scan.size()) plan.starts.push_back(scan[lowest]);
  return plan;
}

/// The start of a candidate's fit from its profile starts (Candidate::profile_starts, diagnose.h
/// step 4): with the candidate held at each, the subject parameters fitted `iterations` LM steps
/// from each of `subject_starts` (side by side on fo.threads threads). When the profile starts
/// differ in one parameter and the lowest Σr² is at an inner one, the profile is refined twice at
/// the vertex of the parabola through the lowest and its neighbours (ParabolaVertex; held fits
/// from those three points' subject values): steps of 10 % of the forearm weight left seed 1095
/// 20 % off the planted force where the all-free fit stopped (docs/diagnosis.md, session 13).
/// Returns the lowest Σr² as subject ⊕ candidate values (empty when none simulates). A stage of
/// `stages`; its simulations are added to *simulations.
Eigen::VectorXd LowestProfileStart(const sim::ModelParams& rig,
                                   const std::vector<ModelParameter>& subject,
                                   const std::vector<Eigen::VectorXd>& subject_starts,
                                   const Candidate& cand, int index, const DataView& train,
                                   const FitOptions& fo, int iterations, const StageCache& stages,
                                   int* simulations) {
  constexpr int kVertexRounds = 2;
  const auto nc = static_cast<Eigen::Index>(cand.params.size());
  const std::vector<ModelParameter> held_first = Join(cand.params, subject);
  std::vector<std::string> stage = {"profile_start", std::to_string(index) + ":" + cand.label,
                                    "iterations=" + std::to_string(iterations),
                                    "vertex_rounds=" + std::to_string(kVertexRounds)};
  for (const auto& x : subject_starts) {
    std::string text = "x=";
    for (Eigen::Index k = 0; k < x.size(); ++k) text += ExactNumberText(x(k)) + ",";
    stage.push_back(text);
  }
  // The one candidate parameter the profile starts vary (-1: none or several).
  Eigen::Index varied = -1;
  int n_varied = 0;
  for (Eigen::Index k = 0; k < nc; ++k) {
    const bool differs =
        std::any_of(cand.profile_starts.begin(), cand.profile_starts.end(),
                    [&](const Eigen::VectorXd& p) { return p(k) != cand.profile_starts[0](k); });
    if (differs) {
      varied = k;
      ++n_varied;
    }
  }
  if (n_varied != 1) varied = -1;
  const Json j = stages.Get(stage, [&] {
    int n_sims = 0;
    // Held fits from x0s (held-first layout), all side by side; per group of `group` consecutive
    // starts the lowest Σr² as (cost, x), cost ∞ when none of the group ran.
    using Point = std::pair<double, Eigen::VectorXd>;
    const auto lowest_of = [&](const std::vector<Eigen::VectorXd>& x0s, std::size_t group) {
      std::vector<FitResult> fits(x0s.size());
      std::vector<char> ok(fits.size(), 0);
      ParallelFor(fits.size(), fo.threads, [&](std::size_t k) {
        try {
          fits[k] =
              FitParameters(rig, held_first, x0s[k], train, fo, static_cast<int>(nc), iterations);
          ok[k] = 1;
        } catch (const std::runtime_error&) {
          // not simulable with the candidate there: not a start
        }
      });
      std::vector<Point> best(fits.size() / group, Point{INFINITY, Eigen::VectorXd()});
      for (std::size_t k = 0; k < fits.size(); ++k) {
        if (!ok[k]) continue;
        n_sims += fits[k].simulations;
        if (fits[k].cost < best[k / group].first) best[k / group] = {fits[k].cost, fits[k].x};
      }
      return best;
    };
    std::vector<Eigen::VectorXd> x0s;  // profile-start-major
    x0s.reserve(cand.profile_starts.size() * subject_starts.size());
    for (const auto& p : cand.profile_starts) {
      for (const auto& s : subject_starts) x0s.push_back(Concat(p, s));
    }
    std::vector<Point> profile = lowest_of(x0s, subject_starts.size());  // per profile start
    for (int round = 0; round < kVertexRounds && varied >= 0; ++round) {
      std::vector<Point> done;
      for (const auto& pt : profile) {
        if (std::isfinite(pt.first)) done.push_back(pt);
      }
      std::sort(done.begin(), done.end(),
                [&](const auto& a, const auto& b) { return a.second(varied) < b.second(varied); });
      std::size_t m = 0;
      for (std::size_t k = 0; k < done.size(); ++k) {
        if (done[k].first < done[m].first) m = k;
      }
      if (m == 0 || m + 1 >= done.size()) break;
      const auto &p0 = done[m - 1], &p1 = done[m], &p2 = done[m + 1];
      const double v = ParabolaVertex(p0.second(varied), p0.first, p1.second(varied), p1.first,
                                      p2.second(varied), p2.first);
      if (!(v > p0.second(varied) && v < p2.second(varied))) break;
      std::vector<Eigen::VectorXd> at_vertex = {p0.second, p1.second, p2.second};
      for (auto& x : at_vertex) x(varied) = v;
      profile.push_back(lowest_of(at_vertex, at_vertex.size())[0]);
    }
    Eigen::VectorXd best;
    double best_cost = INFINITY;
    for (const auto& pt : profile) {
      if (pt.first < best_cost) {
        best_cost = pt.first;
        best = Concat(pt.second.tail(pt.second.size() - nc), pt.second.head(nc));
      }
    }
    Json r = Json::Object();
    r.Set("x", best.size() ? VectorJson(best) : Json()).Set("simulations", n_sims);
    return r;
  });
  *simulations += static_cast<int>(Member(j, "simulations").AsNumber());
  const Json& x = Member(j, "x");
  return x.IsNull() ? Eigen::VectorXd() : VectorFromJson(x);
}

}  // namespace

Diagnosis Diagnose(const sim::ModelParams& rig, const std::vector<Trial>& measured,
                   const DiagnoseOptions& options, const DiagnoseProgress& progress) {
  const auto t0 = Clock::now();
  Diagnosis out;
  auto report = [&](double f, const std::string& s) {
    if (progress) progress(f, s + " [" + std::to_string(out.simulations) + " simulations]");
  };
  LibraryContext ctx;
  MeasuredData data = PrepareMeasured(rig, measured, options.holdout_fraction);
  ctx.outputs = data.outputs;
  ctx.channels = data.channels;
  const DataView& train = data.train;
  const DataView& held = data.heldout;
  out.split = data.split;
  out.notes = data.notes;
  FitOptions fo = options.fit;
  out.model = options.model;
  if (options.model != "full") {
    // A reduced model: identified once on the training part, then simulated like the full model
    // under the input- and output-side extensions (reduced_model.h).
    if (!options.reduced_fit) {
      throw std::invalid_argument("Diagnose: model '" + options.model + "' without reduced_fit");
    }
    report(0.0, "identifying the reduced model " + options.model);
    ctx.reduced_model = options.model;
    std::map<std::string, double> u_ref;
    const std::vector<Trial> reduced_train = ReducedTrainingTrials(train, data.channels, &u_ref);
    identification::FittedSimulator fitted;
    try {
      fitted = options.reduced_fit(reduced_train, nullptr);
    } catch (const std::exception& e) {
      throw std::runtime_error("--model " + options.model + ": " + e.what());
    }
    for (const auto& o : train.outputs) {
      if (std::find(fitted.outputs.begin(), fitted.outputs.end(), o) == fitted.outputs.end()) {
        throw std::runtime_error("--model " + options.model + ": does not predict " + o);
      }
    }
    out.model_yaml = fitted.model_yaml;
    for (const auto& w : fitted.warnings) out.notes.push_back(options.model + ": " + w);
    fo.simulator = ReducedSimulator(fitted, u_ref);
  }

  // 2. Baseline calibration of the subject parameters.
  report(0.0, "calibrating subject parameters");
  const std::vector<ModelParameter> subject = SubjectParameters(rig, ctx);
  const std::vector<Eigen::VectorXd> subject_starts = SubjectStarts(subject, ctx);
  const StageCache stages(options, &out.cached_results);
  const Json base_stage =
      stages.Get({"baseline", "starts=" + std::to_string(subject_starts.size())}, [&] {
        // One calibration per start and difference step, side by side (each with its simulations on
        // fit.threads threads again); the lowest Σr² is kept. A coarse step steps over the small
        // bumps of Σr² on the elbow rig, where the fine one stalls (docs/diagnosis.md, session 10);
        // the starts reach its other valleys (SubjectStarts; session 12).
        const std::vector<double>& steps = options.baseline_fd_steps;
        std::size_t kept = 0;
        const FitResult f = FitOverStarts(rig, subject, subject_starts, train, fo, steps,
                                          options.baseline_iterations, nullptr, &kept);
        out.simulations += f.simulations;
        // The training predictions at the fitted point were simulated by the fit.
        std::vector<Trial> train_pred = f.predictions;
        if (train_pred.size() != train.trials.size()) {
          train_pred = Predict(rig, subject, f.x, train, fo);
          out.simulations += static_cast<int>(train.trials.size());
        }
        const std::vector<Trial> held_pred = Predict(rig, subject, f.x, held, fo);
        out.simulations += static_cast<int>(held.trials.size());
        // The score tests and the profiled fits take the Jacobian at the fits' own step.
        const double step = steps[kept % steps.size()];
        const bool own_step = step <= 0.0 || step == fo.fd_step;
        Eigen::MatrixXd jacobian = own_step ? f.jacobian : Eigen::MatrixXd();
        const Eigen::VectorXd r = StackResiduals(train, train_pred);
        if (jacobian.rows() != r.size()) {
          jacobian = ResidualJacobian(rig, subject, f.x, r, train, fo, &out.simulations);
        }
        Json j = Json::Object();
        j.Set("fit", FitJson(f)).Set("jacobian", MatrixJson(jacobian));
        j.Set("train_predictions", TrialsToJson(train_pred));
        j.Set("heldout_predictions", TrialsToJson(held_pred));
        return j;
      });
  const FitResult base_fit = FitFromJson(Member(base_stage, "fit"));
  for (std::size_t k = 0; k < subject.size(); ++k) {
    out.subject_parameters.push_back(
        {subject[k].name, subject[k].unit, base_fit.x(k), base_fit.ci95(k)});
  }
  const std::vector<Trial> train_base = TrialsFromJson(Member(base_stage, "train_predictions"));
  const Eigen::VectorXd r0 = StackResiduals(train, train_base);
  const double rss0 = r0.squaredNorm();
  const long n = r0.size();
  const double sigma2 = rss0 / static_cast<double>(std::max<long>(1, n - base_fit.x.size()));
  out.heldout = held;
  out.heldout_baseline = TrialsFromJson(Member(base_stage, "heldout_predictions"));
  out.baseline_heldout_nrmse = ViewNrmse(held, out.heldout_baseline);
  const Eigen::MatrixXd Js = MatrixFromJson(Member(base_stage, "jacobian"));
  if (Js.rows() != n) throw std::runtime_error("diagnose: cached Jacobian has the wrong size");

  // Descriptive signatures on the first training trial.
  report(0.3, "residual signatures");
  const Trial& tr0 = train.trials[0];
  const double dt = tr0.time[1] - tr0.time[0];
  std::vector<std::vector<double>> inputs;
  const auto input_names = tr0.NamesWithPrefix("u.");
  inputs.reserve(input_names.size());
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
  const auto probe_directions = [&](const std::vector<ModelParameter>& base_params,
                                    const Eigen::VectorXd& base_x,
                                    const std::vector<Trial>& base_pred, const Eigen::VectorXd& r,
                                    const std::vector<int>& cands) {
    return ProbeDirections({rig, library, train, fo, options.map}, base_params, base_x, base_pred,
                           r, cands, &out.simulations);
  };
  // The probe directions at the baseline (step 3's), kept for the second round's screen below;
  // recomputed there when step 3 came from the cache.
  std::map<int, Eigen::MatrixXd> baseline_directions;
  // Score tests of every applicable candidate whose id is not in `skip`, on top of the model
  // (base_params, base_x): its training predictions `base_pred`, residual r, Jacobian J of all
  // its parameters and noise variance s2. Cache stage `stage`. The baseline's tests (step 3)
  // and those of the second round (on top of an accepted mechanism, step 4) are the same test.
  //
  // `screen` (second round): the baseline's probe directions. A candidate whose test with them
  // (this model's residual and Jacobian, the baseline's directions) stays insignificant at twice
  // its statistic keeps that statistic, and its probes are not simulated on top of this model;
  // the others are tested with directions simulated here. The directions change on top of the
  // accepted mechanism by their interaction only (a stiction under a tremor's dither acts as a
  // drag); what changes most is the residual (a second effect swamped by the first: seed 1007's
  // sensor_drift, χ² 15 → 401), which the screen has.
  const auto score_tests =
      [&](const std::vector<ModelParameter>& base_params, const Eigen::VectorXd& base_x,
          const std::vector<Trial>& base_pred, const Eigen::VectorXd& r, const Eigen::MatrixXd& J,
          double s2, const std::set<std::string>& skip, const std::vector<std::string>& stage,
          const std::function<const std::map<int, Eigen::MatrixXd>&()>& screen = nullptr) {
        const auto tested = [&](const Candidate& c) {
          return c.applicable && skip.count(c.id) == 0;
        };
        const Json score_stage = stages.Get(stage, [&] {
          Json all = Json::Object();
          std::vector<int> cands;
          for (std::size_t c = 0; c < library.size(); ++c) {
            if (!tested(library[c])) continue;
            if (screen && !DriftOnly(library[c])) {
              const auto it = screen().find(static_cast<int>(c));
              if (it != screen().end()) {
                const ScoreTest st = RunScoreTest(r, it->second, J, library[c].one_sided, s2);
                if (applicable * ChiSquareSurvival(2.0 * st.statistic, std::max(1, st.dof)) >=
                    options.alpha) {
                  all.Set(std::to_string(c), ScoreTestJson(st));
                  continue;
                }
              }
            }
            cands.push_back(static_cast<int>(c));
          }
          const std::map<int, Eigen::MatrixXd> directions =
              probe_directions(base_params, base_x, base_pred, r, cands);
          for (const auto& [c, D] : directions) {
            all.Set(std::to_string(c),
                    ScoreTestJson(RunScoreTest(r, D, J, library[c].one_sided, s2)));
          }
          if (!screen) baseline_directions = directions;
          return all;
        });
        std::vector<ScoreTest> tests(library.size());
        for (std::size_t c = 0; c < library.size(); ++c) {
          const Json* e = score_stage.Find(std::to_string(c));
          if (e == nullptr) continue;  // not applicable or skipped
          tests[c].statistic = Member(*e, "statistic").AsNumber();
          tests[c].dof = static_cast<int>(Member(*e, "dof").AsNumber());
          tests[c].theta = VectorFromJson(Member(*e, "theta"));
        }
        return tests;
      };
  const std::vector<ScoreTest> tests =
      score_tests(subject, base_fit.x, train_base, r0, Js, sigma2, {}, {"score_tests"});
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
  // Fitted in batches of max_fitted, best-scoring first, up to max_screened candidates in all
  // (when a further batch runs: search_on below).
  if (static_cast<int>(order.size()) > options.max_screened) order.resize(options.max_screened);

  struct Fitted {
    std::vector<int> cands;
    FitResult fit;
    bool all_free = false;  ///< every parameter fitted (not held, not profiled only).
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
  // their linearised step (within bounds) before the held-out prediction. The result is the
  // fit's cache stage {fit, held-out predictions (null when the extended model cannot simulate
  // the held-out data)}; `sims` counts the simulations it ran (none when cached).
  //
  // Fits computed in this run leave their end point's residual (and, when every parameter was
  // free, Jacobian) in `ends`, keyed by candidates and point: a later fit from that point (the
  // refit of an accepted extension from its screening fit) starts from them instead of
  // simulating them again (FitStart; the same numbers as simulating).
  std::map<std::string, FitStart> ends;
  std::mutex ends_mutex;
  const auto point_key = [&](const std::vector<int>& cands, const Eigen::VectorXd& x) {
    std::string key;
    for (int c : cands) key += std::to_string(c) + ";";
    for (Eigen::Index k = 0; k < x.size(); ++k) key += ExactNumberText(x(k)) + ",";
    return key;
  };
  const auto remember_end = [&](const std::vector<int>& cands, const FitResult& fit,
                                bool all_free) {
    if (fit.residual.size() == 0) return;
    FitStart s;
    s.residual = fit.residual;
    if (all_free) s.jacobian = fit.jacobian;
    s.predictions = fit.predictions;
    const std::lock_guard<std::mutex> lock(ends_mutex);
    ends[point_key(cands, fit.x)] = std::move(s);
  };
  const auto known_start = [&](const std::vector<int>& cands, const Eigen::VectorXd& x0,
                               int first_free) {
    FitStart s;
    const std::lock_guard<std::mutex> lock(ends_mutex);
    const auto it = ends.find(point_key(cands, x0));
    if (it == ends.end()) return s;
    s = it->second;
    if (first_free != 0) s.jacobian.resize(0, 0);  // the Jacobian of all parameters only
    return s;
  };
  // fd_step > 0: the fit's difference step instead of fo.fd_step.
  auto extension_stage = [&](const std::vector<int>& cands, const Eigen::VectorXd& x0,
                             int first_free, int iterations, const Eigen::MatrixXd* held_jacobian,
                             double rss_held, int* sims, double fd_step = 0.0) {
    std::vector<ModelParameter> params = subject;
    std::vector<std::string> stage = {"extension"};
    for (int c : cands) {
      params = Join(params, library[c].params);
      stage.push_back(std::to_string(c) + ":" + library[c].label);
    }
    std::string x0_text = "x0=";
    for (Eigen::Index k = 0; k < x0.size(); ++k) x0_text += ExactNumberText(x0(k)) + ",";
    stage.push_back(x0_text);
    stage.push_back("free_from=" + std::to_string(first_free));
    stage.push_back("iterations=" + std::to_string(iterations));
    const bool profiled = first_free > 0 && held_jacobian && held_jacobian->cols() == first_free;
    stage.push_back(profiled ? "profiled, rss_held=" + ExactNumberText(rss_held) : "held");
    FitOptions fo_step = fo;
    if (fd_step > 0.0) {
      fo_step.fd_step = fd_step;
      stage.push_back("fd_step=" + ExactNumberText(fd_step));
    }
    return stages.Get(stage, [&] {
      FitStart start = known_start(cands, x0, first_free);
      // A Jacobian known at x0 is one of fo.fd_step (remember_end keeps only those).
      if (fd_step > 0.0) start.jacobian.resize(0, 0);
      FitResult fit = FitParameters(rig, params, x0, train, fo_step, first_free, iterations,
                                    profiled ? held_jacobian : nullptr, &start);
      bool all_free = !profiled && first_free == 0;
      // Polish only a profiled fit that explains something (its training LR test against the
      // fit without it, RSS `rss_held`, passes on the profiled cost); the others keep their
      // profiled fit, which fails the LR test anyway.
      if (profiled && lr_p_adj(rss_held, fit.cost, static_cast<int>(params.size()) - first_free) <
                          options.alpha) {
        *sims += fit.simulations;
        Eigen::VectorXd x1 = fit.x;
        for (int k = 0; k < first_free; ++k) {
          x1(k) = std::clamp(x1(k) + fit.nuisance_step(k), params[k].lower, params[k].upper);
        }
        // The linearised step is poor when the held parameters must move far (a strong
        // mechanism the baseline absorbed): polish everything together from there.
        fit = FitParameters(rig, params, x1, train, fo_step, 0, options.refit_iterations);
        all_free = true;
      }
      remember_end(cands, fit, all_free && fd_step <= 0.0);
      *sims += fit.simulations + static_cast<int>(held.trials.size());
      Json j = Json::Object();
      j.Set("fit", FitJson(fit)).Set("all_free", all_free);
      try {
        j.Set("heldout_predictions", TrialsToJson(Predict(rig, params, fit.x, held, fo)));
      } catch (const std::runtime_error&) {
        // The extended model fails to simulate the held-out data (e.g. driven past a joint's
        // range): it predicts nothing there, so its held-out gain is −∞ and it is not accepted.
        j.Set("heldout_predictions", Json());
      }
      return j;
    });
  };
  auto fitted_from = [&](const std::vector<int>& cands, const Json& st) {
    Fitted f;
    f.cands = cands;
    f.fit = FitFromJson(Member(st, "fit"));
    const Json* all_free = st.Find("all_free");
    f.all_free = all_free && all_free->AsBool();
    const Json& predictions = Member(st, "heldout_predictions");
    if (predictions.IsNull()) {
      f.heldout_pred = out.heldout_baseline;
      f.heldout_nrmse = INFINITY;
    } else {
      f.heldout_pred = TrialsFromJson(predictions);
      f.heldout_nrmse = ViewNrmse(held, f.heldout_pred);
    }
    return f;
  };
  auto fit_extension = [&](const std::vector<int>& cands, const Eigen::VectorXd& x0, int first_free,
                           int iterations, const Eigen::MatrixXd* held_jacobian = nullptr,
                           double rss_held = 0.0, double fd_step = 0.0) {
    return fitted_from(cands, extension_stage(cands, x0, first_free, iterations, held_jacobian,
                                              rss_held, &out.simulations, fd_step));
  };
  const int ns = static_cast<int>(subject.size());

  // Screening: each plausible candidate alone, subject parameters held at the baseline.
  const auto screen_start = [&](int c) {
    return Concat(base_fit.x, library[c].start_from_step(tests[c].theta));
  };
  // The candidates' fits are independent: one item each, on the MPI ranks (options.map) or on
  // fit.threads threads here, each fit's simulations on fit.threads threads again (the two
  // levels keep both cores busy through the fits' serial parts: single-trial residuals, the
  // held-out prediction, the linear algebra). The stage and its simulation count return.
  const auto local_map = [&](std::size_t n_items,
                             const std::function<std::string(std::size_t)>& fn) {
    std::vector<std::string> texts(n_items);
    ParallelFor(n_items, fo.threads, [&](std::size_t k) { texts[k] = fn(k); });
    return texts;
  };
  std::vector<int> batch;
  // Profile starts (Candidate::profile_starts) from the subject starts and the calibration.
  std::vector<Eigen::VectorXd> profile_subject_starts = subject_starts;
  profile_subject_starts.push_back(base_fit.x);
  const std::function<std::string(std::size_t)> screen_item = [&](std::size_t k) {
    int sims = 0;
    const int c = batch[k];
    Json stage =
        extension_stage({c}, screen_start(c), ns, options.screen_iterations, &Js, rss0, &sims);
    if (!library[c].profile_starts.empty()) {
      const Eigen::VectorXd x =
          LowestProfileStart(rig, subject, profile_subject_starts, library[c], c, train, fo,
                             options.baseline_iterations, stages, &sims);
      if (x.size()) {
        Json alt = extension_stage({c}, x, 0, options.screen_iterations, nullptr, 0.0, &sims);
        if (FitFromJson(Member(alt, "fit")).cost < FitFromJson(Member(stage, "fit")).cost) {
          stage = std::move(alt);
        }
      }
    }
    Json j = Json::Object();
    j.Set("stage", stage);
    j.Set("simulations", sims);
    return j.Dump(0);
  };
  auto passes = [&](const CandidateResult& cr) {
    return cr.fitted && cr.collapsed.empty() && cr.lr_p_adjusted < options.alpha &&
           cr.heldout_gain > options.min_heldout_gain;
  };
  const auto structure_of = [&](const std::vector<Trial>& pred, std::vector<double>* per_output) {
    return HeldoutStructure(held, ctx.outputs, pred, per_output);
  };
  std::vector<Fitted> round1;
  int best = -1;
  // A further batch runs while nothing passes, or (batches_while_structured) while the best that
  // passes leaves structure in the held-out residual that it did not explain.
  const auto search_on = [&] {
    if (best < 0) return true;
    return options.batches_while_structured &&
           structure_of(round1[best].heldout_pred, nullptr) > options.max_structure;
  };
  for (std::size_t first = 0; first < order.size() && search_on(); first += batch.size()) {
    batch.assign(order.begin() + static_cast<std::ptrdiff_t>(first),
                 order.begin() + static_cast<std::ptrdiff_t>(std::min(
                                     order.size(), first + std::max(1, options.max_fitted))));
    // Progress over the candidates that may be fitted (monotone across batches).
    const auto progress = [&](std::size_t k) { return 0.35 + 0.4 * k / order.size(); };
    report(progress(first), "fitting " + std::to_string(batch.size()) + " extensions");
    const std::vector<std::string> texts =
        options.map ? options.map(batch.size(), screen_item) : local_map(batch.size(), screen_item);
    for (std::size_t k = 0; k < batch.size(); ++k) {
      const int c = batch[k];
      const Json j = Json::Parse(texts[k], "screening fit");
      out.simulations += static_cast<int>(Member(j, "simulations").AsNumber());
      report(progress(first + k), "fitting extension " + library[c].label);
      Fitted f = fitted_from({c}, Member(j, "stage"));
      CandidateResult& cr = out.candidates[c];
      cr.fitted = true;
      cr.lr_p_adjusted = lr_p_adj(rss0, f.fit.cost, static_cast<int>(library[c].params.size()));
      cr.heldout_nrmse = f.heldout_nrmse;
      cr.heldout_gain = (out.baseline_heldout_nrmse - f.heldout_nrmse) / out.baseline_heldout_nrmse;
      for (std::size_t p = 0; p < library[c].params.size(); ++p) {
        cr.parameters.push_back({library[c].params[p].name, library[c].params[p].unit,
                                 f.fit.x(ns + p), f.fit.ci95(ns + p)});
      }
      cr.collapsed = CollapsedParameter(library[c].params, f.fit.x, ns);
      if (!cr.collapsed.empty()) {
        cr.evidence += (cr.evidence.empty() ? "" : "; ") + cr.collapsed +
                       " fitted at its bound, where the mechanism is a subject parameter";
      }
      round1.push_back(std::move(f));
    }
    for (std::size_t k = 0; k < round1.size(); ++k) {
      const CandidateResult& cr = out.candidates[round1[k].cands[0]];
      if (passes(cr) &&
          (best < 0 || cr.heldout_gain > out.candidates[round1[best].cands[0]].heldout_gain)) {
        best = static_cast<int>(k);
      }
    }
  }
  std::vector<int> accepted;
  Fitted current;
  // Held-out NRMSE of the model a candidate was fitted on top of (second round), by library index.
  std::vector<double> on_top_reference(library.size(), NAN);
  double first_lr_p = 1.0, first_gain = 0.0;
  // Training-test p and held-out gain with which each mechanism was accepted (the first: on the
  // baseline; later ones: on top of those before them); ids dropped by the backward step.
  std::map<int, double> accept_p, accept_gain;
  std::set<std::string> dropped;
  if (best >= 0) {
    const int c1 = round1[best].cands[0];
    accepted.push_back(c1);
    out.candidates[c1].accepted = true;
    accept_p[c1] = out.candidates[c1].lr_p_adjusted;
    accept_gain[c1] = out.candidates[c1].heldout_gain;
    // Its screening fit was polished (it passed its training test there: every parameter fitted
    // together, refit_iterations LM steps). When that LM stopped on its tolerance, it is the refit
    // of the extended model: a refit would start where it stopped for want of progress (on the
    // tremor benchmark: 21 simulations, no step accepted). Else a refit goes on from it.
    if (round1[best].all_free && round1[best].fit.converged) {
      current = round1[best];
    } else {
      report(0.78, "refitting " + library[c1].label + " with the subject parameters");
      current = fit_extension({c1}, round1[best].fit.x, 0, options.refit_iterations);
    }
    // Further mechanisms on top (forward selection, diagnose.h step 4): the score tests are
    // repeated at the extended model, its parameters' Jacobian projected out, for the ids not
    // accepted yet; the best-scoring `max_fitted` (one joint per id) are fitted on top of it
    // (profiled and polished like screening; polishing is a fit of all parameters together, so
    // the accepted one is not refitted again), and the one with the largest held-out gain over
    // it that passes both tests is accepted.
    // (Taking the candidates from the baseline's ranking instead missed a second mechanism that
    // the first pushed down that ranking, or that only shows with the first in the model.)
    while (static_cast<int>(accepted.size()) < options.max_accepted) {
      std::vector<ModelParameter> cur_params = subject;
      std::vector<std::string> cur_stage = {"on_top"};
      std::set<std::string> cur_ids;
      for (int c : accepted) {
        cur_params = Join(cur_params, library[c].params);
        cur_stage.push_back(std::to_string(c) + ":" + library[c].label);
        cur_ids.insert(library[c].id);
      }
      for (const auto& id : dropped) {
        cur_ids.insert(id);
        cur_stage.push_back("dropped:" + id);
      }
      std::string x_text = "x=";
      for (Eigen::Index k = 0; k < current.fit.x.size(); ++k) {
        x_text += ExactNumberText(current.fit.x(k)) + ",";
      }
      cur_stage.push_back(x_text);
      // The extended model's training predictions and Jacobian (all its parameters) at its fit.
      std::vector<std::string> point_stage = cur_stage;
      point_stage.emplace_back("point");
      const Json point = stages.Get(point_stage, [&] {
        const FitStart known = known_start(accepted, current.fit.x, 0);
        std::vector<Trial> pred = known.predictions;
        if (pred.size() != train.trials.size()) {
          pred = Predict(rig, cur_params, current.fit.x, train, fo);
          out.simulations += static_cast<int>(train.trials.size());
        }
        const Eigen::VectorXd r = StackResiduals(train, pred);
        Eigen::MatrixXd jac = known.jacobian;
        if (jac.rows() != r.size() || jac.cols() != current.fit.x.size()) {
          jac = ResidualJacobian(rig, cur_params, current.fit.x, r, train, fo, &out.simulations);
        }
        Json j = Json::Object();
        j.Set("train_predictions", TrialsToJson(pred)).Set("jacobian", MatrixJson(jac));
        return j;
      });
      const std::vector<Trial> cur_pred = TrialsFromJson(Member(point, "train_predictions"));
      const Eigen::MatrixXd cur_jac = MatrixFromJson(Member(point, "jacobian"));
      const Eigen::VectorXd r1 = StackResiduals(train, cur_pred);
      const double rss1 = r1.squaredNorm();
      const int p1 = static_cast<int>(current.fit.x.size());
      const double s2 = rss1 / static_cast<double>(std::max<long>(1, n - p1));
      report(0.8, "score tests on top of the extended model");
      std::vector<std::string> test_stage = cur_stage;
      test_stage.emplace_back("score_tests");
      const auto screen = [&]() -> const std::map<int, Eigen::MatrixXd>& {
        if (baseline_directions.empty()) {  // step 3 came from the cache
          std::vector<int> all;
          for (std::size_t c = 0; c < library.size(); ++c) {
            if (library[c].applicable) all.push_back(static_cast<int>(c));
          }
          baseline_directions = probe_directions(subject, base_fit.x, train_base, r0, all);
        }
        return baseline_directions;
      };
      const std::vector<ScoreTest> tests2 = score_tests(cur_params, current.fit.x, cur_pred, r1,
                                                        cur_jac, s2, cur_ids, test_stage, screen);
      std::vector<int> order2;
      for (std::size_t c = 0; c < library.size(); ++c) {
        if (!library[c].applicable || cur_ids.count(library[c].id) || tests2[c].dof == 0) continue;
        CandidateResult& cr = out.candidates[c];
        cr.score_on_accepted = tests2[c].statistic;
        const double p =
            std::min(1.0, applicable * ChiSquareSurvival(tests2[c].statistic, tests2[c].dof));
        if (p < options.alpha) order2.push_back(static_cast<int>(c));
      }
      std::stable_sort(order2.begin(), order2.end(),
                       [&](int a, int b) { return tests2[a].statistic > tests2[b].statistic; });
      {
        std::vector<int> unique;
        std::set<std::string> seen;
        for (int c : order2) {
          if (seen.insert(library[c].id).second) unique.push_back(c);
        }
        order2 = unique;
      }
      if (static_cast<int>(order2.size()) > options.max_fitted) order2.resize(options.max_fitted);
      if (order2.empty()) break;
      // Start: a candidate's own fit on the baseline when it passed its training test there
      // (better than a linearised step for nonlinear parameters such as a tremor's phase),
      // else the Gauss–Newton step of its test on top of the extended model.
      const auto start_on_top = [&](int c) {
        const CandidateResult& cr = out.candidates[c];
        for (const auto& f : round1) {
          if (f.cands[0] == c && cr.lr_p_adjusted < options.alpha) {
            return Concat(current.fit.x, f.fit.x.tail(library[c].params.size()));
          }
        }
        return Concat(current.fit.x, library[c].start_from_step(tests2[c].theta));
      };
      const std::function<std::string(std::size_t)> item = [&](std::size_t k) {
        int sims = 0;
        std::vector<int> cands = accepted;
        cands.push_back(order2[k]);
        Json j = Json::Object();
        j.Set("stage", extension_stage(cands, start_on_top(order2[k]), p1,
                                       options.screen_iterations, &cur_jac, rss1, &sims));
        j.Set("simulations", sims);
        return j.Dump(0);
      };
      report(0.85, "fitting " + std::to_string(order2.size()) + " extensions on top");
      const std::vector<std::string> texts =
          options.map ? options.map(order2.size(), item) : local_map(order2.size(), item);
      int pick = -1;
      double pick_gain = 0.0;
      std::vector<Fitted> on_top;
      for (std::size_t k = 0; k < order2.size(); ++k) {
        const int c = order2[k];
        const Json j = Json::Parse(texts[k], "fit on top");
        out.simulations += static_cast<int>(Member(j, "simulations").AsNumber());
        std::vector<int> cands = accepted;
        cands.push_back(c);
        on_top.push_back(fitted_from(cands, Member(j, "stage")));
        const Fitted& f = on_top.back();
        const double g = (current.heldout_nrmse - f.heldout_nrmse) / current.heldout_nrmse;
        const double p = lr_p_adj(rss1, f.fit.cost, static_cast<int>(library[c].params.size()));
        out.candidates[c].heldout_gain_on_accepted = g;
        on_top_reference[c] = current.heldout_nrmse;
        const bool collapsed =
            !CollapsedParameter(
                 library[c].params, f.fit.x,
                 f.fit.x.size() - static_cast<Eigen::Index>(library[c].params.size()))
                 .empty();
        if (!collapsed && p < options.alpha && g > options.min_heldout_gain &&
            (pick < 0 || g > pick_gain)) {
          pick = static_cast<int>(k);
          pick_gain = g;
        }
      }
      if (pick < 0) break;
      const int c = order2[pick];
      accepted.push_back(c);
      out.candidates[c].accepted = true;
      accept_p[c] =
          lr_p_adj(rss1, on_top[pick].fit.cost, static_cast<int>(library[c].params.size()));
      accept_gain[c] = pick_gain;
      // It passed its training test, so its profiled fit was polished: all parameters fitted
      // together (refit_iterations LM steps), the refit of the extended model.
      current = on_top[pick];
      // Backward step: an earlier mechanism that no longer passes both tests on top of the others
      // (the new one explains what it stood in for, e.g. force_length_velocity taken first for a
      // delay) is dropped for good, and the search goes on.
      for (std::size_t a = 0; a + 1 < accepted.size(); ++a) {
        const int old = accepted[a];
        std::vector<int> rest;
        Eigen::VectorXd x_rest(current.fit.x.size() - library[old].params.size());
        Eigen::Index at = 0, to = 0;
        for (Eigen::Index k = 0; k < ns; ++k) x_rest(to++) = current.fit.x(at++);
        for (int c2 : accepted) {
          const auto np = static_cast<Eigen::Index>(library[c2].params.size());
          if (c2 != old) {
            rest.push_back(c2);
            x_rest.segment(to, np) = current.fit.x.segment(at, np);
            to += np;
          }
          at += np;
        }
        report(0.9, "testing " + library[old].label + " on top of the others");
        // Without it: a refit of the others with the subject parameters; for a single other
        // mechanism that is its own polished screening fit when it passed its training test there.
        Fitted without;
        bool have = false;
        if (rest.size() == 1 && out.candidates[rest[0]].lr_p_adjusted < options.alpha) {
          for (const auto& f : round1) {
            if (f.cands[0] == rest[0]) {
              without = f;
              have = true;
            }
          }
        }
        if (!have) without = fit_extension(rest, x_rest, 0, options.refit_iterations);
        const double g_old =
            (without.heldout_nrmse - current.heldout_nrmse) / without.heldout_nrmse;
        const double p_old = lr_p_adj(without.fit.cost, current.fit.cost,
                                      static_cast<int>(library[old].params.size()));
        out.candidates[old].heldout_gain_on_accepted = g_old;
        on_top_reference[old] = without.heldout_nrmse;
        // Kept when it passes, or when the others alone cannot predict the held-out data.
        if (!std::isfinite(without.heldout_nrmse) ||
            (p_old < options.alpha && g_old > options.min_heldout_gain)) {
          continue;
        }
        out.candidates[old].accepted = false;
        dropped.insert(library[old].id);
        accepted = rest;
        current = without;
        break;  // one drop per step
      }
    }
    // The cause's figures on the baseline when it was screened there and passed, as for c1.
    const CandidateResult& cause = out.candidates[accepted[0]];
    const bool screened = cause.fitted && cause.lr_p_adjusted < options.alpha;
    first_lr_p = screened ? cause.lr_p_adjusted : accept_p[accepted[0]];
    first_gain = screened ? cause.heldout_gain : accept_gain[accepted[0]];
    // The last refit (diagnose.h step 4) at the accepted mechanisms' further difference steps
    // (Candidate::refit_fd_steps), from the extended model's fit and from the lowest of the
    // scanned starts (Candidate::refit_scan_*); the lowest Σr² is kept.
    const RefitPlan plan = PlanRefit(rig, library, subject, accepted, current.fit, train, fo,
                                     stages, &out.simulations);
    if (!plan.text.empty()) report(0.92, plan.text);
    const std::vector<Eigen::VectorXd>& starts = plan.starts;
    const std::set<double>& steps = plan.steps;
    for (std::size_t s = 0; s < starts.size(); ++s) {
      for (const double h : steps) {
        report(0.93, "refitting the extended model at difference step " + ExactNumberText(h));
        Fitted f = fit_extension(accepted, starts[s], 0, options.refit_iterations, nullptr, 0.0, h);
        if (f.fit.cost < current.fit.cost) current = std::move(f);
      }
      if (s > 0) {  // a scanned start: also at the default step
        Fitted f = fit_extension(accepted, starts[s], 0, options.refit_iterations);
        if (f.fit.cost < current.fit.cost) current = std::move(f);
      }
    }
  }

  // 5. Verdict.
  report(0.95, "verdict");
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
    // An alternative competes with the cause for the share of its gain that it loses once the
    // accepted mechanisms are in the model (fitted on top of them: the NRMSE it still removes
    // there, x_ext g_on_top, explains something else); not fitted there: all of it.
    double g_alt = 0.0;
    for (std::size_t c = 0; c < out.candidates.size(); ++c) {
      const CandidateResult& cr = out.candidates[c];
      // A fit collapsed into a subject parameter is no alternative mechanism.
      if (cr.fitted && cr.id != id && std::isfinite(cr.heldout_gain) && !cr.accepted &&
          cr.collapsed.empty()) {
        double g = cr.heldout_gain;
        if (std::isfinite(cr.heldout_gain_on_accepted)) {
          g -= std::max(0.0, cr.heldout_gain_on_accepted) * on_top_reference[c] /
               out.baseline_heldout_nrmse;
        }
        g_alt = std::max(g_alt, g);
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
