#include "identification/tremor_arx.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <complex>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "identification/levenberg_marquardt.h"
#include "identification/method_support.h"
#include "identification/metrics.h"
#include "identification/nnls.h"
#include "identification/spectrum.h"

namespace fesim::identification {
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kPi = 3.14159265358979323846;
constexpr double kSlopeTol = 1e-10;  // relative violation of h' ≥ 0 accepted before a cut

double Seconds(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

Eigen::RowVectorXd SlopeRow(int m, double s) {
  Eigen::RowVectorXd r = Eigen::RowVectorXd::Zero(m + 1);
  double p = 1.0;
  for (int k = 1; k <= m; ++k, p *= s) r(k) = k * p;
  return r;
}

double PolyValue(const Eigen::VectorXd& beta, double s) {
  double v = 0.0;
  for (Eigen::Index k = beta.size() - 1; k >= 0; --k) v = v * s + beta(k);
  return v;
}

/// (min, argmin) of h'(s) = Σ k β_k s^{k−1} over [lo, hi]: ends and real roots of h''.
std::pair<double, double> SlopeMinimum(const Eigen::VectorXd& beta, double lo, double hi) {
  const int m = static_cast<int>(beta.size()) - 1;
  const auto slope = [&](double s) { return SlopeRow(m, s).dot(beta); };
  std::pair<double, double> best{slope(lo), lo};
  const double vhi = slope(hi);
  if (vhi < best.first) best = {vhi, hi};
  // h''(s) = Σ_{k≥2} k(k−1) β_k s^{k−2}
  Eigen::VectorXd c(std::max(0, m - 1));
  for (int k = 2; k <= m; ++k) c(k - 2) = k * (k - 1) * beta(k);
  int deg = static_cast<int>(c.size()) - 1;
  const double cmax = c.size() ? c.cwiseAbs().maxCoeff() : 0.0;
  while (deg >= 1 && std::abs(c(deg)) <= 1e-14 * cmax) --deg;
  if (deg >= 1) {
    Eigen::MatrixXd comp = Eigen::MatrixXd::Zero(deg, deg);
    for (int i = 1; i < deg; ++i) comp(i, i - 1) = 1.0;
    for (int i = 0; i < deg; ++i) comp(i, deg - 1) = -c(i) / c(deg);
    const Eigen::VectorXcd roots = Eigen::EigenSolver<Eigen::MatrixXd>(comp, false).eigenvalues();
    for (Eigen::Index r = 0; r < roots.size(); ++r) {
      const double x = roots(r).real();
      if (std::abs(roots(r).imag()) > 1e-9 * (1.0 + std::abs(x)) || x <= lo || x >= hi) continue;
      const double v = slope(x);
      if (v < best.first) best = {v, x};
    }
  }
  return best;
}

int FirstRow(const TremorOrders& o) { return std::max(o.poles_l, o.delay_m + o.zeros_n); }

/// Columns of the lifted regressor z(k) of eq. (12): e(k) = z(k)ᵀ θ_z with
///   z(k) = [y(k), y(k−1) … y(k−l_P), 1, s(k−m_P−j)^p (j = 0…n_P, p = 1…m), cos ω k, sin ω k],
///   θ_z  = [1, a_1 … a_{l_P}, −β_0 Σ_j b_j, −b_j β_p, −λ_1, −λ_2],
/// the tremor pair once per trial (zero outside its rows). Only the last pair depends on ω.
struct LiftedLayout {
  int l, n, m;
  explicit LiftedLayout(const TremorOrders& o) : l(o.poles_l), n(o.zeros_n), m(o.poly_degree) {}
  int Fixed() const { return 2 + l + (n + 1) * m; }  ///< columns independent of ω
  int One() const { return l + 1; }
  int S(int j, int p) const { return l + 2 + j * m + (p - 1); }  ///< p ≥ 1
};

/// The ω-independent columns of z(k) over the complete rows (k ≥ max(l_P, m_P + n_P) and
/// y(k) … y(k − l_P) measured; a row touching a missing sample is left out) of all trials,
/// factorised once as Z = Q R (Householder; Q kept as its reflectors).
struct FixedRegression {
  Eigen::HouseholderQR<Eigen::MatrixXd> qr;
  std::vector<int> trial;  ///< trial of each row
  Eigen::VectorXd k;       ///< sample index of each row within its trial
};

/// FixedRegression of `data` at orders `o`; `s` = u/u_scale per trial.
std::shared_ptr<const FixedRegression> BuildFixedRegression(const TremorData& data,
                                                            const TremorOrders& o,
                                                            const std::vector<Eigen::VectorXd>& s) {
  const LiftedLayout L(o);
  const int k0 = FirstRow(o);
  Eigen::Index total = 0;
  for (const auto& y : data.y) total += std::max<Eigen::Index>(0, y.size() - k0);
  Eigen::MatrixXd Z(total, L.Fixed());
  auto fixed = std::make_shared<FixedRegression>();
  fixed->trial.resize(static_cast<std::size_t>(total));
  fixed->k.resize(total);
  Eigen::Index r = 0;
  for (std::size_t t = 0; t < data.y.size(); ++t) {
    const Eigen::VectorXd& y = data.y[t];
    const Eigen::Index rows = std::max<Eigen::Index>(0, y.size() - k0);
    if (rows == 0) continue;
    for (int i = 0; i <= o.poles_l; ++i) Z.col(i).segment(r, rows) = y.segment(k0 - i, rows);
    Z.col(L.One()).segment(r, rows).setOnes();
    for (int j = 0; j <= o.zeros_n; ++j) {
      const auto base = s[t].segment(k0 - o.delay_m - j, rows).array();
      Eigen::ArrayXd power = base;
      for (int p = 1; p <= o.poly_degree; ++p, power *= base) {
        Z.col(L.S(j, p)).segment(r, rows) = power.matrix();
      }
    }
    fixed->k.segment(r, rows) = Eigen::VectorXd::LinSpaced(rows, k0, k0 + rows - 1);
    std::fill_n(fixed->trial.begin() + r, rows, static_cast<int>(t));
    r += rows;
  }
  if (!Z.allFinite()) {
    Eigen::Index kept = 0;
    for (Eigen::Index i = 0; i < total; ++i) {
      if (!Z.row(i).allFinite()) continue;
      Z.row(kept) = Z.row(i);
      fixed->k(kept) = fixed->k(i);
      fixed->trial[static_cast<std::size_t>(kept)] = fixed->trial[static_cast<std::size_t>(i)];
      ++kept;
    }
    Z.conservativeResize(kept, Eigen::NoChange);
    fixed->k.conservativeResize(kept);
    fixed->trial.resize(static_cast<std::size_t>(kept));
  }
  fixed->qr.compute(Z);
  return fixed;
}

struct Problem {
  const TremorData* data;
  TremorOrders o;
  double u_scale;
  double omega = -1.0;  // rad/sample; < 0 means no tremor regressors
  double s_min, s_max;
  int constraint_points;
  std::vector<Eigen::VectorXd> s;  // normalised inputs
  std::shared_ptr<const FixedRegression> fixed;
  /// R of the lifted regression [Z, C(ω)] = Q̃ R: ‖z θ_z‖ over the rows = ‖R θ_z‖, so every least
  /// squares of Algorithm 1 and V_N (eq. 14) are solved on R (≤ p_z rows) instead of N rows.
  Eigen::MatrixXd r;

  /// Sets ω (rad/sample; < 0: no tremor regressors) and R: the fixed R_Z, Q_Zᵀ C for the
  /// cos/sin columns C (Householder reflectors of Z applied to C) and the R of the part of C
  /// orthogonal to Z.
  void SetOmega(double w) {
    omega = w;
    const FixedRegression& F = *fixed;
    const Eigen::Index rows = F.qr.rows(), pf = F.qr.cols(), tc = TremorCols();
    const Eigen::Index top = std::min(rows, pf), tail = std::min(rows - top, tc);
    r = Eigen::MatrixXd::Zero(top + tail, pf + tc);
    r.topLeftCorner(top, pf) = F.qr.matrixQR().topRows(top).triangularView<Eigen::Upper>();
    if (tc == 0) return;
    Eigen::MatrixXd C = Eigen::MatrixXd::Zero(rows, tc);
    for (Eigen::Index i = 0; i < rows; ++i) {
      const Eigen::Index c = 2 * F.trial[static_cast<std::size_t>(i)];
      C(i, c) = std::cos(w * F.k(i));
      C(i, c + 1) = std::sin(w * F.k(i));
    }
    C.applyOnTheLeft(F.qr.householderQ().adjoint());
    r.topRightCorner(top, tc) = C.topRows(top);
    if (tail == 0) return;
    const Eigen::HouseholderQR<Eigen::MatrixXd> qc(C.bottomRows(rows - top));
    r.bottomRightCorner(tail, tc) = qc.matrixQR().topRows(tail).triangularView<Eigen::Upper>();
  }
  bool HasTremor() const { return omega >= 0.0; }
  int TremorCols() const { return HasTremor() ? 2 * static_cast<int>(data->y.size()) : 0; }
  /// Complete rows of the regression (N of the confidence intervals).
  Eigen::Index Rows() const { return fixed->qr.rows(); }
};

/// θ_z of LiftedLayout for (β, a, b, λ).
Eigen::VectorXd LiftedTheta(const Problem& P, const Eigen::VectorXd& beta, const Eigen::VectorXd& a,
                            const Eigen::VectorXd& b, const Eigen::VectorXd& lam) {
  const LiftedLayout L(P.o);
  Eigen::VectorXd th(P.r.cols());
  th(0) = 1.0;
  th.segment(1, L.l) = a;
  th(L.One()) = -beta(0) * b.sum();
  for (int j = 0; j <= L.n; ++j) {
    for (int p = 1; p <= L.m; ++p) th(L.S(j, p)) = -b(j) * beta(p);
  }
  th.tail(P.TremorCols()) = -lam;
  return th;
}

/// min ‖Φ θ − Y‖ of a lifted least squares (Φ = R Φ_z, Y = R y_z); the cost and the 95 %
/// half-widths (N = P.Rows()) only `with_ci`, as SolveLinearLs on the full rows.
LinearLsResult LiftedLs(const Problem& P, const Eigen::MatrixXd& Phi, const Eigen::VectorXd& Y,
                        bool with_ci) {
  LinearLsResult res;
  res.theta = Phi.colPivHouseholderQr().solve(Y);
  if (!with_ci) return res;
  res.cost = (Phi * res.theta - Y).squaredNorm();
  res.ci95_half_width =
      ConfidenceHalfWidths95(Phi.transpose() * Phi, res.cost, static_cast<long>(P.Rows()));
  return res;
}

/// θ_n of eq. (17) subject to h' ≥ 0 on [s_min, s_max] (grid + exact cutting planes); the 95 %
/// half-widths only `with_ci` (the iterations need θ_n alone). Regressor Φ_n(k) = Σ_j b_j
/// [1, s(k−m_P−j), …]; target y(k) + Σ a_i y(k−i) − d(k) (eq. 16), both on the lifted R.
LinearLsResult NonlinearStep(const Problem& P, const Eigen::VectorXd& a, const Eigen::VectorXd& b,
                             const Eigen::VectorXd& lam, bool with_ci) {
  const LiftedLayout L(P.o);
  const int m = P.o.poly_degree;
  Eigen::MatrixXd Mz = Eigen::MatrixXd::Zero(P.r.cols(), m + 1);  // Φ_n = Z Mz
  Mz(L.One(), 0) = b.sum();
  for (int j = 0; j <= L.n; ++j) {
    for (int p = 1; p <= m; ++p) Mz(L.S(j, p), p) = b(j);
  }
  Eigen::VectorXd yz = Eigen::VectorXd::Zero(P.r.cols());  // target = Z yz
  yz(0) = 1.0;
  yz.segment(1, L.l) = a;
  yz.tail(P.TremorCols()) = -lam;
  const Eigen::MatrixXd Phi = P.r * Mz;
  const Eigen::VectorXd Y = P.r * yz;
  std::vector<double> pts;
  pts.reserve(static_cast<std::size_t>(P.constraint_points));
  for (int g = 0; g < P.constraint_points; ++g) {
    pts.push_back(P.s_min + (P.s_max - P.s_min) * g / std::max(1, P.constraint_points - 1));
  }
  LinearLsResult res;
  for (int cut = 0; cut < 20; ++cut) {
    Eigen::MatrixXd G(static_cast<Eigen::Index>(pts.size()), m + 1);
    for (std::size_t g = 0; g < pts.size(); ++g) G.row(g) = SlopeRow(m, pts[g]);
    res.theta = LeastSquaresInequality(Phi, Y, G, Eigen::VectorXd::Zero(G.rows())).x;
    const auto [vmin, at] = SlopeMinimum(res.theta, P.s_min, P.s_max);
    const double scale = SlopeRow(m, P.s_max).cwiseAbs().dot(res.theta.cwiseAbs()) + 1e-300;
    if (vmin >= -kSlopeTol * scale) break;
    pts.push_back(at);
  }
  res.cost = (Phi * res.theta - Y).squaredNorm();
  if (with_ci) res.ci95_half_width = LiftedLs(P, Phi, Y, true).ci95_half_width;
  return res;
}

/// θ_l = [a; b; λ per trial] of eq. (21): regressor [−y(k−i), h(k−m_P−j), cos ω k, sin ω k]
/// (eq. 19–20), target y(k), on the lifted R; the cost and 95 % half-widths only `with_ci`.
LinearLsResult LinearStep(const Problem& P, const Eigen::VectorXd& beta, bool with_ci) {
  const LiftedLayout L(P.o);
  const int p = L.l + L.n + 1 + P.TremorCols();
  Eigen::MatrixXd Mz = Eigen::MatrixXd::Zero(P.r.cols(), p);  // Φ_l = Z Mz
  for (int i = 1; i <= L.l; ++i) Mz(i, i - 1) = -1.0;
  for (int j = 0; j <= L.n; ++j) {
    Mz(L.One(), L.l + j) = beta(0);
    for (int q = 1; q <= L.m; ++q) Mz(L.S(j, q), L.l + j) = beta(q);
  }
  const Eigen::Index pf = L.Fixed();
  for (int c = 0; c < P.TremorCols(); ++c) Mz(pf + c, L.l + L.n + 1 + c) = 1.0;
  return LiftedLs(P, P.r * Mz, P.r.col(0), with_ci);
}

/// V_N of eq. (14) over the complete rows: ‖R θ_z‖².
double Cost(const Problem& P, const Eigen::VectorXd& beta, const Eigen::VectorXd& a,
            const Eigen::VectorXd& b, const Eigen::VectorXd& lam) {
  return (P.r * LiftedTheta(P, beta, a, b, lam)).squaredNorm();
}

struct RunResult {
  Eigen::VectorXd beta, a, b, lam, beta_ci, l_ci;
  int iterations = 0;
  Convergence convergence;
  std::vector<double> history;
  double cost = 0.0;
};

/// Algorithm 1 of [Copur 2016] (§3.3.4).
RunResult Algorithm1(const Problem& P, const TremorOptions& opt) {
  const TremorOrders& o = P.o;
  RunResult rr;
  rr.a = Eigen::VectorXd::Zero(o.poles_l);
  rr.b = Eigen::VectorXd::Constant(o.zeros_n + 1, 1.0 / (o.zeros_n + 1));
  rr.lam = Eigen::VectorXd::Zero(P.TremorCols());
  double scale = 0.0;
  for (const auto& y : P.data->y) {
    scale += y.allFinite() ? y.squaredNorm() : y.array().isFinite().select(y, 0.0).squaredNorm();
  }
  double v_prev = std::numeric_limits<double>::infinity();
  for (rr.iterations = 1; rr.iterations <= opt.max_iterations; ++rr.iterations) {
    rr.beta = NonlinearStep(P, rr.a, rr.b, rr.lam, false).theta;
    const Eigen::VectorXd th = LinearStep(P, rr.beta, false).theta;
    rr.a = th.head(o.poles_l);
    rr.b = th.segment(o.poles_l, o.zeros_n + 1);
    rr.lam = th.tail(P.TremorCols());
    const double gain = rr.b.sum() / (1.0 + rr.a.sum());
    if (std::isfinite(gain) && gain > 1e-300) {
      rr.b /= gain;
      rr.beta *= gain;
    }
    rr.cost = Cost(P, rr.beta, rr.a, rr.b, rr.lam);
    rr.history.push_back(rr.cost);
    if (std::abs(rr.cost - v_prev) < opt.tolerance_eps * scale) {
      rr.convergence = {true, "cost_change_below_eps", rr.iterations};
      break;
    }
    v_prev = rr.cost;
  }
  rr.iterations = std::min(rr.iterations, opt.max_iterations);
  if (!rr.convergence.converged) rr.convergence = {false, "iteration_limit", rr.iterations};
  rr.beta_ci = NonlinearStep(P, rr.a, rr.b, rr.lam, true).ci95_half_width;
  rr.l_ci = LinearStep(P, rr.beta, true).ci95_half_width;
  return rr;
}

/// One-step residual A y − B h(u) of a low-order tremor-free fit (a high-order AR part could
/// absorb the tremor); frequencies (Hz) of the `count` largest local maxima of its summed
/// periodogram in the band, largest first.
std::vector<double> PeriodogramPeaks(const Problem& P, const RunResult& rr, double f_lo,
                                     double f_hi, int count) {
  const double T = P.data->sample_period_s;
  std::vector<Eigen::VectorXd> res;
  const int k0 = FirstRow(P.o);
  for (std::size_t t = 0; t < P.data->y.size(); ++t) {
    const Eigen::VectorXd& y = P.data->y[t];
    Eigen::VectorXd e = Eigen::VectorXd::Zero(y.size());
    for (Eigen::Index k = k0; k < y.size(); ++k) {
      double v = y(k);
      for (int i = 1; i <= P.o.poles_l; ++i) v += rr.a(i - 1) * y(k - i);
      for (int j = 0; j <= P.o.zeros_n; ++j) {
        v -= rr.b(j) * PolyValue(rr.beta, P.s[t](k - P.o.delay_m - j));
      }
      e(k) = std::isfinite(v) ? v : 0.0;  // a residual touching a missing sample: none
    }
    res.push_back(e);
  }
  // O(N log N) zoomed DFT (identification/spectrum.h) on the 4x zero-padded grid.
  const Periodogram spectrum = SummedPeriodogram(res, T, f_lo, f_hi);
  const std::vector<double>& f_grid = spectrum.f_hz;
  const std::vector<double>& power = spectrum.power;
  std::vector<std::pair<double, double>> peaks;  // (power, f)
  for (std::size_t i = 0; i < power.size(); ++i) {
    const bool left = i == 0 || power[i] >= power[i - 1];
    const bool right = i + 1 == power.size() || power[i] >= power[i + 1];
    if (left && right) peaks.emplace_back(power[i], f_grid[i]);
  }
  std::sort(peaks.rbegin(), peaks.rend());
  std::vector<double> out;
  for (std::size_t i = 0; i < peaks.size() && static_cast<int>(i) < count; ++i) {
    out.push_back(peaks[i].second);
  }
  if (out.empty()) out.push_back(0.5 * (f_lo + f_hi));
  return out;
}

/// The problem of `opt.orders` on `data` without tremor regressors (ω < 0).
Problem MakeProblem(const TremorData& data, const TremorOptions& opt, double u_scale) {
  Problem P;
  P.data = &data;
  P.o = opt.orders;
  P.u_scale = u_scale;
  P.constraint_points = std::max(2, opt.constraint_points);
  P.s_min = INFINITY;
  P.s_max = -INFINITY;
  for (const auto& u : data.u_us) {
    P.s.emplace_back(u / u_scale);
    P.s_min = std::min(P.s_min, P.s.back().minCoeff());
    P.s_max = std::max(P.s_max, P.s.back().maxCoeff());
  }
  P.fixed = BuildFixedRegression(data, P.o, P.s);
  P.SetOmega(-1.0);
  return P;
}

}  // namespace

Eigen::Vector2d CoactivationSplit(const Coactivation& c, double u_us) {
  return u_us >= 0.0 ? Eigen::Vector2d(u_us + c.c_agonist_us, c.c_antagonist_us)
                     : Eigen::Vector2d(c.c_agonist_us, c.c_antagonist_us - u_us);
}

double CoactivationCombine(const Coactivation& c, double u_agonist_us, double u_antagonist_us) {
  return (u_agonist_us - c.c_agonist_us) - (u_antagonist_us - c.c_antagonist_us);
}

double TremorRecruitment(const TremorModel& m, double u_us) {
  return PolyValue(m.beta, u_us / m.u_scale_us);
}

double TremorRecruitmentSlope(const TremorModel& m, double u_us) {
  return SlopeRow(static_cast<int>(m.beta.size()) - 1, u_us / m.u_scale_us).dot(m.beta) /
         m.u_scale_us;
}

double MinimumRecruitmentSlope(const Eigen::VectorXd& beta, double s_min, double s_max) {
  return SlopeMinimum(beta, s_min, s_max).first;
}

Eigen::VectorXd SimulateTremorArx(const TremorModel& m, const Eigen::VectorXd& u_us,
                                  const Eigen::VectorXd& y_init) {
  const TremorOrders& o = m.orders;
  const int k0 = FirstRow(o);
  const Eigen::Index N = u_us.size();
  if (y_init.size() < std::min<Eigen::Index>(k0, N)) {
    throw std::invalid_argument("SimulateTremorArx: need the first max(l_P, m_P + n_P) samples");
  }
  Eigen::VectorXd h(N), y(N);
  for (Eigen::Index k = 0; k < N; ++k) h(k) = TremorRecruitment(m, u_us(k));
  const double w = 2.0 * kPi * m.tremor_hz * m.sample_period_s;
  for (Eigen::Index k = 0; k < N; ++k) {
    if (k < k0) {
      y(k) = y_init(k);
      continue;
    }
    double v = m.lambda1 * std::cos(w * k) + m.lambda2 * std::sin(w * k);
    for (int i = 1; i <= o.poles_l; ++i) v -= m.a(i - 1) * y(k - i);
    for (int j = 0; j <= o.zeros_n; ++j) v += m.b(j) * h(k - o.delay_m - j);
    y(k) = v;
  }
  return y;
}

TremorFit FitTremorArx(const TremorData& data, const TremorOptions& options, double u_scale_us) {
  const auto t0 = Clock::now();
  const TremorOrders& o = options.orders;
  if (o.poles_l < 1 || o.zeros_n < 0 || o.delay_m < 0 || o.poly_degree < 1) {
    throw std::invalid_argument("tremor orders: need l_P >= 1, n_P >= 0, m_P >= 0, degree >= 1");
  }
  if (!(u_scale_us > 0.0) || data.y.empty()) {
    throw std::invalid_argument("FitTremorArx: need data and u_scale > 0");
  }
  Problem P = MakeProblem(data, options, u_scale_us);
  const double T = data.sample_period_s;
  double f_hz = options.tremor_hz;
  if (f_hz <= 0.0) {
    TremorOptions low_options = options;  // order ≤ 2, so the AR part cannot absorb the tremor
    low_options.orders.poles_l = std::min(2, o.poles_l);
    low_options.orders.zeros_n = std::min(1, o.zeros_n);
    const Problem low = MakeProblem(data, low_options, u_scale_us);
    const RunResult free = Algorithm1(low, options);
    const auto cost_at = [&](double f) {
      P.SetOmega(2.0 * kPi * f * T);
      return Algorithm1(P, options).cost;
    };
    // The 3 largest periodogram peaks compete on V_N of the full fit (input harmonics and noise
    // can out-shine the tremor in the band).
    double peak = 0.0, best = INFINITY;
    for (double f : PeriodogramPeaks(low, free, options.tremor_min_hz, options.tremor_max_hz, 3)) {
      const double v = cost_at(f);
      if (v < best) {
        best = v;
        peak = f;
      }
    }
    Eigen::Index n_max = 0;
    for (const auto& y : data.y) n_max = std::max(n_max, y.size());
    const double bin = 1.0 / (static_cast<double>(n_max) * T);
    // Golden-section refinement of V_N over one periodogram bin either side.
    double lo = std::max(1e-6, peak - bin), hi = peak + bin;
    const double g = 0.5 * (std::sqrt(5.0) - 1.0);
    double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
    double c1 = cost_at(x1), c2 = cost_at(x2);
    while (hi - lo > 1e-10 * peak) {
      if (c1 < c2) {
        hi = x2;
        x2 = x1;
        c2 = c1;
        x1 = hi - g * (hi - lo);
        c1 = cost_at(x1);
      } else {
        lo = x1;
        x1 = x2;
        c1 = c2;
        x2 = lo + g * (hi - lo);
        c2 = cost_at(x2);
      }
    }
    f_hz = 0.5 * (lo + hi);
  }
  P.SetOmega(2.0 * kPi * f_hz * T);
  const RunResult rr = Algorithm1(P, options);
  TremorFit fit;
  TremorModel& m = fit.model;
  m.orders = o;
  m.u_scale_us = u_scale_us;
  m.beta = rr.beta;
  m.a = rr.a;
  m.b = rr.b;
  m.lambda1 = rr.lam(0);
  m.lambda2 = rr.lam(1);
  m.tremor_hz = f_hz;
  m.sample_period_s = T;
  m.s_min = P.s_min;
  m.s_max = P.s_max;
  fit.iterations = rr.iterations;
  fit.convergence = rr.convergence;
  fit.cost_history = rr.history;
  fit.beta_ci95 = rr.beta_ci;
  fit.theta_l_ci95 = rr.l_ci;
  fit.wall_s = Seconds(t0);
  return fit;
}

namespace {

/// The measured output as the simulation's initial samples: a missing (NaN) one among the first
/// max(l_P, m_P + n_P) takes the next measured value.
Eigen::VectorXd InitialSamples(const TremorModel& m, const Eigen::VectorXd& y) {
  Eigen::VectorXd init = y;
  const Eigen::Index k0 = std::min<Eigen::Index>(FirstRow(m.orders), y.size());
  for (Eigen::Index k = k0 - 1; k >= 0; --k) {
    if (std::isfinite(init(k))) continue;
    Eigen::Index next = k + 1;
    while (next < y.size() && !std::isfinite(init(next))) ++next;
    init(k) = next < y.size() ? init(next) : 0.0;
  }
  return init;
}

/// The simulated output ŷ and the Best Fit over the measured samples.
double SimBestFit(const TremorModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y) {
  const Eigen::VectorXd yh = SimulateTremorArx(m, u, InitialSamples(m, y));
  std::vector<double> yv(y.data(), y.data() + y.size()), yhv(yh.data(), yh.data() + yh.size());
  KeepMeasuredPairs(&yv, &yhv);
  return BestFitPercent(yv, yhv);
}

}  // namespace

std::complex<double> TremorArxResponse(const Eigen::VectorXd& a, const Eigen::VectorXd& b,
                                       int delay_m, double sample_period_s, double f_hz) {
  if (!(sample_period_s > 0.0) || b.size() == 0 || delay_m < 0) {
    throw std::invalid_argument("TremorArxResponse: needs T > 0, b_0 and m_P >= 0");
  }
  const std::complex<double> zinv = std::polar(1.0, -2.0 * kPi * f_hz * sample_period_s);
  std::complex<double> num = 0.0, den = 1.0, p = 1.0;
  for (Eigen::Index j = 0; j < b.size(); ++j, p *= zinv) num += b(j) * p;
  p = zinv;
  for (Eigen::Index i = 0; i < a.size(); ++i, p *= zinv) den += a(i) * p;
  return std::pow(zinv, delay_m) * num / den;
}

std::vector<TremorSweepEntry> SweepTremorOrders(const TremorData& data, const TremorOptions& base,
                                                const std::vector<int>& poles,
                                                const std::vector<int>& zeros,
                                                const std::vector<int>& delays, double u_scale_us,
                                                const ProgressFn& progress) {
  std::vector<TremorSweepEntry> out;
  const auto total = static_cast<double>(poles.size() * zeros.size() * delays.size());
  const std::size_t T = data.y.size();
  for (int l : poles) {
    for (int n : zeros) {
      for (int d : delays) {
        TremorOptions opt = base;
        opt.orders.poles_l = l;
        opt.orders.zeros_n = n;
        opt.orders.delay_m = d;
        TremorSweepEntry e;
        e.orders = opt.orders;
        for (std::size_t i = 0; i < T; ++i) {
          TremorData one;
          one.sample_period_s = data.sample_period_s;
          one.u_us = {data.u_us[i]};
          one.y = {data.y[i]};
          const TremorFit fit = FitTremorArx(one, opt, u_scale_us);
          if (i == 0) {
            e.first_a = fit.model.a;
            e.first_b = fit.model.b;
          }
          const std::size_t j = (i + 1) % T;
          e.validation_best_fit += SimBestFit(fit.model, data.u_us[i], data.y[i]) / T;
          e.cross_validation_best_fit += SimBestFit(fit.model, data.u_us[j], data.y[j]) / T;
        }
        out.push_back(e);
        if (progress) {
          progress(static_cast<double>(out.size()) / total, "order sweep l_P=" + std::to_string(l) +
                                                                " n_P=" + std::to_string(n) +
                                                                " m_P=" + std::to_string(d));
        }
      }
    }
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// CLI adapter.
namespace {

struct TremorColumns {
  std::string agonist, antagonist, output;
};

TremorColumns PickTremorColumns(const Trial& t, const std::string& label) {
  const auto us = t.NamesWithPrefix("u.");
  const auto qs = t.NamesWithPrefix("q.");
  if (us.size() != 2) {
    throw std::runtime_error(label +
                             ": tremor-arx needs exactly two u.* columns (agonist, "
                             "antagonist), found " +
                             std::to_string(us.size()));
  }
  if (qs.size() != 1) {
    throw std::runtime_error(label + ": tremor-arx needs exactly one q.* column, found " +
                             std::to_string(qs.size()));
  }
  return {us[0], us[1], qs[0]};
}

/// The training or test trials (`what`) as TremorData: the combined input u of eq. (5) from the
/// co-activation levels `c`, the output with its missing samples (tracker dropouts, NaN; inputs
/// must be complete) counted per trial into `missing`.
TremorData TremorDataOf(const std::vector<Trial>& trials, const TremorColumns& cols,
                        const Coactivation& c, const std::string& what,
                        std::vector<std::size_t>* missing) {
  TremorData d;
  for (std::size_t t = 0; t < trials.size(); ++t) {
    const std::string label = what + " trial " + std::to_string(t);
    const double T = UniformSamplePeriod(trials[t], label);
    if (t == 0) d.sample_period_s = T;
    if (std::abs(T - d.sample_period_s) > 1e-3 * T) {
      throw std::runtime_error(label + ": sample period differs from trial 0");
    }
    const Eigen::MatrixXd x = RequireColumns(trials[t], {cols.agonist, cols.antagonist}, label);
    std::size_t n_missing = 0;
    Eigen::VectorXd y = OutputColumn(trials[t], cols.output, label, &n_missing);
    if (n_missing == static_cast<std::size_t>(y.size())) {
      throw std::runtime_error(label + ": column " + cols.output + " has no measured sample");
    }
    missing->push_back(n_missing);
    Eigen::VectorXd u(x.rows());
    for (Eigen::Index k = 0; k < x.rows(); ++k) u(k) = CoactivationCombine(c, x(k, 0), x(k, 1));
    d.u_us.push_back(u);
    d.y.push_back(std::move(y));
  }
  return d;
}

/// The order sweep of [Copur 2016] (Figs 7–8) as metrics; `opt->orders` set to the entry of best
/// cross-validation Best Fit.
Json SweepOrders(const TremorData& tr, double u_scale, const ProgressFn& progress,
                 TremorOptions* opt) {
  const auto entries =
      SweepTremorOrders(tr, *opt, {2, 4, 8, 12}, {1, 3, 7, 12}, {1}, u_scale, progress);
  Json js = Json::Array();
  double best = -INFINITY;
  for (const auto& e : entries) {
    Json j = Json::Object();
    j.Set("poles_l", e.orders.poles_l);
    j.Set("zeros_n", e.orders.zeros_n);
    j.Set("delay_m", e.orders.delay_m);
    j.Set("validation_best_fit_percent", e.validation_best_fit);
    j.Set("cross_validation_best_fit_percent", e.cross_validation_best_fit);
    // Data set 1's polynomials: the frequency responses compared across orders (paper 001
    // Figs 9–10; `fesim benchmark`'s tremor section).
    const auto array = [](const Eigen::VectorXd& v) {
      Json arr = Json::Array();
      for (Eigen::Index k = 0; k < v.size(); ++k) arr.Push(v(k));
      return arr;
    };
    j.Set("data_set_1_a", array(e.first_a));
    j.Set("data_set_1_b", array(e.first_b));
    js.Push(j);
    if (e.cross_validation_best_fit > best) {
      best = e.cross_validation_best_fit;
      opt->orders = e.orders;
    }
  }
  return js;
}

/// model.yaml of a tremor-arx fit: orders, co-activation levels, h(u), the ARX polynomials and
/// the tremor amplitudes with their 95 % half-widths, and how Algorithm 1 stopped.
std::string TremorModelYaml(const TremorColumns& cols, const Coactivation& c,
                            const TremorFit& fit) {
  const TremorModel& m = fit.model;
  std::string y = "# fesim identify: tremor-arx (paper 001_50576a960b4d02ae eq. 5-21; P(1) = 1)\n";
  y += "method: tremor-arx\ninputs: {agonist: " + cols.agonist +
       ", antagonist: " + cols.antagonist + "}\noutput: " + cols.output + "\n";
  y += YamlParam("sample_time_s", m.sample_period_s, "s", NAN, 0);
  y += "orders: {poles_l: " + std::to_string(m.orders.poles_l) +
       ", zeros_n: " + std::to_string(m.orders.zeros_n) +
       ", delay_m: " + std::to_string(m.orders.delay_m) +
       ", poly_degree: " + std::to_string(m.orders.poly_degree) + "}\n";
  y += YamlParam("c_agonist", c.c_agonist_us, "us", NAN, 0);
  y += YamlParam("c_antagonist", c.c_antagonist_us, "us", NAN, 0);
  y += YamlParam("u_scale", m.u_scale_us, "us", NAN, 0);
  y += YamlParam("tremor_frequency", m.tremor_hz, "Hz", NAN, 0);
  y += "# h(u) = sum_k beta_k (u/u_scale)^k; ci95 conditional on the other block\nbeta:\n";
  for (Eigen::Index k = 0; k < m.beta.size(); ++k) {
    y += YamlParam("beta" + std::to_string(k), m.beta(k), "rad", fit.beta_ci95(k), 2);
  }
  y += "a:\n";
  for (Eigen::Index i = 0; i < m.a.size(); ++i) {
    y += YamlParam("a" + std::to_string(i + 1), m.a(i), "1", fit.theta_l_ci95(i), 2);
  }
  y += "b:\n";
  for (Eigen::Index j = 0; j < m.b.size(); ++j) {
    y += YamlParam("b" + std::to_string(j), m.b(j), "1", fit.theta_l_ci95(m.a.size() + j), 2);
  }
  const Eigen::Index li = m.a.size() + m.b.size();
  y += "# tremor amplitudes of training trial 0 (phase from its first sample)\n";
  y += YamlParam("lambda1", m.lambda1, "rad", fit.theta_l_ci95(li), 0);
  y += YamlParam("lambda2", m.lambda2, "rad", fit.theta_l_ci95(li + 1), 0);
  y += "# how the iterative algorithm stopped\nconvergence: {converged: " +
       std::string(fit.convergence.converged ? "true" : "false") +
       ", stop_reason: " + fit.convergence.stop_reason +
       ", iterations: " + std::to_string(fit.convergence.iterations) + "}\n";
  return y;
}

MethodResult RunTremor(const std::vector<Trial>& train_rows, const std::vector<Trial>& test_rows,
                       const ProgressFn& progress) {
  if (train_rows.empty()) throw std::runtime_error("--train: no trials");
  const TremorColumns cols = PickTremorColumns(train_rows[0], "train trial 0");
  // The rows of the output's sensor (a record may interleave other sensors' rows).
  const std::vector<Trial> train = SensorRows(train_rows, {cols.output});
  const std::vector<Trial> test = SensorRows(test_rows, {cols.output});
  RequireVaryingOutput(train, cols.output, "train");
  MetadataOptions md(train[0].metadata, "tremor");
  TremorOptions opt;
  const bool orders_given = train[0].metadata.count("tremor.poles_l") ||
                            train[0].metadata.count("tremor.zeros_n") ||
                            train[0].metadata.count("tremor.delay_m");
  opt.orders.poles_l = md.Int("poles_l", opt.orders.poles_l, 1, 200);
  opt.orders.zeros_n = md.Int("zeros_n", opt.orders.zeros_n, 0, 200);
  opt.orders.delay_m = md.Int("delay_m", opt.orders.delay_m, 0, 200);
  opt.orders.poly_degree = md.Int("poly_degree", opt.orders.poly_degree, 1, 9);
  opt.tremor_hz = md.Real("hz", 0.0, 0.0, 1e3);
  opt.tolerance_eps = md.Real("eps", opt.tolerance_eps, 1e-300, 1.0);
  const int sweep = md.Int("sweep", orders_given ? 0 : 1, 0, 1);
  // Co-activation levels: per-channel minimum over the training trials unless given.
  Coactivation c{INFINITY, INFINITY};
  std::vector<Eigen::MatrixXd> raw;
  for (std::size_t t = 0; t < train.size(); ++t) {
    const std::string label = "train trial " + std::to_string(t);
    RequireSamples(train[t], 50, label, "ARX orders");
    raw.push_back(RequireColumns(train[t], {cols.agonist, cols.antagonist}, label));
    c.c_agonist_us = std::min(c.c_agonist_us, raw.back().col(0).minCoeff());
    c.c_antagonist_us = std::min(c.c_antagonist_us, raw.back().col(1).minCoeff());
  }
  c.c_agonist_us = md.Real("c_agonist_us", c.c_agonist_us, 0.0, 300.0);
  c.c_antagonist_us = md.Real("c_antagonist_us", c.c_antagonist_us, 0.0, 300.0);
  md.RejectUnknown();
  std::vector<std::size_t> train_missing, test_missing;
  const TremorData tr = TremorDataOf(train, cols, c, "train", &train_missing);
  double u_scale = 0.0;
  for (const auto& u : tr.u_us) u_scale = std::max(u_scale, u.cwiseAbs().maxCoeff());
  if (!(u_scale > 0.0)) throw std::runtime_error("train: combined input u is identically zero");
  Json metrics = Json::Object();
  metrics.Set("method", "tremor-arx");
  // The frequency search ends with the fit at the frequency it found: that is the final fit
  // unless an order sweep follows.
  std::optional<TremorFit> searched;
  if (opt.tremor_hz <= 0.0) {
    if (progress) progress(0.05, "tremor frequency");
    searched = FitTremorArx(tr, opt, u_scale);
    opt.tremor_hz = searched->model.tremor_hz;
  }
  if (sweep && tr.y.size() >= 2) {
    if (progress) progress(0.2, "order sweep");
    const ProgressFn sweep_progress = [&progress](double f, const std::string& stage) {
      if (progress) progress(0.2 + 0.6 * f, stage);
    };
    metrics.Set("order_sweep", SweepOrders(tr, u_scale, sweep_progress, &opt));
    searched.reset();
  }
  if (progress) progress(0.8, "final fit");
  const TremorFit fit = searched ? *std::move(searched) : FitTremorArx(tr, opt, u_scale);
  const TremorModel& m = fit.model;
  MethodResult result;
  result.model_yaml = TremorModelYaml(cols, c, fit);
  if (!fit.convergence.converged) {
    result.warnings.push_back("tremor-arx iterative algorithm: did not converge (" +
                              fit.convergence.stop_reason + " after " +
                              std::to_string(fit.convergence.iterations) + " iterations)");
  }
  const bool has_test = !test.empty();
  if (has_test) PickTremorColumns(test[0], "test trial 0");
  const TremorData ev = has_test ? TremorDataOf(test, cols, c, "test", &test_missing) : tr;
  const std::vector<std::size_t>& ev_missing = has_test ? test_missing : train_missing;
  const std::vector<Trial>& eval = has_test ? test : train;
  Json fits = Json::Array();
  for (std::size_t t = 0; t < ev.y.size(); ++t) {
    const Eigen::VectorXd yh = SimulateTremorArx(m, ev.u_us[t], InitialSamples(m, ev.y[t]));
    std::vector<double> yhv(yh.data(), yh.data() + yh.size());
    // The metrics are over the measured samples; the prediction covers every row.
    std::vector<double> yv(ev.y[t].data(), ev.y[t].data() + ev.y[t].size()), yhm = yhv;
    KeepMeasuredPairs(&yv, &yhm);
    Json f = Json::Object();
    f.Set("trial", static_cast<int>(t));
    f.Set("best_fit_percent", BestFitPercent(yv, yhm));
    f.Set("normalised_error", NormalisedError(yv, yhm));
    f.Set("rms_rad", Rms(yv, yhm));
    f.Set("missing_samples", static_cast<double>(ev_missing[t]));
    fits.Push(f);
    Trial pred;
    pred.metadata["source"] = "fesim identify --method tremor-arx";
    pred.time = eval[t].time;
    pred.AddColumn(cols.agonist, eval[t].Column(cols.agonist));
    pred.AddColumn(cols.antagonist, eval[t].Column(cols.antagonist));
    pred.AddColumn(cols.output, std::move(yhv));
    result.predictions.push_back(std::move(pred));
  }
  metrics.Set(has_test ? "test" : "train", fits);
  std::size_t n_train_missing = 0;
  for (std::size_t n : train_missing) n_train_missing += n;
  metrics.Set("train_missing_samples", static_cast<double>(n_train_missing));
  metrics.Set("prediction", "simulation from the first max(l_P, m_P + n_P) measured samples");
  metrics.Set("iterations", fit.iterations);
  metrics.Set("converged", fit.convergence.converged);
  metrics.Set("stop_reason", fit.convergence.stop_reason);
  metrics.Set("cost_history", fit.cost_history);
  metrics.Set("wall_s", fit.wall_s);
  metrics.Set("min_recruitment_slope_rad_per_us",
              MinimumRecruitmentSlope(m.beta, m.s_min, m.s_max) / m.u_scale_us);
  result.metrics = metrics;
  if (progress) progress(1.0, "done");
  return result;
}

}  // namespace

MethodEntry TremorArxMethod() {
  return {"tremor-arx",
          "tremor wrist model: co-activation, monotone polynomial IRC, ARX + tremor, paper 001",
          RunTremor};
}

}  // namespace fesim::identification
