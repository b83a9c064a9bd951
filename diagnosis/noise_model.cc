#include "diagnosis/noise_model.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace fesim::diagnosis {
namespace {

/// Row ranges [begin, end) of each run of `layout` whose rows belong to output o (o < 0: all).
std::vector<std::pair<long, long>> Runs(const RowLayout& layout, int o) {
  std::vector<std::pair<long, long>> out;
  const long n = layout.rows();
  long begin = 0;
  for (long i = 1; i <= n; ++i) {
    if (i == n || layout.run[i] != layout.run[i - 1]) {
      if (o < 0 || layout.output[begin] == o) out.emplace_back(begin, i);
      begin = i;
    }
  }
  return out;
}

/// Yule–Walker AR fit of the series `r` over `runs` (mean removed), order by BIC, by the
/// Levinson–Durbin recursion (stable by construction: the biased autocovariances are positive
/// definite).
ArModel FitAr(const Eigen::VectorXd& r, const std::vector<std::pair<long, long>>& runs,
              int max_order) {
  ArModel m;
  long n = 0;
  double sum = 0.0;
  for (const auto& [b, e] : runs) {
    n += e - b;
    sum += r.segment(b, e - b).sum();
  }
  if (n < 2) return m;
  const double mean = sum / static_cast<double>(n);
  const int pmax = static_cast<int>(std::min<long>(max_order, n / 10));
  std::vector<double> gamma(pmax + 1, 0.0);
  for (const auto& [b, e] : runs) {
    for (long i = b; i < e; ++i) {
      const double x = r(i) - mean;
      for (int k = 0; k <= pmax && i + k < e; ++k) gamma[k] += x * (r(i + k) - mean);
    }
  }
  for (double& g : gamma) g /= static_cast<double>(n);
  m.variance = gamma[0];
  if (!(gamma[0] > 0.0)) return m;
  // Levinson–Durbin: phi holds the order-p coefficients, v the innovation variance.
  std::vector<double> phi, best_phi;
  double v = gamma[0], best_v = v;
  double best_bic = static_cast<double>(n) * std::log(v);
  for (int p = 1; p <= pmax; ++p) {
    double acc = gamma[p];
    for (int k = 1; k < p; ++k) acc -= phi[k - 1] * gamma[p - k];
    const double kappa = acc / v;
    std::vector<double> next(p);
    for (int k = 1; k < p; ++k) next[k - 1] = phi[k - 1] - kappa * phi[p - k - 1];
    next[p - 1] = kappa;
    phi = next;
    v *= (1.0 - kappa * kappa);
    if (!(v > 0.0)) break;
    const double bic = static_cast<double>(n) * std::log(v) + p * std::log(static_cast<double>(n));
    if (bic < best_bic) {
      best_bic = bic;
      best_phi = phi;
      best_v = v;
    }
  }
  m.a = Eigen::Map<const Eigen::VectorXd>(best_phi.data(),
                                          static_cast<Eigen::Index>(best_phi.size()));
  m.innovation_var = best_v;
  return m;
}

/// σ_e² ‖A⁻ᵀ D‖² per run (A of `m`), summed into `out` (D rows [b, e)).
void AddCovarianceForm(const ArModel& m, const Eigen::MatrixXd& d, long b, long e,
                       Eigen::MatrixXd* out) {
  const long len = e - b;
  const auto p = m.a.size();
  Eigen::MatrixXd z = d.middleRows(b, len);
  for (long i = len - 1; i >= 0; --i) {
    for (Eigen::Index k = 1; k <= p && i + k < len; ++k) z.row(i) += m.a(k - 1) * z.row(i + k);
  }
  *out += m.innovation_var * z.transpose() * z;
}

Eigen::MatrixXd ProjectOut(const Eigen::MatrixXd& j, const Eigen::MatrixXd& d) {
  if (j.cols() == 0) return d;
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(j);
  return d - j * qr.solve(d);
}

}  // namespace

RowLayout LayoutOf(const DataView& view) {
  RowLayout layout;
  layout.outputs = static_cast<int>(view.outputs.size());
  int run = -1;
  for (std::size_t t = 0; t < view.trials.size(); ++t) {
    for (std::size_t o = 0; o < view.outputs.size(); ++o) {
      const auto& y = view.trials[t].Column(view.outputs[o]);
      long previous = -2;
      for (std::size_t i = 0; i < y.size(); ++i) {
        if (!(view.use[t][i] && std::isfinite(y[i]))) continue;
        if (static_cast<long>(i) != previous + 1) ++run;
        previous = static_cast<long>(i);
        layout.output.push_back(static_cast<int>(o));
        layout.run.push_back(run);
      }
    }
  }
  return layout;
}

NoiseModel FitNoiseModel(const RowLayout& layout, const Eigen::VectorXd& r, int max_order) {
  if (r.size() != layout.rows()) {
    throw std::invalid_argument("FitNoiseModel: " + std::to_string(r.size()) + " residuals for " +
                                std::to_string(layout.rows()) + " rows");
  }
  NoiseModel m;
  for (int o = 0; o < layout.outputs; ++o)
    m.outputs.push_back(FitAr(r, Runs(layout, o), max_order));
  return m;
}

