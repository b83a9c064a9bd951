#include "identification/spline_hammerstein.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "identification/levenberg_marquardt.h"
#include "identification/method_support.h"
#include "identification/metrics.h"

namespace fesim::identification {
namespace {

/// Stop reason of an alternation that met its ε test.
constexpr const char* kCostChangeBelowEps = "cost_change_below_eps";

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// N×c matrix whose row k is Σ_j b_j X(k − d − j, :) (zero for negative indices).
Eigen::MatrixXd LaggedSum(const Eigen::MatrixXd& X, const Eigen::VectorXd& b, int d) {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(X.rows(), X.cols());
  for (Eigen::Index j = 0; j < b.size(); ++j) {
    const Eigen::Index lag = d + j;
    if (lag >= X.rows()) continue;
    out.bottomRows(X.rows() - lag) += b(j) * X.topRows(X.rows() - lag);
  }
  return out;
}

Eigen::MatrixXd BasisMatrix(const Eigen::VectorXd& knots, const Eigen::VectorXd& u) {
  Eigen::MatrixXd B(u.size(), knots.size() + 2);
  for (Eigen::Index k = 0; k < u.size(); ++k) B.row(k) = SplineBasis(knots, u(k));
  return B;
}

Eigen::VectorXd SplineValues(const Eigen::VectorXd& knots, const Eigen::VectorXd& beta,
                             const Eigen::VectorXd& u) {
  return BasisMatrix(knots, u) * beta;
}

int FirstRow(const SplineOrders& o) { return std::max(o.poles_l, o.zeros_n + o.delay_d); }

/// Σ y² over the measured (finite) samples.
double SumSquares(const SisoData& data) {
  double s = 0.0;
  for (const auto& y : data.y) s += y.array().isFinite().select(y, 0.0).squaredNorm();
  return s;
}

/// ‖e‖² over the finite entries: a residual of a missing output sample (NaN) is left out.
double SquaredNormOfMeasured(const Eigen::VectorXd& e) {
  return e.array().isFinite().select(e, 0.0).squaredNorm();
}

void Normalise(SplineHammersteinModel* m) {
  const double gain = m->linear.b.sum() / (1.0 + m->linear.a.sum());
  if (!std::isfinite(gain) || std::abs(gain) < 1e-300) return;
  m->linear.b /= gain;
  m->beta *= gain;
}

void CheckOrders(const SplineOrders& o) {
  if (o.zeros_n < 0 || o.poles_l < 1 || o.delay_d < 0 || o.knots_m < 2) {
    throw std::invalid_argument(
        "spline orders: need zeros_n >= 0, poles_l >= 1, delay_d >= 0, knots_m >= 2");
  }
}

// ---- Algorithm 1 blocks (ARX) ----

/// θ_n of eq. (9): Y_n = A(q) y, Φ_n = B(q) basis(u), rows k ≥ max(l, n+d).
LinearLsResult ArxNonlinearStep(const SisoData& data, const Eigen::VectorXd& knots,
                                const SplineOrders& o, const LinearBlock& lin) {
  const int k0 = FirstRow(o);
  std::vector<Eigen::MatrixXd> phis;
  std::vector<Eigen::VectorXd> ys;
  Eigen::Index rows = 0;
  for (std::size_t t = 0; t < data.y.size(); ++t) {
    const Eigen::VectorXd& y = data.y[t];
    const Eigen::Index N = y.size() - k0;
    if (N <= 0) continue;
    const Eigen::MatrixXd phi = LaggedSum(BasisMatrix(knots, data.u_us[t]), lin.b, o.delay_d);
    Eigen::VectorXd Yn = y.tail(N);
    for (int i = 1; i <= o.poles_l; ++i) Yn += lin.a(i - 1) * y.segment(k0 - i, N);
    phis.emplace_back(phi.bottomRows(N));
    ys.push_back(Yn);
    rows += N;
  }
  Eigen::MatrixXd Phi(rows, knots.size() + 2);
  Eigen::VectorXd Y(rows);
  Eigen::Index r = 0;
  for (std::size_t t = 0; t < phis.size(); ++t) {
    Phi.middleRows(r, phis[t].rows()) = phis[t];
    Y.segment(r, ys[t].size()) = ys[t];
    r += ys[t].size();
  }
  return SolveLinearLs(Phi, Y);
}

/// θ_l of eq. (14): regressors [−y(k−1) … −y(k−l), f(u(k−d)) … f(u(k−d−n))].
LinearLsResult ArxLinearStep(const SisoData& data, const Eigen::VectorXd& knots,
                             const SplineOrders& o, const Eigen::VectorXd& beta) {
  const int k0 = FirstRow(o);
  const int p = o.poles_l + o.zeros_n + 1;
  Eigen::Index rows = 0;
  for (const auto& y : data.y) rows += std::max<Eigen::Index>(0, y.size() - k0);
  Eigen::MatrixXd Phi(rows, p);
  Eigen::VectorXd Y(rows);
  Eigen::Index r = 0;
  for (std::size_t t = 0; t < data.y.size(); ++t) {
    const Eigen::VectorXd& y = data.y[t];
    const Eigen::Index N = y.size() - k0;
    if (N <= 0) continue;
    const Eigen::VectorXd fu = SplineValues(knots, beta, data.u_us[t]);
    for (int i = 1; i <= o.poles_l; ++i) Phi.block(r, i - 1, N, 1) = -y.segment(k0 - i, N);
    for (int j = 0; j <= o.zeros_n; ++j) {
      Phi.block(r, o.poles_l + j, N, 1) = fu.segment(k0 - o.delay_d - j, N);
    }
    Y.segment(r, N) = y.tail(N);
    r += N;
  }
  return SolveLinearLs(Phi, Y);
}

// ---- Algorithm 2 blocks (OE, zero initial conditions) ----

/// θ_n of eq. (13): columns T_ext⁻¹ Φ_n(u_ext, θ_b), i.e. each basis function filtered by B/A.
LinearLsResult OeNonlinearStep(const SisoData& data, const Eigen::VectorXd& knots,
                               const SplineOrders& o, const LinearBlock& lin) {
  Eigen::Index rows = 0;
  for (const auto& y : data.y) rows += y.size();
  Eigen::MatrixXd Phi(rows, knots.size() + 2);
  Eigen::VectorXd Y(rows);
  Eigen::Index r = 0;
  for (std::size_t t = 0; t < data.y.size(); ++t) {
    const Eigen::MatrixXd basis = BasisMatrix(knots, data.u_us[t]);
    const Eigen::Index N = basis.rows();
    for (Eigen::Index c = 0; c < basis.cols(); ++c) {
      Phi.block(r, c, N, 1) = FilterBA(lin.b, lin.a, o.delay_d, basis.col(c));
    }
    Y.segment(r, N) = data.y[t];
    r += N;
  }
  return SolveLinearLs(Phi, Y);
}

/// g(θ_a) of eq. (16): columns 1/A(q) f(u(k − d − j)), j = 0…n, and the least-squares θ_b.
LinearLsResult OeNumeratorStep(const SisoData& data, const std::vector<Eigen::VectorXd>& fu,
                               const SplineOrders& o, const Eigen::VectorXd& a) {
  Eigen::Index rows = 0;
  for (const auto& y : data.y) rows += y.size();
  Eigen::MatrixXd W(rows, o.zeros_n + 1);
  Eigen::VectorXd Y(rows);
  Eigen::Index r = 0;
  const Eigen::VectorXd one = Eigen::VectorXd::Ones(1);
  for (std::size_t t = 0; t < data.y.size(); ++t) {
    const Eigen::Index N = data.y[t].size();
    const Eigen::VectorXd base = FilterBA(one, a, o.delay_d, fu[t]);
    for (int j = 0; j <= o.zeros_n; ++j) {
      Eigen::VectorXd col = Eigen::VectorXd::Zero(N);
      if (j < N) col.tail(N - j) = base.head(N - j);
      W.block(r, j, N, 1) = col;
    }
    Y.segment(r, N) = data.y[t];
    r += N;
  }
  return SolveLinearLs(W, Y);
}

struct ThetaAProblem {
  Eigen::VectorXd lower, upper;
};

ThetaAProblem ThetaABounds(const SplineOrders& o) {
  ThetaAProblem p;
  const double inf = std::numeric_limits<double>::infinity();
  p.lower = Eigen::VectorXd::Constant(o.poles_l, -inf);
  p.upper = Eigen::VectorXd::Constant(o.poles_l, inf);
  if (o.poles_l == 2) {  // §4.2: 0 < a_2 ≤ 1, −2 ≤ a_1 ≤ 0
    p.lower << -2.0, 1e-12;
    p.upper << 0.0, 1.0;
  }
  return p;
}

}  // namespace

Eigen::VectorXd UniformKnots(double u_min_us, double u_max_us, int m) {
  if (m < 2 || !(u_max_us > u_min_us)) {
    throw std::invalid_argument("spline knots: need m >= 2 and u_max > u_min");
  }
  return Eigen::VectorXd::LinSpaced(m, u_min_us, u_max_us);
}

Eigen::RowVectorXd SplineBasis(const Eigen::VectorXd& knots_us, double u_us) {
  const Eigen::Index m = knots_us.size();
  const double u1 = knots_us(0);
  const double span = knots_us(m - 1) - u1;
  const double s = (u_us - u1) / span;
  Eigen::RowVectorXd row(m + 2);
  for (Eigen::Index i = 0; i + 2 < m; ++i) {
    const double si = (knots_us(i + 1) - u1) / span;
    const double d = std::abs(s - si);
    row(i) = d * d * d;
  }
  row(m - 2) = 1.0;
  row(m - 1) = s;
  row(m) = s * s;
  row(m + 1) = s * s * s;
  return row;
}

double SplineValue(const Eigen::VectorXd& knots_us, const Eigen::VectorXd& beta, double u_us) {
  return SplineBasis(knots_us, u_us).dot(beta);
}

Eigen::VectorXd SimulateSplineHammerstein(const SplineHammersteinModel& model,
                                          const Eigen::VectorXd& u_us) {
  return FilterBA(model.linear.b, model.linear.a, model.orders.delay_d,
                  SplineValues(model.knots_us, model.beta, u_us));
}

LinearBlock GenericLinearStart(const SplineOrders& orders, double sample_period_s,
                               double time_constant_s) {
  CheckOrders(orders);
  const double p = std::exp(-sample_period_s / time_constant_s);
  // (1 − p q⁻¹)^l
  Eigen::VectorXd poly = Eigen::VectorXd::Zero(orders.poles_l + 1);
  poly(0) = 1.0;
  for (int k = 0; k < orders.poles_l; ++k) {
    for (int i = k + 1; i >= 1; --i) poly(i) -= p * poly(i - 1);
  }
  LinearBlock lin;
  lin.a = poly.tail(orders.poles_l);
  lin.b = Eigen::VectorXd::Constant(orders.zeros_n + 1, poly.sum() / (orders.zeros_n + 1));
  return lin;
}

double SplineArxCost(const SisoData& data, const SplineHammersteinModel& model) {
  const SplineOrders& o = model.orders;
  const int k0 = FirstRow(o);
  double v = 0.0;
  for (std::size_t t = 0; t < data.y.size(); ++t) {
    const Eigen::VectorXd& y = data.y[t];
    const Eigen::Index N = y.size() - k0;
    if (N <= 0) continue;
    const Eigen::VectorXd fu = SplineValues(model.knots_us, model.beta, data.u_us[t]);
    Eigen::VectorXd e = y.tail(N);
    for (int i = 1; i <= o.poles_l; ++i) e += model.linear.a(i - 1) * y.segment(k0 - i, N);
    for (int j = 0; j <= o.zeros_n; ++j) {
      e -= model.linear.b(j) * fu.segment(k0 - o.delay_d - j, N);
    }
    v += SquaredNormOfMeasured(e);
  }
  return v;
}

double SplineOeCost(const SisoData& data, const SplineHammersteinModel& model) {
  double v = 0.0;
  for (std::size_t t = 0; t < data.y.size(); ++t) {
    v += SquaredNormOfMeasured(data.y[t] - SimulateSplineHammerstein(model, data.u_us[t]));
  }
  return v;
}

SplineFitReport FitSplineArx(const SisoData& data, const Eigen::VectorXd& knots_us,
                             const SplineOptions& options, const LinearBlock& start) {
  const auto t0 = Clock::now();
  const SplineOrders& o = options.orders;
  CheckOrders(o);
  if (start.a.size() != o.poles_l || start.b.size() != o.zeros_n + 1) {
    throw std::invalid_argument("FitSplineArx: start does not match orders (l, n)");
  }
  SplineFitReport rep;
  SplineHammersteinModel& m = rep.model;
  m.orders = o;
  m.knots_us = knots_us;
  m.linear = start;
  const double scale = SumSquares(data);
  double v_prev = std::numeric_limits<double>::infinity();
  for (rep.iterations = 1; rep.iterations <= options.max_iterations; ++rep.iterations) {
    m.beta = ArxNonlinearStep(data, knots_us, o, m.linear).theta;
    const Eigen::VectorXd theta_l = ArxLinearStep(data, knots_us, o, m.beta).theta;
    m.linear.a = theta_l.head(o.poles_l);
    m.linear.b = theta_l.tail(o.zeros_n + 1);
    Normalise(&m);
    const double v = SplineArxCost(data, m);
    rep.cost_history.push_back(v);
    if (std::abs(v - v_prev) < options.tolerance_eps * scale) {
      rep.convergence = {true, kCostChangeBelowEps, rep.iterations};
      break;
    }
    v_prev = v;
  }
  rep.iterations = std::min(rep.iterations, options.max_iterations);
  if (!rep.convergence.converged) rep.convergence = {false, "iteration_limit", rep.iterations};
  rep.beta_ci95 = ArxNonlinearStep(data, knots_us, o, m.linear).ci95_half_width;
  const Eigen::VectorXd ci_l = ArxLinearStep(data, knots_us, o, m.beta).ci95_half_width;
  rep.a_ci95 = ci_l.head(o.poles_l);
  rep.b_ci95 = ci_l.tail(o.zeros_n + 1);
  rep.wall_s = Seconds(t0);
  return rep;
}

SplineFitReport FitSplineOe(const SisoData& data, const Eigen::VectorXd& knots_us,
                            const SplineOptions& options, const LinearBlock& start) {
  const auto t0 = Clock::now();
  const SplineOrders& o = options.orders;
  CheckOrders(o);
  if (start.a.size() != o.poles_l || start.b.size() != o.zeros_n + 1) {
    throw std::invalid_argument("FitSplineOe: start does not match orders (l, n)");
  }
  SplineFitReport rep;
  SplineHammersteinModel& m = rep.model;
  m.orders = o;
  m.knots_us = knots_us;
  m.linear = start;
  const ThetaAProblem bounds = ThetaABounds(o);
  // Start inside the stability box (a start outside it would be projected by the first LM step).
  m.linear.a = m.linear.a.cwiseMax(bounds.lower).cwiseMin(bounds.upper);
  Eigen::Index n_res = 0, n_measured = 0;
  for (const auto& y : data.y) {
    n_res += y.size();
    n_measured += y.array().isFinite().count();
  }
  const double scale = SumSquares(data);
  double v_prev = std::numeric_limits<double>::infinity();
  LmResult lm;
  for (rep.iterations = 1; rep.iterations <= options.max_iterations; ++rep.iterations) {
    m.beta = OeNonlinearStep(data, knots_us, o, m.linear).theta;
    std::vector<Eigen::VectorXd> fu;
    for (const auto& u : data.u_us) fu.push_back(SplineValues(knots_us, m.beta, u));
    const auto residual = [&](const Eigen::VectorXd& a) -> Eigen::VectorXd {
      const LinearLsResult g = OeNumeratorStep(data, fu, o, a);
      Eigen::VectorXd r(n_res);
      Eigen::Index k = 0;
      const Eigen::VectorXd one = Eigen::VectorXd::Ones(1);
      for (std::size_t t = 0; t < data.y.size(); ++t) {
        const Eigen::Index N = data.y[t].size();
        r.segment(k, N) = data.y[t] - FilterBA(g.theta, a, o.delay_d, fu[t]);
        k += N;
      }
      for (Eigen::Index i = 0; i < r.size(); ++i) {
        if (!std::isfinite(r(i))) r(i) = 0.0;  // a missing output sample is not in the loss
      }
      return r;
    };
    const auto ts = Clock::now();
    LmOptions lo;
    lo.max_iterations = 100;
    lm = LevenbergMarquardt(residual, m.linear.a, bounds.lower, bounds.upper, lo);
    rep.step_wall_s.push_back(Seconds(ts));
    rep.lm_iterations += lm.iterations;
    rep.step_convergence.push_back(ToConvergence(lm));
    m.linear.a = lm.x;
    m.linear.b = OeNumeratorStep(data, fu, o, m.linear.a).theta;
    Normalise(&m);
    const double v = SplineOeCost(data, m);
    rep.cost_history.push_back(v);
    if (std::abs(v - v_prev) < options.tolerance_eps * scale) {
      rep.convergence = {true, kCostChangeBelowEps, rep.iterations};
      break;
    }
    v_prev = v;
  }
  rep.iterations = std::min(rep.iterations, options.max_iterations);
  if (!rep.convergence.converged) rep.convergence = {false, "iteration_limit", rep.iterations};
  rep.beta_ci95 = OeNonlinearStep(data, knots_us, o, m.linear).ci95_half_width;
  std::vector<Eigen::VectorXd> fu;
  for (const auto& u : data.u_us) fu.push_back(SplineValues(knots_us, m.beta, u));
  rep.b_ci95 = OeNumeratorStep(data, fu, o, m.linear.a).ci95_half_width;
  // θ_a: the LM Jacobian at the last step (scale-invariant: a is unaffected by normalisation).
  rep.a_ci95 = ConfidenceHalfWidths95(lm.jtj, lm.cost, n_measured);
  rep.wall_s = Seconds(t0);
  return rep;
}

// ---------------------------------------------------------------------------------------------
// CLI adapter.
namespace {

struct SisoColumns {
  std::string input, output;
};

SisoColumns PickColumns(const Trial& trial, const std::string& label) {
  const auto us = trial.NamesWithPrefix("u.");
  if (us.size() != 1) {
    throw std::runtime_error(label +
                             ": spline methods are single-input: need exactly one u.* "
                             "column, found " +
                             std::to_string(us.size()));
  }
  auto ys = trial.NamesWithPrefix("tau.");
  if (ys.empty()) ys = trial.NamesWithPrefix("q.");
  if (ys.size() != 1) {
    throw std::runtime_error(label +
                             ": spline methods are single-output: need exactly one tau.* "
                             "(or, without tau.*, one q.*) column, found " +
                             std::to_string(ys.size()));
  }
  return {us[0], ys[0]};
}

/// The output's mean over the samples before the input first leaves 0 (the rest level the model's
/// zero initial conditions are relative to); 0 when the input starts non-zero.
double InitialBaseline(const Eigen::VectorXd& u_us, const Eigen::VectorXd& y) {
  double base = 0.0;
  Eigen::Index n = 0, measured = 0;
  for (; n < u_us.size() && u_us(n) == 0.0; ++n) {
    if (!std::isfinite(y(n))) continue;  // a missing sample
    base += y(n);
    ++measured;
  }
  return measured > 0 ? base / static_cast<double>(measured) : 0.0;
}

struct Prepared {
  SisoData data;
  std::vector<double> baselines;
  std::vector<std::size_t> missing;  ///< missing (NaN) output samples per trial.
};

Prepared Prepare(const std::vector<Trial>& trials, const SisoColumns& cols, const std::string& what,
                 int min_samples) {
  Prepared p;
  for (std::size_t t = 0; t < trials.size(); ++t) {
    const std::string label = what + " trial " + std::to_string(t);
    RequireSamples(trials[t], static_cast<std::size_t>(min_samples), label,
                   "orders and spline knots");
    const double T = UniformSamplePeriod(trials[t], label);
    if (t == 0) p.data.sample_period_s = T;
    if (std::abs(T - p.data.sample_period_s) > 1e-3 * T) {
      throw std::runtime_error(label + ": sample period differs from trial 0");
    }
    // Inputs must be complete; output samples may be missing (tracker dropouts, NaN): the
    // equation-error rows touching them are dropped, the output-error loss skips them.
    const Eigen::MatrixXd u = RequireColumns(trials[t], {cols.input}, label);
    std::size_t missing = 0;
    const Eigen::VectorXd y = OutputColumn(trials[t], cols.output, label, &missing);
    if (missing == static_cast<std::size_t>(y.size())) {
      throw std::runtime_error(label + ": column " + cols.output + " has no measured sample");
    }
    const double base = InitialBaseline(u.col(0), y);
    p.baselines.push_back(base);
    p.missing.push_back(missing);
    p.data.u_us.emplace_back(u.col(0));
    p.data.y.emplace_back(y.array() - base);
  }
  return p;
}

SplineOptions ReadOptions(const Trial& first) {
  MetadataOptions md(first.metadata, "spline");
  SplineOptions o;
  o.orders.zeros_n = md.Int("zeros_n", o.orders.zeros_n, 0, 50);
  o.orders.poles_l = md.Int("poles_l", o.orders.poles_l, 1, 50);
  o.orders.delay_d = md.Int("delay_d", o.orders.delay_d, 0, 200);
  o.orders.knots_m = md.Int("knots_m", o.orders.knots_m, 2, 40);
  o.tolerance_eps = md.Real("eps", o.tolerance_eps, 1e-300, 1.0);
  o.max_iterations = md.Int("max_iterations", o.max_iterations, 1, 100000);
  o.initial_time_constant_s = md.Real("tau0_s", o.initial_time_constant_s, 1e-6, 1e6);
  md.RejectUnknown();
  return o;
}

std::string ModelYaml(const std::string& method, const SplineFitReport& rep,
                      const SisoColumns& cols, const std::string& unit, double sample_period_s) {
  const SplineHammersteinModel& m = rep.model;
  std::string s = "# fesim identify: " + method +
                  " (paper 002_78a57b74c57ee464 eq. 1-2; f normalised to G(1) = 1)\n";
  s += "method: " + method + "\ninput: " + cols.input + "\noutput: " + cols.output + "\n";
  s += YamlParam("sample_time_s", sample_period_s, "s", NAN, 0);
  s += "orders: {zeros_n: " + std::to_string(m.orders.zeros_n) +
       ", poles_l: " + std::to_string(m.orders.poles_l) +
       ", delay_d: " + std::to_string(m.orders.delay_d) +
       ", knots_m: " + std::to_string(m.orders.knots_m) + "}\n";
  s += YamlParam("baseline_trial0", m.baseline, unit, NAN, 0);
  s += "knots:\n";
  for (Eigen::Index i = 0; i < m.knots_us.size(); ++i) {
    s += YamlParam("u" + std::to_string(i + 1), m.knots_us(i), "us", NAN, 2);
  }
  s += "# f(u) = sum_i beta_i |s - s_{i+1}|^3 + beta_{m-1} + beta_m s + beta_{m+1} s^2 + "
       "beta_{m+2} s^3, s = (u - u1)/(um - u1)\nbeta:\n";
  for (Eigen::Index i = 0; i < m.beta.size(); ++i) {
    s += YamlParam("beta" + std::to_string(i + 1), m.beta(i), unit, rep.beta_ci95(i), 2);
  }
  s += "# ci95 are conditional on the other parameter block\na:\n";
  for (Eigen::Index i = 0; i < m.linear.a.size(); ++i) {
    s += YamlParam("a" + std::to_string(i + 1), m.linear.a(i), "1", rep.a_ci95(i), 2);
  }
  s += "b:\n";
  for (Eigen::Index i = 0; i < m.linear.b.size(); ++i) {
    s += YamlParam("b" + std::to_string(i), m.linear.b(i), "1", rep.b_ci95(i), 2);
  }
  return s;
}

/// The model as MATLAB polynomials (method.h DiscreteModel): ARX A = [1 a], F = 1; OE A = 1,
/// F = [1 a]; B = [0 × d, b]; f(u) at kNonlinearityPoints breakpoints over the knots' span.
DiscreteModel DiscreteOf(bool oe, const SplineHammersteinModel& m, const SisoColumns& cols,
                         const std::string& unit, double sample_period_s) {
  constexpr int kNonlinearityPoints = 101;
  DiscreteModel d;
  d.sample_time_s = sample_period_s;
  d.inputs = {cols.input};
  d.input_units = {"us"};
  d.output = cols.output;
  d.output_unit = unit;
  std::vector<double> poles = {1.0};
  for (Eigen::Index i = 0; i < m.linear.a.size(); ++i) poles.push_back(m.linear.a(i));
  (oe ? d.f : d.a) = poles;
  std::vector<double> b(static_cast<std::size_t>(m.orders.delay_d), 0.0);
  for (Eigen::Index i = 0; i < m.linear.b.size(); ++i) b.push_back(m.linear.b(i));
  d.b = {b};
  std::vector<double> u, f;
  const double lo = m.knots_us(0), hi = m.knots_us(m.knots_us.size() - 1);
  for (int k = 0; k < kNonlinearityPoints; ++k) {
    u.push_back(lo + (hi - lo) * k / (kNonlinearityPoints - 1));
    f.push_back(SplineValue(m.knots_us, m.beta, u.back()));
  }
  d.nonlinearity_u = {u};
  d.nonlinearity_f = {f};
  d.output_offset = m.baseline;
  return d;
}

Json FitMetrics(const SplineFitReport& rep) {
  Json j = Json::Object();
  j.Set("iterations", rep.iterations);
  j.Set("converged", rep.convergence.converged);
  j.Set("stop_reason", rep.convergence.stop_reason);
  if (!rep.step_convergence.empty()) {
    j.Set("local_step_convergence",
          ConvergenceJson(rep.step_convergence, rep.step_convergence.size() - 1));
  }
  j.Set("lm_iterations", rep.lm_iterations);
  j.Set("cost_history", rep.cost_history);
  j.Set("local_step_wall_s", rep.step_wall_s);
  j.Set("wall_s", rep.wall_s);
  return j;
}

/// Algorithm 1 (and 2 for OE) on `train`: the model, its YAML and fit metrics (shared by
/// `fesim identify` and the diagnosis simulator).
struct SplineFitted {
  SisoColumns cols;
  int min_samples = 0;
  Prepared tr;
  SplineFitReport alg1, final_rep;
  Json metrics;
  MethodResult result;  ///< model_yaml and warnings filled.
};

SplineFitted FitSplineOnTrials(bool oe, const std::vector<Trial>& train_rows,
                               const ProgressFn& progress) {
  const std::string method = oe ? "spline-oe" : "spline-arx";
  if (train_rows.empty()) throw std::runtime_error("--train: no trials");
  const SisoColumns cols = PickColumns(train_rows[0], "train trial 0");
  // The rows of the output's sensor (a record may interleave other sensors' rows).
  const std::vector<Trial> train = SensorRows(train_rows, {cols.output});
  RequireVaryingOutput(train, cols.output, "train");
  const SplineOptions options = ReadOptions(train[0]);
  const SplineOrders& o = options.orders;
  const int min_samples = 4 * (o.poles_l + o.zeros_n + o.delay_d + o.knots_m + 2);
  const Prepared tr = Prepare(train, cols, "train", min_samples);
  double umin = INFINITY, umax = -INFINITY;
  for (const auto& u : tr.data.u_us) {
    umin = std::min(umin, u.minCoeff());
    umax = std::max(umax, u.maxCoeff());
  }
  if (!(umax > umin)) {
    throw std::runtime_error("train: column " + cols.input + " is constant (no excitation)");
  }
  const Eigen::VectorXd knots = UniformKnots(umin, umax, o.knots_m);
  if (progress) progress(0.0, "Algorithm 1 (ARX)");
  const LinearBlock start =
      GenericLinearStart(o, tr.data.sample_period_s, options.initial_time_constant_s);
  SplineFitReport alg1 = FitSplineArx(tr.data, knots, options, start);
  SplineFitReport final_rep = alg1;
  Json metrics = Json::Object();
  metrics.Set("method", method);
  metrics.Set("input", cols.input);
  metrics.Set("output", cols.output);
  metrics.Set("algorithm1", FitMetrics(alg1));
  if (oe) {
    if (progress) progress(0.3, "Algorithm 2 (OE) from Algorithm 1");
    final_rep = FitSplineOe(tr.data, knots, options, alg1.model.linear);
    metrics.Set("algorithm2", FitMetrics(final_rep));
  }
  final_rep.model.baseline = tr.baselines[0];
  const std::string unit = cols.output.rfind("tau.", 0) == 0 ? "N m" : "rad";
  MethodResult result;
  result.model_yaml = ModelYaml(method, final_rep, cols, unit, tr.data.sample_period_s);
  result.discrete_models = {DiscreteOf(oe, final_rep.model, cols, unit, tr.data.sample_period_s)};
  result.model_yaml += "# how the alternation stopped (Algorithm 1" +
                       std::string(oe ? " and 2" : "") + ")\nconvergence:\n";
  const auto add_convergence = [&](const std::string& key, const SplineFitReport& rep) {
    result.model_yaml += "  " + key +
                         ": {converged: " + (rep.convergence.converged ? "true" : "false") +
                         ", stop_reason: " + rep.convergence.stop_reason +
                         ", iterations: " + std::to_string(rep.convergence.iterations) + "}\n";
    if (!rep.convergence.converged) {
      result.warnings.push_back(method + " " + key + ": did not converge (" +
                                rep.convergence.stop_reason + " after " +
                                std::to_string(rep.convergence.iterations) + " iterations)");
    }
  };
  add_convergence("algorithm1", alg1);
  if (oe) {
    add_convergence("algorithm2", final_rep);
    if (!final_rep.step_convergence.empty()) {
      const std::size_t last = final_rep.step_convergence.size() - 1;
      result.model_yaml +=
          ConvergenceYaml("algorithm2_lm_runs", final_rep.step_convergence, last, 2);
      const std::string w = NotConvergedWarning(method + " algorithm 2 theta_a (last LM run)",
                                                final_rep.step_convergence, last);
      if (!w.empty()) result.warnings.push_back(w);
    }
  }
  return {cols, min_samples, tr, alg1, final_rep, metrics, result};
}

MethodResult RunSpline(bool oe, const std::vector<Trial>& train_rows,
                       const std::vector<Trial>& test_rows, const ProgressFn& progress) {
  const std::string method = oe ? "spline-oe" : "spline-arx";
  SplineFitted fitted = FitSplineOnTrials(oe, train_rows, progress);
  const SisoColumns& cols = fitted.cols;
  const std::vector<Trial> train = SensorRows(train_rows, {cols.output});
  const std::vector<Trial> test = SensorRows(test_rows, {cols.output});
  const int min_samples = fitted.min_samples;
  const Prepared& tr = fitted.tr;
  const SplineFitReport& alg1 = fitted.alg1;
  const SplineFitReport& final_rep = fitted.final_rep;
  Json metrics = fitted.metrics;
  MethodResult result = std::move(fitted.result);
  const bool has_test = !test.empty();
  const std::vector<Trial>& eval = has_test ? test : train;
  if (has_test) PickColumns(test[0], "test trial 0");
  const Prepared ev = has_test ? Prepare(test, cols, "test", min_samples) : tr;
  Json fits = Json::Array();
  for (std::size_t t = 0; t < eval.size(); ++t) {
    const Eigen::VectorXd yhat =
        SimulateSplineHammerstein(final_rep.model, ev.data.u_us[t]).array() + ev.baselines[t];
    const Eigen::VectorXd y = ev.data.y[t].array() + ev.baselines[t];
    const std::vector<double> yh(yhat.data(), yhat.data() + yhat.size());
    // The metrics are over the measured samples; the prediction covers every row.
    std::vector<double> yv(y.data(), y.data() + y.size()), yhv = yh;
    KeepMeasuredPairs(&yv, &yhv);
    Json f = Json::Object();
    f.Set("trial", static_cast<int>(t));
    f.Set("best_fit_percent", BestFitPercent(yv, yhv));
    f.Set("normalised_error", NormalisedError(yv, yhv));
    f.Set("rms", Rms(yv, yhv));
    f.Set("missing_samples", static_cast<double>(ev.missing[t]));
    if (oe) {
      const Eigen::VectorXd y1 =
          SimulateSplineHammerstein(alg1.model, ev.data.u_us[t]).array() + ev.baselines[t];
      std::vector<double> ym(y.data(), y.data() + y.size());
      std::vector<double> y1v(y1.data(), y1.data() + y1.size());
      KeepMeasuredPairs(&ym, &y1v);
      f.Set("algorithm1_best_fit_percent", BestFitPercent(ym, y1v));
    }
    fits.Push(f);
    Trial pred;
    pred.metadata["source"] = "fesim identify --method " + method;
    pred.metadata["evaluated_on"] = has_test ? "test" : "train";
    pred.time = eval[t].time;
    pred.AddColumn(cols.input, eval[t].Column(cols.input));
    pred.AddColumn(cols.output, yh);
    result.predictions.push_back(std::move(pred));
  }
  metrics.Set(has_test ? "test" : "train", fits);
  std::size_t train_missing = 0;
  for (std::size_t m : tr.missing) train_missing += m;
  metrics.Set("train_missing_samples", static_cast<double>(train_missing));
  metrics.Set("prediction", "simulation with zero initial conditions (not one-step-ahead)");
  result.metrics = metrics;
  if (progress) progress(1.0, "done");
  return result;
}

FittedSimulator FitSplineSimulator(bool oe, const std::vector<Trial>& train,
                                   const ProgressFn& progress) {
  SplineFitted fitted = FitSplineOnTrials(oe, train, progress);
  FittedSimulator out;
  out.model_yaml = fitted.result.model_yaml;
  out.warnings = fitted.result.warnings;
  out.inputs = {fitted.cols.input};
  out.outputs = {fitted.cols.output};
  out.simulate = [cols = fitted.cols, model = fitted.final_rep.model](const Trial& trial) {
    const Eigen::MatrixXd uy = RequireColumns(trial, {cols.input, cols.output}, "simulated trial");
    const Eigen::VectorXd yhat =
        SimulateSplineHammerstein(model, uy.col(0)).array() + InitialBaseline(uy.col(0), uy.col(1));
    Trial pred;
    pred.time = trial.time;
    pred.AddColumn(cols.output, std::vector<double>(yhat.data(), yhat.data() + yhat.size()));
    return pred;
  };
  if (progress) progress(1.0, "done");
  return out;
}

}  // namespace

MethodEntry SplineArxMethod() {
  return {"spline-arx", "cubic-spline Hammerstein, Algorithm 1 (ARX, alternating LS), paper 002",
          [](const std::vector<Trial>& tr, const std::vector<Trial>& te, const ProgressFn& p) {
            return RunSpline(false, tr, te, p);
          },
          [](const std::vector<Trial>& tr, const ProgressFn& p) {
            return FitSplineSimulator(false, tr, p);
          }};
}

MethodEntry SplineOeMethod() {
  return {"spline-oe",
          "cubic-spline Hammerstein, Algorithm 2 (OE, separable LS + LM) from Alg. 1, paper 002",
          [](const std::vector<Trial>& tr, const std::vector<Trial>& te, const ProgressFn& p) {
            return RunSpline(true, tr, te, p);
          },
          [](const std::vector<Trial>& tr, const ProgressFn& p) {
            return FitSplineSimulator(true, tr, p);
          }};
}

}  // namespace fesim::identification
