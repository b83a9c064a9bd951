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

#include "base/parallel.h"
#include "identification/fullmodel/full_model_fit.h"
#include "identification/levenberg_marquardt.h"
#include "identification/metrics.h"

namespace fesim::diagnosis {

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
                                      const Eigen::VectorXd& x, int trial) {
  if (static_cast<std::size_t>(x.size()) != params.size()) {
    throw std::invalid_argument("ApplyModelParameters: " + std::to_string(x.size()) +
                                " values for " + std::to_string(params.size()) + " parameters");
  }
  sim::ModelParams m = base;
  for (std::size_t k = 0; k < params.size(); ++k) {
    if (params[k].target == ModelParameter::Target::kModel && params[k].set &&
        (trial < 0 || AppliesToTrial(params[k], trial))) {
      params[k].set(x(static_cast<Eigen::Index>(k)), &m);
    }
  }
  return m;
}

bool AppliesToTrial(const ModelParameter& param, int trial) {
  return param.trial < 0 || param.trial == trial;
}

namespace {

/// The trial's inputs with the kInputScale parameters (values x) applied.
Trial ScaledInputs(const std::vector<ModelParameter>& params, const Eigen::VectorXd& x,
                   const Trial& trial) {
  Trial scaled = trial;
  for (std::size_t k = 0; k < params.size(); ++k) {
    if (params[k].target != ModelParameter::Target::kInputScale) continue;
    if (!scaled.Has(params[k].column)) continue;
    for (double& v : scaled.MutableColumn(params[k].column)) v *= x(static_cast<Eigen::Index>(k));
  }
  return scaled;
}

bool AnyInputScale(const std::vector<ModelParameter>& params) {
  return std::any_of(params.begin(), params.end(), [](const ModelParameter& p) {
    return p.target == ModelParameter::Target::kInputScale;
  });
}

sim::IntegratorParams Integrator(const FitOptions& options, const Trial& trial, double factor) {
  sim::IntegratorParams integrator;
  integrator.tolerance = std::min(1e-2, options.tolerance * factor);
  integrator.speed_time_scale_s = options.speed_time_scale_s;
  integrator.simbody_right_hand_side = options.simbody_right_hand_side;
  const double duration = trial.time.empty() ? 0.0 : trial.time.back();
  integrator.max_steps =
      options.max_steps_per_s > 0.0
          ? static_cast<long>(std::ceil(options.max_steps_per_s * std::max(duration, 1.0)))
          : 0;
  return integrator;
}

/// One trial's prediction for an already-applied model (its initial posture set).
Trial PredictOne(const sim::ModelParams& model, const std::vector<ModelParameter>& params,
                 const Eigen::VectorXd& x, const Trial& trial, int trial_index,
                 const FitOptions& options) {
  const bool scale = AnyInputScale(params);
  const Trial scaled = scale ? ScaledInputs(params, x, trial) : Trial();
  const Trial& input = scale ? scaled : trial;
  Trial out = options.simulator ? options.simulator(model, input, options.tolerance)
                                : identification::fullmodel::SimulateLike(
                                      model, input, Integrator(options, input, 1.0));
  AddOutputDrift(params, x, &out, trial_index);
  return out;
}

}  // namespace