Eigen::MatrixXd CovarianceForm(const NoiseModel& noise, const RowLayout& layout,
                               const Eigen::MatrixXd& d) {
  if (d.rows() != layout.rows()) throw std::invalid_argument("CovarianceForm: row count differs");
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(d.cols(), d.cols());
  for (int o = 0; o < layout.outputs; ++o) {
    for (const auto& [b, e] : Runs(layout, o)) AddCovarianceForm(noise.outputs[o], d, b, e, &out);
  }
  return out;
}

ScoreTest RobustScoreTest(const RowLayout& layout, const Eigen::VectorXd& r,
                          const Eigen::MatrixXd& d, const Eigen::MatrixXd& j,
                          const std::vector<bool>& one_sided) {
  if (d.rows() != r.size() || (j.cols() > 0 && j.rows() != r.size()) ||
      static_cast<Eigen::Index>(one_sided.size()) != d.cols()) {
    throw std::invalid_argument("RobustScoreTest: sizes differ");
  }
  const Eigen::MatrixXd dt = ProjectOut(j, d);
  Eigen::MatrixXd jd(r.size(), j.cols() + d.cols());
  jd << j, d;
  const NoiseModel noise = FitNoiseModel(layout, ProjectOut(jd, r));
  const double white =
      ProjectOut(jd, r).squaredNorm() / static_cast<double>(std::max<long>(1, r.size()));
  ScoreTest out;
  out.theta = Eigen::VectorXd::Zero(d.cols());
  std::vector<int> keep(d.cols());
  for (int k = 0; k < static_cast<int>(d.cols()); ++k) keep[k] = k;
  while (!keep.empty()) {
    Eigen::MatrixXd kd(dt.rows(), static_cast<Eigen::Index>(keep.size()));
    for (std::size_t k = 0; k < keep.size(); ++k)
      kd.col(static_cast<Eigen::Index>(k)) = dt.col(keep[k]);
    const Eigen::MatrixXd g2 = kd.transpose() * kd;
    const Eigen::VectorXd g = kd.transpose() * r;
    const Eigen::VectorXd theta = -g2.ldlt().solve(g);
    int worst = -1;
    for (std::size_t k = 0; k < keep.size(); ++k) {
      const auto kk = static_cast<Eigen::Index>(k);
      if (one_sided[keep[k]] && theta(kk) < 0.0 && (worst < 0 || theta(kk) < theta(worst))) {
        worst = static_cast<int>(k);
      }
    }
    if (worst >= 0) {
      keep.erase(keep.begin() + worst);
      continue;
    }
    const Eigen::MatrixXd v = CovarianceForm(noise, layout, kd);
    const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(v);
    out.statistic = std::max(0.0, g.dot(cod.solve(g)));
    out.dof = static_cast<int>(keep.size());
    for (std::size_t k = 0; k < keep.size(); ++k)
      out.theta(keep[k]) = theta(static_cast<Eigen::Index>(k));
    const double along = g2.trace() > 0.0 ? v.trace() / g2.trace() : 0.0;
    out.variance_inflation = white > 0.0 ? along / white : 1.0;
    break;
  }
  return out;
}

double RobustLikelihoodRatio(const RowLayout& layout, const Eigen::VectorXd& r0,
                             const Eigen::VectorXd& r1) {
  if (r0.size() != r1.size() || r0.size() != layout.rows()) {
    throw std::invalid_argument("RobustLikelihoodRatio: sizes differ");
  }
  const double drop = r0.squaredNorm() - r1.squaredNorm();
  const Eigen::VectorXd d = r0 - r1;
  if (!(drop > 0.0) || !(d.squaredNorm() > 0.0)) return 0.0;
  const NoiseModel noise = FitNoiseModel(layout, r1);
  const double sigma2 = CovarianceForm(noise, layout, d)(0, 0) / d.squaredNorm();
  return sigma2 > 0.0 ? drop / sigma2 : 0.0;
}

double DieboldMariano(const RowLayout& layout, const Eigen::VectorXd& r0,
                      const Eigen::VectorXd& r1) {
  if (r0.size() != r1.size() || r0.size() != layout.rows()) {
    throw std::invalid_argument("DieboldMariano: sizes differ");
  }
  const long n = r0.size();
  if (n < 2) return 0.0;
  const Eigen::VectorXd l = r0.array().square() - r1.array().square();
  const double mean = l.mean();
  const ArModel ar = FitAr(l, Runs(layout, -1), kMaxNoiseOrder);
  const double sum_a = ar.a.size() ? ar.a.sum() : 0.0;
  const double lrv = ar.innovation_var / ((1.0 - sum_a) * (1.0 - sum_a));
  if (!(lrv > 0.0)) return mean > 0.0 ? INFINITY : 0.0;
  return mean / std::sqrt(lrv / static_cast<double>(n));
}

double NormalSurvival(double z) { return 0.5 * std::erfc(z / std::sqrt(2.0)); }

}  // namespace fesim::diagnosis
