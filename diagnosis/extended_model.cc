#include "diagnosis/extended_model.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "identification/fullmodel/full_model_fit.h"
#include "identification/levenberg_marquardt.h"
#include "identification/metrics.h"
#include "scenarios/parallel.h"

namespace fesim::diagnosis {

long DataView::Count() const {
  long n = 0;
  for (std::size_t t = 0; t < trials.size(); ++t) {
    for (const auto& name : outputs) {
      const auto& y = trials[t].Column(name);
      for (std::size_t i = 0; i < y.size(); ++i) n += (use[t][i] && std::isfinite(y[i])) ? 1 : 0;
    }
  }
  return n;
}

sim::ModelParams ApplyModelParameters(const sim::ModelParams& base,
                                      const std::vector<ModelParameter>& params,
                                      const Eigen::VectorXd& x) {
  if (static_cast<std::size_t>(x.size()) != params.size()) {
    throw std::invalid_argument("ApplyModelParameters: " + std::to_string(x.size()) +
                                " values for " + std::to_string(params.size()) + " parameters");
  }
  sim::ModelParams m = base;
  for (std::size_t k = 0; k < params.size(); ++k) {
    if (params[k].target == ModelParameter::Target::kModel && params[k].set) {
      params[k].set(x(static_cast<Eigen::Index>(k)), &m);
    }
  }
  return m;
}

namespace {

/// One trial's prediction for an already-applied model.
Trial PredictOne(const sim::ModelParams& model, const std::vector<ModelParameter>& params,
                 const Eigen::VectorXd& x, const Trial& trial, const FitOptions& options) {
  const Trial* input = &trial;
  Trial scaled;
  bool any_scale = false;
  for (const auto& p : params) any_scale |= p.target == ModelParameter::Target::kInputScale;
  if (any_scale) {
    scaled = trial;
    for (std::size_t k = 0; k < params.size(); ++k) {
      if (params[k].target != ModelParameter::Target::kInputScale) continue;
      if (!scaled.Has(params[k].column)) continue;
      for (double& v : scaled.MutableColumn(params[k].column)) v *= x(static_cast<Eigen::Index>(k));
    }
    input = &scaled;
  }
  Trial out;
  if (options.simulator) {
    out = options.simulator(model, *input, options.tolerance);
  } else {
    sim::IntegratorParams integrator;
    integrator.tolerance = options.tolerance;
    integrator.speed_time_scale_s = options.speed_time_scale_s;
    const double duration = input->time.empty() ? 0.0 : input->time.back();
    integrator.max_steps =
        options.max_steps_per_s > 0.0
            ? static_cast<long>(std::ceil(options.max_steps_per_s * std::max(duration, 1.0)))
            : 0;
    out = identification::fullmodel::SimulateLike(model, *input, integrator);
  }
  AddOutputDrift(params, x, &out);
  return out;
}

}  // namespace

void AddOutputDrift(const std::vector<ModelParameter>& params, const Eigen::VectorXd& x,
                    Trial* prediction) {
  for (std::size_t k = 0; k < params.size(); ++k) {
    if (params[k].target != ModelParameter::Target::kOutputDrift) continue;
    if (!prediction->Has(params[k].column)) continue;
    auto& y = prediction->MutableColumn(params[k].column);
    for (std::size_t i = 0; i < y.size(); ++i) {
      y[i] += x(static_cast<Eigen::Index>(k)) * prediction->time[i];
    }
  }
}

std::vector<Trial> Predict(const sim::ModelParams& base, const std::vector<ModelParameter>& params,
                           const Eigen::VectorXd& x, const DataView& view,
                           const FitOptions& options, int threads) {
  const sim::ModelParams model = ApplyModelParameters(base, params, x);
  std::vector<Trial> out(view.trials.size());
  ParallelFor(static_cast<int>(view.trials.size()), threads > 0 ? threads : options.threads,
              [&](int t) { out[t] = PredictOne(model, params, x, view.trials[t], options); });
  return out;
}

Eigen::VectorXd StackResiduals(const DataView& view, const std::vector<Trial>& predictions) {
  std::vector<double> r;
  for (std::size_t t = 0; t < view.trials.size(); ++t) {
    for (const auto& name : view.outputs) {
      const auto& y = view.trials[t].Column(name);
      const auto& yh = predictions[t].Column(name);
      for (std::size_t i = 0; i < y.size(); ++i) {
        if (view.use[t][i] && std::isfinite(y[i])) r.push_back(y[i] - yh[i]);
      }
    }
  }
  return Eigen::Map<Eigen::VectorXd>(r.data(), static_cast<Eigen::Index>(r.size()));
}

double ViewNrmse(const DataView& view, const std::vector<Trial>& predictions) {
  double sum = 0.0;
  for (const auto& name : view.outputs) {
    std::vector<double> y, yh;
    for (std::size_t t = 0; t < view.trials.size(); ++t) {
      const auto& a = view.trials[t].Column(name);
      const auto& b = predictions[t].Column(name);
      for (std::size_t i = 0; i < a.size(); ++i) {
        if (view.use[t][i] && std::isfinite(a[i])) {
          y.push_back(a[i]);
          yh.push_back(b[i]);
        }
      }
    }
    sum += identification::NormalisedError(y, yh);
  }
  return sum / static_cast<double>(std::max<std::size_t>(1, view.outputs.size()));
}

Eigen::MatrixXd ResidualJacobian(const sim::ModelParams& base,
                                 const std::vector<ModelParameter>& params,
                                 const Eigen::VectorXd& x, const Eigen::VectorXd& r0,
                                 const DataView& view, const FitOptions& options, int* simulations,
                                 int first_free) {
  const int p = static_cast<int>(params.size()) - first_free;
  const int nt = static_cast<int>(view.trials.size());
  std::vector<double> h(p);
  std::vector<sim::ModelParams> models;
  std::vector<Eigen::VectorXd> xs;
  std::vector<int> simulated;  // columns that need simulations (not output drifts)
  for (int c = 0; c < p; ++c) {
    const int k = first_free + c;
    double step = options.fd_step * std::max(params[k].scale, std::abs(x(k) - params[k].start));
    if (x(k) + step > params[k].upper) step = -step;
    h[c] = step;
    Eigen::VectorXd xp = x;
    xp(k) += step;
    xs.push_back(xp);
    models.push_back(ApplyModelParameters(base, params, xp));
    if (params[k].target != ModelParameter::Target::kOutputDrift) simulated.push_back(c);
  }
  std::vector<Trial> sims(static_cast<std::size_t>(p) * nt);
  std::vector<char> ok(sims.size(), 1);
  ParallelFor(simulated.size() * nt, options.threads, [&](int item) {
    const int c = simulated[item / nt], t = item % nt;
    const int task = c * nt + t;
    try {
      sims[task] = PredictOne(models[c], params, xs[c], view.trials[t], options);
    } catch (const std::exception&) {
      ok[task] = 0;
    }
  });
  if (simulations) *simulations += static_cast<int>(simulated.size()) * nt;
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(r0.size(), p);
  for (int c = 0; c < p; ++c) {
    const ModelParameter& param = params[first_free + c];
    if (param.target == ModelParameter::Target::kOutputDrift) {
      // ∂(y − ŷ)/∂drift = −t on the drift's output, 0 elsewhere (StackResiduals' order).
      Eigen::Index row = 0;
      for (int t = 0; t < nt; ++t) {
        const Trial& trial = view.trials[t];
        for (const auto& name : view.outputs) {
          const auto& y = trial.Column(name);
          for (std::size_t i = 0; i < y.size(); ++i) {
            if (!(view.use[t][i] && std::isfinite(y[i]))) continue;
            if (name == param.column) J(row, c) = -trial.time[i];
            ++row;
          }
        }
      }
      continue;
    }
    bool column_ok = true;
    for (int t = 0; t < nt; ++t) column_ok = column_ok && ok[c * nt + t];
    if (!column_ok) continue;
    const auto first = sims.begin() + static_cast<std::ptrdiff_t>(c) * nt;
    std::vector<Trial> pred(first, first + nt);
    J.col(c) = (StackResiduals(view, pred) - r0) / h[c];
  }
  return J;
}

FitResult FitParameters(const sim::ModelParams& base, const std::vector<ModelParameter>& params,
                        const Eigen::VectorXd& x0, const DataView& view, const FitOptions& options,
                        int first_free, int max_iterations, const Eigen::MatrixXd* nuisance,
                        const FitStart* start) {
  const int np = static_cast<int>(params.size());
  if (x0.size() != np || first_free < 0 || first_free >= np) {
    throw std::invalid_argument("FitParameters: x0 size or first_free out of range");
  }
  const int p = np - first_free;
  Eigen::VectorXd lower(p), upper(p);
  for (int k = 0; k < p; ++k) {
    lower(k) = params[first_free + k].lower;
    upper(k) = params[first_free + k].upper;
  }
  const auto full = [&](const Eigen::VectorXd& free) {
    Eigen::VectorXd x = x0;
    x.tail(p) = free;
    return x;
  };
  FitResult out;
  const long n = view.Count();
  // Profiled fit: an orthonormal basis Q of the nuisance columns' span; project = (I − QQᵀ).
  Eigen::MatrixXd q_basis;
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> nuisance_qr;
  if (nuisance) {
    if (nuisance->rows() != n) {
      throw std::invalid_argument("FitParameters: nuisance Jacobian has " +
                                  std::to_string(nuisance->rows()) + " rows, residuals " +
                                  std::to_string(n));
    }
    nuisance_qr.compute(*nuisance);
    const Eigen::Index rank = nuisance_qr.rank();
    q_basis = (nuisance_qr.householderQ() * Eigen::MatrixXd::Identity(n, rank)).eval();
  }
  const auto project = [&](const Eigen::MatrixXd& m) -> Eigen::MatrixXd {
    if (!nuisance) return m;
    return m - q_basis * (q_basis.transpose() * m);
  };
  constexpr double kFailedResidualRad = 10.0;  // a failed simulation: make LM reject the step
  // The raw residual (and predictions) of the best (smallest, projected when profiled, cost)
  // point evaluated: LM's end point, for nuisance_step and FitResult::residual.
  Eigen::VectorXd best_free, best_raw, last_free, last_raw;
  std::vector<Trial> best_pred;
  double best_cost = INFINITY;
  const auto remember = [&](const Eigen::VectorXd& free, const Eigen::VectorXd& r,
                            std::vector<Trial>* pred) {
    last_free = free;
    last_raw = r;
    const double cost = project(r).squaredNorm();
    if (cost < best_cost) {
      best_cost = cost;
      best_free = free;
      best_raw = r;
      best_pred = pred ? std::move(*pred) : std::vector<Trial>{};
    }
  };
  const auto raw_residual = [&](const Eigen::VectorXd& free) {
    out.simulations += static_cast<int>(view.trials.size());
    Eigen::VectorXd r;
    std::vector<Trial> pred;
    try {
      pred = Predict(base, params, full(free), view, options);
      r = StackResiduals(view, pred);
    } catch (const std::exception&) {
      r = Eigen::VectorXd::Constant(n, kFailedResidualRad);
      pred.clear();
    }
    remember(free, r, &pred);
    return r;
  };
  // identification::LevenbergMarquardt starts its damping at 1e-3 · max diag(JᵀJ) and adds it
  // times diag(JᵀJ), i.e. relative to the largest column scale; residuals are scaled here by
  // c = 1/√max diag(J₀ᵀJ₀) so that the start is the usual relative damping 1e-3 whatever the
  // units of the parameters. J₀ and r₀ are computed once and handed to LM's first calls.
  const Eigen::VectorXd x0_free = x0.tail(p);
  Eigen::VectorXd r0;
  if (start && start->residual.size() == n) {
    r0 = start->residual;
    std::vector<Trial> pred = start->predictions;
    remember(x0_free, r0, pred.size() == view.trials.size() ? &pred : nullptr);
  } else {
    r0 = raw_residual(x0_free);
  }
  const Eigen::MatrixXd j0 =
      start && start->jacobian.rows() == n && start->jacobian.cols() == p
          ? start->jacobian
          : ResidualJacobian(base, params, x0, r0, view, options, &out.simulations, first_free);
  const double max_diag = project(j0).colwise().squaredNorm().maxCoeff();
  const double c = max_diag > 0.0 ? 1.0 / std::sqrt(max_diag) : 1.0;
  bool first_residual = true, first_jacobian = true;
  const identification::ResidualFn residual = [&](const Eigen::VectorXd& free) {
    if (first_residual && free == x0_free) {
      first_residual = false;
      return (c * project(r0)).eval();
    }
    first_residual = false;
    return (c * project(raw_residual(free))).eval();
  };
  out.jacobian = j0;
  const identification::JacobianFn jacobian = [&](const Eigen::VectorXd& free,
                                                  const Eigen::VectorXd& r, int* evaluations) {
    *evaluations += p;
    if (first_jacobian && free == x0_free) {
      first_jacobian = false;
      return (c * project(j0)).eval();
    }
    first_jacobian = false;
    // The finite differences need the raw residual at `free` (LM's r is scaled, and projected
    // when profiled): the one simulated there (LM asks at the point it just evaluated).
    const Eigen::VectorXd raw =
        last_free.size() == p && last_free == free
            ? last_raw
            : (best_free.size() == p && best_free == free ? best_raw : raw_residual(free));
    out.jacobian = ResidualJacobian(base, params, full(free), raw, view, options, &out.simulations,
                                    first_free);
    return (c * project(out.jacobian)).eval();
  };
  identification::LmOptions lm;
  lm.max_iterations = max_iterations > 0 ? max_iterations : options.max_iterations;
  lm.relative_tolerance = options.relative_tolerance;
  lm.step_tolerance = 1e-9;
  identification::LmResult res =
      identification::LevenbergMarquardt(residual, x0_free, lower, upper, lm, {}, jacobian);
  res.cost /= c * c;
  res.jtj /= c * c;
  out.x = full(res.x);
  out.cost = res.cost;
  out.converged = res.converged;
  out.residuals = n;
  out.ci95 = Eigen::VectorXd::Constant(np, NAN);
  out.ci95.tail(p) = identification::ConfidenceHalfWidths95(res.jtj, res.cost, n);
  if (nuisance) {
    if (!(best_free.size() == p && best_free == res.x)) {
      raw_residual(res.x);
      best_free = res.x;
      best_raw = last_raw;
      best_pred.clear();
    }
    out.nuisance_step = -nuisance_qr.solve(best_raw);
  }
  if (best_free.size() == p && best_free == res.x) {
    out.residual = best_raw;
    out.predictions = std::move(best_pred);
  }
  return out;
}

double ParabolaVertex(double f0, double c0, double f1, double c1, double f2, double c2) {
  const double a = (f1 - f0) * (c1 - c2), b = (f1 - f2) * (c1 - c0);
  return f1 - 0.5 * ((f1 - f0) * a - (f1 - f2) * b) / (a - b);
}

FitResult FitOverStarts(const sim::ModelParams& base, const std::vector<ModelParameter>& params,
                        const std::vector<Eigen::VectorXd>& starts, const DataView& view,
                        const FitOptions& options, const std::vector<double>& fd_steps,
                        int max_iterations, std::vector<double>* costs, std::size_t* kept) {
  if (fd_steps.empty() || std::any_of(fd_steps.begin(), fd_steps.end(),
                                      [](double h) { return !(h >= 0.0 && h < 1.0); })) {
    throw std::invalid_argument("FitOverStarts: fd_steps must be non-empty, each in [0, 1)");
  }
  if (starts.empty()) throw std::invalid_argument("FitOverStarts: no start");
  const std::size_t n_steps = fd_steps.size();
  std::vector<FitResult> fits(starts.size() * n_steps);
  ParallelFor(fits.size(), options.threads, [&](std::size_t k) {
    FitOptions o = options;
    if (fd_steps[k % n_steps] > 0.0) o.fd_step = fd_steps[k % n_steps];
    fits[k] = FitParameters(base, params, starts[k / n_steps], view, o, 0, max_iterations);
  });
  std::size_t best = 0;
  int simulations = 0;
  if (costs) costs->clear();
  for (std::size_t k = 0; k < fits.size(); ++k) {
    simulations += fits[k].simulations;
    if (costs) costs->push_back(fits[k].cost);
    if (fits[k].cost < fits[best].cost) best = k;
  }
  if (kept) *kept = best;
  FitResult out = std::move(fits[best]);
  out.simulations = simulations;
  return out;
}

FitResult FitOverDifferenceSteps(const sim::ModelParams& base,
                                 const std::vector<ModelParameter>& params,
                                 const Eigen::VectorXd& x0, const DataView& view,
                                 const FitOptions& options, const std::vector<double>& fd_steps,
                                 int max_iterations, std::vector<double>* costs,
                                 std::size_t* kept) {
  return FitOverStarts(base, params, {x0}, view, options, fd_steps, max_iterations, costs, kept);
}

std::string CollapsedParameter(const std::vector<ModelParameter>& params, const Eigen::VectorXd& x,
                               Eigen::Index offset) {
  if (offset < 0 || offset + static_cast<Eigen::Index>(params.size()) > x.size()) {
    throw std::invalid_argument("CollapsedParameter: offset out of range");
  }
  for (std::size_t k = 0; k < params.size(); ++k) {
    const ModelParameter& p = params[k];
    if (std::isfinite(p.collapses_at) && std::abs(x(offset + static_cast<Eigen::Index>(k)) -
                                                  p.collapses_at) <= 1e-3 * (p.upper - p.lower)) {
      return p.name;
    }
  }
  return "";
}

}  // namespace fesim::diagnosis