void AddOutputDrift(const std::vector<ModelParameter>& params, const Eigen::VectorXd& x,
                    Trial* prediction, int trial) {
  for (std::size_t k = 0; k < params.size(); ++k) {
    if (params[k].target != ModelParameter::Target::kOutputDrift) continue;
    if (trial >= 0 && !AppliesToTrial(params[k], trial)) continue;
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
  const bool per_trial = std::any_of(params.begin(), params.end(),
                                     [](const ModelParameter& p) { return p.trial >= 0; });
  const sim::ModelParams shared = per_trial ? base : ApplyModelParameters(base, params, x);
  std::vector<Trial> out(view.trials.size());
  ParallelFor(static_cast<int>(view.trials.size()), threads > 0 ? threads : options.threads,
              [&](int t) {
                const sim::ModelParams model =
                    per_trial ? ApplyModelParameters(base, params, x, t) : shared;
                out[t] = PredictOne(WithInitialPosture(model, view, static_cast<std::size_t>(t)),
                                    params, x, view.trials[t], t, options);
              });
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

std::vector<ResidualSeries> UnstackResiduals(const DataView& view, const Eigen::VectorXd& r) {
  std::vector<ResidualSeries> out;
  Eigen::Index row = 0;
  for (std::size_t t = 0; t < view.trials.size(); ++t) {
    for (const auto& name : view.outputs) {
      ResidualSeries s;
      s.trial = static_cast<int>(t);
      s.output = name;
      const auto& y = view.trials[t].Column(name);
      for (std::size_t i = 0; i < y.size(); ++i) {
        if (!view.use[t][i] || !std::isfinite(y[i])) continue;
        if (row >= r.size()) throw std::invalid_argument("UnstackResiduals: residual too short");
        s.time_s.push_back(view.trials[t].time[i]);
        s.r.push_back(r(row++));
      }
      out.push_back(std::move(s));
    }
  }
  if (row != r.size()) throw std::invalid_argument("UnstackResiduals: residual too long");
  return out;
}

sim::ModelParams WithInitialPosture(const sim::ModelParams& base, const DataView& view,
                                    std::size_t t) {
  sim::ModelParams m = base;
  if (t >= view.initial_q.size()) return m;
  for (std::size_t o = 0; o < view.outputs.size() && o < view.initial_q[t].size(); ++o) {
    const int c = sim::CoordinateIndex(view.outputs[o].substr(2));
    if (c >= 0 && std::isfinite(view.initial_q[t][o]))
      m.coordinates[c].initial_rad = view.initial_q[t][o];
  }
  return m;
}

std::vector<double> ViewNrmsePerOutput(const DataView& view,
                                       const std::vector<Trial>& predictions) {
  std::vector<double> out;
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
    out.push_back(identification::NormalisedError(y, yh));
  }
  return out;
}

double ViewNrmse(const DataView& view, const std::vector<Trial>& predictions) {
  const std::vector<double> per = ViewNrmsePerOutput(view, predictions);
  double sum = 0.0;
  for (double v : per) sum += v;
  return sum / static_cast<double>(std::max<std::size_t>(1, per.size()));
}

namespace {

/// Rows of the stacked residual (StackResiduals' order) of the counted samples of trial t:
/// calls fn(row, output index, sample index) for each.
template <typename Fn>
void ForEachRow(const DataView& view, Fn fn) {
  Eigen::Index row = 0;
  for (std::size_t t = 0; t < view.trials.size(); ++t) {
    for (std::size_t o = 0; o < view.outputs.size(); ++o) {
      const auto& y = view.trials[t].Column(view.outputs[o]);
      for (std::size_t i = 0; i < y.size(); ++i) {
        if (view.use[t][i] && std::isfinite(y[i])) fn(row++, t, o, i);
      }
    }
  }
}

/// The Jacobian columns `cols` (indices into the free columns c, parameter first_free + c) of
/// trial t by forward sensitivities: −∂ŷ/∂θ on the trial's rows. Throws when the model cannot be
/// differentiated (the stretch reflex's states) or the integration fails.
std::vector<Eigen::MatrixXd> SensitivityColumns(const sim::ModelParams& base,
                                                const std::vector<ModelParameter>& params,
                                                const Eigen::VectorXd& x, const DataView& view,
                                                std::size_t t, const std::vector<int>& cols,
                                                int first_free, const FitOptions& options) {
  const int index = static_cast<int>(t);
  const sim::ModelParams model =
      WithInitialPosture(ApplyModelParameters(base, params, x, index), view, t);
  std::vector<sim::ParameterPerturbation> perturbed;
  perturbed.reserve(cols.size());
  for (int c : cols) {
    const int k = first_free + c;
    const double scale = std::max(params[k].scale, std::abs(x(k)));
    double step = 1e-6 * scale;
    if (x(k) + step > params[k].upper) step = -step;
    Eigen::VectorXd xp = x;
    xp(k) += step;
    perturbed.push_back(
        {WithInitialPosture(ApplyModelParameters(base, params, xp, index), view, t), step, scale});
  }
  const Trial& trial = view.trials[t];
  const bool scale = AnyInputScale(params);
  const Trial input = scale ? ScaledInputs(params, x, trial) : trial;
  const identification::fullmodel::SimulationSensitivities sens =
      identification::fullmodel::SimulateLikeSensitivities(
          model, input, perturbed, Integrator(options, input, options.jacobian_tolerance_factor));
  std::vector<Eigen::MatrixXd> out;
  const auto simulated = input.NamesWithPrefix("q.");
  for (const auto& name : view.outputs) {
    const auto at = std::find(simulated.begin(), simulated.end(), name) - simulated.begin();
    out.push_back(-sens.dq_dtheta[static_cast<std::size_t>(at)]);
  }
  return out;
}

}  // namespace

Eigen::MatrixXd ResidualJacobian(const sim::ModelParams& base,
                                 const std::vector<ModelParameter>& params,
                                 const Eigen::VectorXd& x, const Eigen::VectorXd& r0,
                                 const DataView& view, const FitOptions& options, int* simulations,
                                 int first_free) {
  const int p = static_cast<int>(params.size()) - first_free;
  const int nt = static_cast<int>(view.trials.size());
  std::vector<double> h(p);
  std::vector<Eigen::VectorXd> xs(p);
  std::vector<int> differenced, sensed;  // columns by forward differences / sensitivities
  const bool can_sense = options.sensitivities && !options.simulator;
  for (int c = 0; c < p; ++c) {
    const ModelParameter& par = params[first_free + c];
    if (par.target == ModelParameter::Target::kOutputDrift) continue;  // exact below
    if (can_sense && par.target == ModelParameter::Target::kModel && par.sensitivity) {
      sensed.push_back(c);
      continue;
    }
    differenced.push_back(c);
  }
  const auto prepare_difference = [&](int c) {
    const int k = first_free + c;
    double step = options.fd_step * std::max(params[k].scale, std::abs(x(k) - params[k].start));
    if (x(k) + step > params[k].upper) step = -step;
    h[c] = step;
    xs[c] = x;
    xs[c](k) += step;
  };
  // A column of a parameter of one trial (ModelParameter::trial) is 0 on the other trials' rows.
  const auto moves = [&](int c, int t) { return AppliesToTrial(params[first_free + c], t); };
  for (int c : differenced) prepare_difference(c);
  // Jobs: one sensitivity integration per trial (all sensed columns), then one perturbed
  // simulation per differenced column and trial; a failed sensitivity job falls back to
  // differences of its columns.
  std::vector<std::vector<Eigen::MatrixXd>> sens(sensed.empty() ? 0 : nt);
  std::vector<char> sens_ok(sens.size(), 1);
  std::vector<Trial> sims(static_cast<std::size_t>(p) * nt);
  std::vector<char> ok(sims.size(), 1);
  const auto difference = [&](int c, int t) {
    if (!moves(c, t)) return;
    const int task = c * nt + t;
    try {
      sims[task] = PredictOne(WithInitialPosture(ApplyModelParameters(base, params, xs[c], t), view,
                                                 static_cast<std::size_t>(t)),
                              params, xs[c], view.trials[t], t, options);
    } catch (const std::exception&) {
      ok[task] = 0;
    }
  };
  const auto simulated_tasks = [&](const std::vector<int>& cols) {
    int n = 0;
    for (int c : cols) {
      for (int t = 0; t < nt; ++t) n += moves(c, t) ? 1 : 0;
    }
    return n;
  };
  const int n_sens = static_cast<int>(sens.size());
  const auto any_sensed_moves = [&](int t) {
    return std::any_of(sensed.begin(), sensed.end(), [&](int c) { return moves(c, t); });
  };
  ParallelFor(n_sens + static_cast<int>(differenced.size()) * nt, options.threads, [&](int item) {
    if (item < n_sens) {
      if (!any_sensed_moves(item)) return;
      try {
        sens[item] = SensitivityColumns(base, params, x, view, static_cast<std::size_t>(item),
                                        sensed, first_free, options);
      } catch (const std::exception&) {
        sens_ok[item] = 0;
      }
      return;
    }
    item -= n_sens;
    difference(differenced[item / nt], item % nt);
  });
  int n_sims = simulated_tasks(differenced);
  for (int t = 0; t < n_sens; ++t) n_sims += any_sensed_moves(t) ? 1 : 0;
  if (std::any_of(sens_ok.begin(), sens_ok.end(), [](char v) { return v == 0; })) {
    for (int c : sensed) prepare_difference(c);
    ParallelFor(static_cast<int>(sensed.size()) * nt, options.threads,
                [&](int item) { difference(sensed[item / nt], item % nt); });
    n_sims += simulated_tasks(sensed);
    differenced.insert(differenced.end(), sensed.begin(), sensed.end());
    sensed.clear();
  }
  if (simulations) *simulations += n_sims;
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(r0.size(), p);
  if (!sensed.empty()) {
    ForEachRow(view, [&](Eigen::Index row, std::size_t t, std::size_t o, std::size_t i) {
      for (std::size_t s = 0; s < sensed.size(); ++s) {
        if (!moves(sensed[s], static_cast<int>(t))) continue;
        J(row, sensed[s]) = sens[t][o](static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(s));
      }
    });
  }
  for (int c = 0; c < p; ++c) {
    const ModelParameter& param = params[first_free + c];
    if (param.target != ModelParameter::Target::kOutputDrift) continue;
    // ∂(y − ŷ)/∂drift = −t on the drift's output (and trial), 0 elsewhere.
    ForEachRow(view, [&](Eigen::Index row, std::size_t t, std::size_t o, std::size_t i) {
      if (view.outputs[o] == param.column && moves(c, static_cast<int>(t)))
        J(row, c) = -view.trials[t].time[i];
    });
  }
  for (int c : differenced) {
    bool column_ok = true;
    for (int t = 0; t < nt; ++t) column_ok = column_ok && ok[c * nt + t];
    if (!column_ok) continue;
    ForEachRow(view, [&](Eigen::Index row, std::size_t t, std::size_t o, std::size_t i) {
      if (!moves(c, static_cast<int>(t))) return;
      const double y = view.trials[t].Column(view.outputs[o])[i];
      const double y_perturbed = sims[c * nt + t].Column(view.outputs[o])[i];
      J(row, c) = (y - y_perturbed - r0(row)) / h[c];
    });
  }
  return J;
}

namespace {

/// A profiled fit's projection (I − QQᵀ) onto the complement of the nuisance columns' span
/// (Q an orthonormal basis of it); the identity without nuisance columns.
struct NuisanceProjection {
  NuisanceProjection(const Eigen::MatrixXd* nuisance, long n) : active(nuisance != nullptr) {
    if (!nuisance) return;
    if (nuisance->rows() != n) {
      throw std::invalid_argument("FitParameters: nuisance Jacobian has " +
                                  std::to_string(nuisance->rows()) + " rows, residuals " +
                                  std::to_string(n));
    }
    qr.compute(*nuisance);
    q_basis = (qr.householderQ() * Eigen::MatrixXd::Identity(n, qr.rank())).eval();
  }
  Eigen::MatrixXd Apply(const Eigen::MatrixXd& m) const {
    if (!active) return m;
    return m - q_basis * (q_basis.transpose() * m);
  }
  bool active;
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr;
  Eigen::MatrixXd q_basis;
};

/// The prior rows σ_p (x_k − start_k) / width_k (log-normal: σ_p ln(x_k / start_k) / width_k) of
/// the free parameters with a finite prior width, appended to a residual and its Jacobian
/// (docs/diagnosis.md, "The person" step 1).
class PriorRows {
 public:
  PriorRows(const std::vector<ModelParameter>& params, int first_free, double prior_sigma)
      : params_(params), first_free_(first_free), sigma_(prior_sigma) {
    if (prior_sigma <= 0.0) return;
    for (int k = 0; k + first_free < static_cast<int>(params.size()); ++k) {
      if (std::isfinite(params[first_free + k].prior_width)) of_.push_back(k);
    }
  }
  Eigen::VectorXd Rows(const Eigen::VectorXd& free) const {
    Eigen::VectorXd rows(static_cast<Eigen::Index>(of_.size()));
    for (std::size_t m = 0; m < of_.size(); ++m) {
      const ModelParameter& par = params_[first_free_ + of_[m]];
      const double x = free(of_[m]);
      const double d = par.log_prior ? std::log(x / par.start) : x - par.start;
      rows(static_cast<Eigen::Index>(m)) = sigma_ * d / par.prior_width;
    }
    return rows;
  }
  Eigen::VectorXd Append(const Eigen::VectorXd& r_data, const Eigen::VectorXd& free) const {
    if (of_.empty()) return r_data;
    Eigen::VectorXd r(r_data.size() + static_cast<Eigen::Index>(of_.size()));
    r << r_data, Rows(free);
    return r;
  }
  Eigen::MatrixXd AppendJacobian(const Eigen::MatrixXd& j_data, const Eigen::VectorXd& free) const {
    if (of_.empty()) return j_data;
    Eigen::MatrixXd j =
        Eigen::MatrixXd::Zero(j_data.rows() + static_cast<Eigen::Index>(of_.size()), j_data.cols());
    j.topRows(j_data.rows()) = j_data;
    for (std::size_t m = 0; m < of_.size(); ++m) {
      const ModelParameter& par = params_[first_free_ + of_[m]];
      const double dd = par.log_prior ? 1.0 / free(of_[m]) : 1.0;
      j(j_data.rows() + static_cast<Eigen::Index>(m), of_[m]) = sigma_ * dd / par.prior_width;
    }
    return j;
  }

 private:
  const std::vector<ModelParameter>& params_;
  int first_free_;
  double sigma_;
  std::vector<int> of_;  ///< free column of each prior row
};

/// The coordinates LM fits in: z = ln x for the free parameters with a log-normal prior (scale
/// factors, lower > 0), x itself for the others. A scale factor's effect is multiplicative
/// (recruitment shape γ over decades, a strength, a damping), so equal steps in ln x are equal
/// relative changes; in x, LM's trust region at a factor's lower bound is far too large and at
/// its upper bound far too small.
class LogCoordinates {
 public:
  LogCoordinates(const std::vector<ModelParameter>& params, int first_free) {
    for (std::size_t k = first_free; k < params.size(); ++k) {
      log_.push_back(params[k].log_prior && params[k].lower > 0.0);
    }
  }
  Eigen::VectorXd ToLm(Eigen::VectorXd x) const {
    for (std::size_t k = 0; k < log_.size(); ++k) {
      if (log_[k]) x(static_cast<Eigen::Index>(k)) = std::log(x(static_cast<Eigen::Index>(k)));
    }
    return x;
  }
  Eigen::VectorXd ToX(Eigen::VectorXd z) const {
    for (std::size_t k = 0; k < log_.size(); ++k) {
      if (log_[k]) z(static_cast<Eigen::Index>(k)) = std::exp(z(static_cast<Eigen::Index>(k)));
    }
    return z;
  }
  /// ∂r/∂z from ∂r/∂x at x: the log columns × x.
  Eigen::MatrixXd ChainRule(Eigen::MatrixXd j, const Eigen::VectorXd& x) const {
    for (std::size_t k = 0; k < log_.size(); ++k) {
      const auto kk = static_cast<Eigen::Index>(k);
      if (log_[k]) j.col(kk) *= x(kk);
    }
    return j;
  }
  /// 95 % half-widths in x from those in z at x (delta method: x · h_z).
  Eigen::VectorXd HalfWidthsToX(Eigen::VectorXd h, const Eigen::VectorXd& x) const {
    for (std::size_t k = 0; k < log_.size(); ++k) {
      const auto kk = static_cast<Eigen::Index>(k);
      if (log_[k]) h(kk) *= x(kk);
    }
    return h;
  }

 private:
  std::vector<bool> log_;
};

/// FitParameters' LM settings: `max_iterations` when > 0, else the options'.
identification::LmOptions LmOptionsOf(const FitOptions& options, int max_iterations) {
  identification::LmOptions lm;
  lm.max_iterations = max_iterations > 0 ? max_iterations : options.max_iterations;
  lm.relative_tolerance = options.relative_tolerance;
  lm.step_tolerance = 1e-9;
  lm.stop_needs_predicted_decrease = options.stop_needs_predicted_decrease;
  lm.hold_active_bounds = options.hold_active_bounds;
  return lm;
}

/// The lower (or upper) bounds of the parameters from `first_free` on.
Eigen::VectorXd FreeBounds(const std::vector<ModelParameter>& params, int first_free, bool upper) {
  Eigen::VectorXd b(static_cast<Eigen::Index>(params.size()) - first_free);
  for (Eigen::Index k = 0; k < b.size(); ++k) {
    const ModelParameter& p = params[first_free + k];
    b(k) = upper ? p.upper : p.lower;
  }
  return b;
}

}  // namespace

FitResult FitParameters(const sim::ModelParams& base, const std::vector<ModelParameter>& params,
                        const Eigen::VectorXd& x0, const DataView& view, const FitOptions& options,
                        int first_free, int max_iterations, const Eigen::MatrixXd* nuisance,
                        const FitStart* start) {
  const int np = static_cast<int>(params.size());
  if (x0.size() != np || first_free < 0 || first_free >= np) {
    throw std::invalid_argument("FitParameters: x0 size or first_free out of range");
  }
  const int p = np - first_free;
  const LogCoordinates coords(params, first_free);
  const Eigen::VectorXd lower = coords.ToLm(FreeBounds(params, first_free, false));
  const Eigen::VectorXd upper = coords.ToLm(FreeBounds(params, first_free, true));
  const auto full = [&](const Eigen::VectorXd& free) {
    Eigen::VectorXd x = x0;
    x.tail(p) = free;
    return x;
  };
  FitResult out;
  const long n = view.Count();
  const NuisanceProjection nuisance_projection(nuisance, n);
  const auto project = [&](const Eigen::MatrixXd& m) { return nuisance_projection.Apply(m); };
  const PriorRows prior(params, first_free, options.prior_sigma);
  const auto prior_rows = [&](const Eigen::VectorXd& free) { return prior.Rows(free); };
  const auto with_prior = [&](const Eigen::VectorXd& r_data, const Eigen::VectorXd& free) {
    return prior.Append(r_data, free);
  };
  const auto with_prior_jacobian = [&](const Eigen::MatrixXd& j_data, const Eigen::VectorXd& free) {
    return prior.AppendJacobian(j_data, free);
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
    const double cost = project(r).squaredNorm() + prior_rows(free).squaredNorm();
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
  // LM works in `coords` (z = ln x for the log-prior parameters): the Jacobian ∂r/∂z is ∂r/∂x
  // times x on those columns, the prior rows' included (their ∂/∂z is then σ_p / width).
  const auto lm_jacobian = [&](const Eigen::MatrixXd& j_x, const Eigen::VectorXd& free) {
    return coords.ChainRule(with_prior_jacobian(project(j_x), free), free);
  };
  const Eigen::VectorXd z0 = coords.ToLm(x0_free);
  const double max_diag = lm_jacobian(j0, x0_free).colwise().squaredNorm().maxCoeff();
  const double c = max_diag > 0.0 ? 1.0 / std::sqrt(max_diag) : 1.0;
  bool first_residual = true, first_jacobian = true;
  const identification::ResidualFn residual = [&](const Eigen::VectorXd& z) {
    if (first_residual && z == z0) {
      first_residual = false;
      return (c * with_prior(project(r0), x0_free)).eval();
    }
    first_residual = false;
    const Eigen::VectorXd free = coords.ToX(z);
    return (c * with_prior(project(raw_residual(free)), free)).eval();
  };
  out.jacobian = j0;
  out.jacobian_x = x0;
  const identification::JacobianFn jacobian = [&](const Eigen::VectorXd& z,
                                                  const Eigen::VectorXd& r, int* evaluations) {
    *evaluations += p;
    if (first_jacobian && z == z0) {
      first_jacobian = false;
      return (c * lm_jacobian(j0, x0_free)).eval();
    }
    first_jacobian = false;
    const Eigen::VectorXd free = coords.ToX(z);
    // The finite differences need the raw residual at `free` (LM's r is scaled, and projected
    // when profiled): the one simulated there (LM asks at the point it just evaluated).
    const Eigen::VectorXd raw =
        last_free.size() == p && last_free == free
            ? last_raw
            : (best_free.size() == p && best_free == free ? best_raw : raw_residual(free));
    out.jacobian = ResidualJacobian(base, params, full(free), raw, view, options, &out.simulations,
                                    first_free);
    out.jacobian_x = full(free);
    return (c * lm_jacobian(out.jacobian, free)).eval();
  };
  identification::LmResult res = identification::LevenbergMarquardt(
      residual, z0, lower, upper, LmOptionsOf(options, max_iterations), {}, jacobian);
  res.cost /= c * c;
  res.jtj /= c * c;
  res.x = coords.ToX(res.x);
  out.x = full(res.x);
  out.map_cost = res.cost;
  out.cost = res.cost - prior_rows(res.x).squaredNorm();
  out.converged = res.converged;
  out.residuals = n;
  out.ci95 = Eigen::VectorXd::Constant(np, NAN);
  out.ci95.tail(p) =
      coords.HalfWidthsToX(identification::ConfidenceHalfWidths95(res.jtj, out.cost, n), res.x);
  if (nuisance) {
    if (!(best_free.size() == p && best_free == res.x)) {
      raw_residual(res.x);
      best_free = res.x;
      best_raw = last_raw;
      best_pred.clear();
    }
    out.nuisance_step = -nuisance_projection.qr.solve(best_raw);
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
                        const FitOptions& options, int max_iterations, std::vector<double>* costs,
                        std::size_t* kept) {
  if (starts.empty()) throw std::invalid_argument("FitOverStarts: no start");
  std::vector<FitResult> fits(starts.size());
  std::vector<char> ok(starts.size(), 0);
  ParallelFor(fits.size(), options.threads, [&](std::size_t k) {
    try {
      fits[k] = FitParameters(base, params, starts[k], view, options, 0, max_iterations);
      ok[k] = 1;
    } catch (const std::runtime_error&) {
      // this start cannot be simulated
    }
  });
  int best = -1, simulations = 0;
  if (costs) costs->clear();
  for (std::size_t k = 0; k < fits.size(); ++k) {
    simulations += fits[k].simulations;
    if (costs) costs->push_back(ok[k] ? fits[k].map_cost : INFINITY);
    if (ok[k] && (best < 0 || fits[k].map_cost < fits[best].map_cost)) best = static_cast<int>(k);
  }
  if (best < 0) throw std::runtime_error("no start of the fit can be simulated");
  if (kept) *kept = static_cast<std::size_t>(best);
  FitResult out = std::move(fits[best]);
  out.simulations = simulations;
  return out;
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

int RangeBoundSide(const ModelParameter& p, double v) {
  const bool log = p.log_prior && p.lower > 0.0 && v > 0.0;
  const double lo = log ? std::log(p.lower) : p.lower, hi = log ? std::log(p.upper) : p.upper;
  const double at = log ? std::log(v) : v, tol = 1e-3 * (hi - lo);
  return at - lo <= tol ? -1 : hi - at <= tol ? 1 : 0;
}

std::string ParameterAtRangeBound(const std::vector<ModelParameter>& params,
                                  const Eigen::VectorXd& x, Eigen::Index offset) {
  if (offset < 0 || offset + static_cast<Eigen::Index>(params.size()) > x.size()) {
    throw std::invalid_argument("ParameterAtRangeBound: offset out of range");
  }
  for (std::size_t k = 0; k < params.size(); ++k) {
    const ModelParameter& p = params[k];
    if (!p.range_is_plausible) continue;
    const int side = RangeBoundSide(p, x(offset + static_cast<Eigen::Index>(k)));
    if (side != 0 && side != RangeBoundSide(p, p.start)) return p.name;
  }
  return "";
}

std::string JointParametersAtBound(const std::vector<ModelParameter>& params,
                                   const Eigen::VectorXd& x, const std::string& joint) {
  if (x.size() < static_cast<Eigen::Index>(params.size())) {
    throw std::invalid_argument("JointParametersAtBound: fewer values than parameters");
  }
  std::string names;
  if (joint.empty()) return names;
  for (std::size_t k = 0; k < params.size(); ++k) {
    const ModelParameter& p = params[k];
    if (p.joint != joint) continue;
    if (RangeBoundSide(p, x(static_cast<Eigen::Index>(k))) != 0) {
      names += (names.empty() ? "" : ", ") + p.name;
    }
  }
  return names;
}

std::string WithinNormalVariation(const std::vector<ModelParameter>& params,
                                  const Eigen::VectorXd& x, Eigen::Index offset,
                                  const Eigen::VectorXd& ci95) {
  if (offset < 0 || offset + static_cast<Eigen::Index>(params.size()) > x.size() ||
      (ci95.size() > 0 && ci95.size() != x.size())) {
    throw std::invalid_argument("WithinNormalVariation: offset out of range or ci95 size differs");
  }
  std::string first;
  for (std::size_t k = 0; k < params.size(); ++k) {
    const ModelParameter& p = params[k];
    const double v = x(offset + static_cast<Eigen::Index>(k));
    if (!std::isfinite(p.normal_half_width)) {
      double w = ci95.size() ? ci95(offset + static_cast<Eigen::Index>(k)) : INFINITY;
      if (std::isnan(w)) w = 0.0;  // no interval (e.g. at a bound): only its start itself
      if (!(std::abs(v - p.start) <= w)) return "";
      continue;
    }
    if (std::abs(v - p.start) > p.normal_half_width) return "";
    if (first.empty()) {
      char buf[256];
      std::snprintf(buf, sizeof buf, "%s = %.3g within its normal variation %.3g ± %.3g",
                    p.name.c_str(), v, p.start, p.normal_half_width);
      first = buf;
    }
  }
  return first;
}

}  // namespace fesim::diagnosis
