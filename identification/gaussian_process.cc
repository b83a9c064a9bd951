#include "identification/gaussian_process.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace fesim::identification {
namespace {

constexpr double kLog2Pi = 1.8378770664093454836;
constexpr double kArmijo = 1e-4;
constexpr double kMaxLogStep = 2.0;  // largest change of any log hyper-parameter per iteration
constexpr double kGradTol = 1e-6;
constexpr double kRelFTol = 1e-12;

void CheckInputs(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, const SeArdHyperParams& hp) {
  if (X.rows() != y.size()) {
    throw std::invalid_argument("GP: X has " + std::to_string(X.rows()) + " rows, y has " +
                                std::to_string(y.size()));
  }
  if (hp.length_scales.size() != X.cols()) {
    throw std::invalid_argument("GP: " + std::to_string(hp.length_scales.size()) +
                                " length scales for " + std::to_string(X.cols()) + " inputs");
  }
}

Eigen::MatrixXd NoisyKernel(const SeArdHyperParams& hp, const Eigen::MatrixXd& X) {
  Eigen::MatrixXd K = SeArdKernelMatrix(hp, X, X);
  K.diagonal().array() += hp.noise_sd * hp.noise_sd;
  return K;
}

/// K(Xs, X) v computed in row blocks so that no m × n temporary is formed for large m.
Eigen::VectorXd ChunkedKernelTimes(const SeArdHyperParams& hp, const Eigen::MatrixXd& Xs,
                                   const Eigen::MatrixXd& X, const Eigen::VectorXd& v) {
  constexpr Eigen::Index kBlock = 256;
  Eigen::VectorXd out(Xs.rows());
  for (Eigen::Index r = 0; r < Xs.rows(); r += kBlock) {
    const Eigen::Index m = std::min(kBlock, Xs.rows() - r);
    out.segment(r, m) = SeArdKernelMatrix(hp, Xs.middleRows(r, m), X) * v;
  }
  return out;
}

}  // namespace

Eigen::VectorXd ToLogVector(const SeArdHyperParams& hp) {
  const auto d = hp.length_scales.size();
  Eigen::VectorXd t(d + 2);
  t.head(d) = hp.length_scales.array().log().matrix();
  t(d) = std::log(hp.signal_sd);
  t(d + 1) = std::log(hp.noise_sd);
  return t;
}

SeArdHyperParams FromLogVector(const Eigen::VectorXd& theta) {
  const auto d = theta.size() - 2;
  SeArdHyperParams hp;
  hp.length_scales = theta.head(d).array().exp().matrix();
  hp.signal_sd = std::exp(theta(d));
  hp.noise_sd = std::exp(theta(d + 1));
  return hp;
}

double SeArdKernel(const SeArdHyperParams& hp, const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const double r2 = ((a - b).array() / hp.length_scales.array()).square().sum();
  return hp.signal_sd * hp.signal_sd * std::exp(-0.5 * r2);
}

Eigen::MatrixXd SeArdKernelMatrix(const SeArdHyperParams& hp, const Eigen::MatrixXd& A,
                                  const Eigen::MatrixXd& B) {
  const Eigen::VectorXd inv_l = hp.length_scales.cwiseInverse();
  const Eigen::MatrixXd As = A * inv_l.asDiagonal();
  const Eigen::MatrixXd Bs = B * inv_l.asDiagonal();
  const Eigen::VectorXd a2 = As.rowwise().squaredNorm();
  const Eigen::VectorXd b2 = Bs.rowwise().squaredNorm();
  Eigen::MatrixXd r2 = -2.0 * As * Bs.transpose();
  r2.colwise() += a2;
  r2.rowwise() += b2.transpose();
  const double s2 = hp.signal_sd * hp.signal_sd;
  return (s2 * (-0.5 * r2.array().max(0.0)).exp()).matrix();
}

LogMarginalLikelihood GpLogMarginalLikelihood(const SeArdHyperParams& hp, const Eigen::MatrixXd& X,
                                              const Eigen::VectorXd& y, const Eigen::VectorXd& mean,
                                              const Eigen::MatrixXd& extra_cov) {
  CheckInputs(X, y, hp);
  const Eigen::Index n = X.rows(), D = X.cols();
  const Eigen::MatrixXd K = SeArdKernelMatrix(hp, X, X);
  Eigen::MatrixXd S = K;
  S.diagonal().array() += hp.noise_sd * hp.noise_sd;
  if (extra_cov.size() > 0) S += extra_cov;
  const Eigen::VectorXd r = mean.size() > 0 ? Eigen::VectorXd(y - mean) : y;
  LogMarginalLikelihood out;
  out.gradient = Eigen::VectorXd::Zero(D + 2);
  const Eigen::LLT<Eigen::MatrixXd> llt(S);
  if (llt.info() != Eigen::Success) {
    out.value = -std::numeric_limits<double>::infinity();
    return out;
  }
  const Eigen::VectorXd alpha = llt.solve(r);
  const Eigen::MatrixXd L = llt.matrixL();
  out.value = -0.5 * r.dot(alpha) - L.diagonal().array().log().sum() - 0.5 * n * kLog2Pi;
  // W = α αᵀ − Σ⁻¹;  ∂L/∂θ = ½ Σ_ij W_ij ∂Σ_ij/∂θ.
  Eigen::MatrixXd W = -llt.solve(Eigen::MatrixXd::Identity(n, n));
  W.noalias() += alpha * alpha.transpose();
  const Eigen::MatrixXd M = W.cwiseProduct(K);
  const Eigen::VectorXd m1 = M.rowwise().sum();
  for (Eigen::Index d = 0; d < D; ++d) {
    const double l2 = hp.length_scales(d) * hp.length_scales(d);
    const Eigen::VectorXd x = X.col(d);
    // Σ_ij M_ij (x_i − x_j)² = 2 Σ_i x_i² (M1)_i − 2 xᵀ M x   (M symmetric)
    const double s = 2.0 * x.cwiseProduct(x).dot(m1) - 2.0 * x.dot(M * x);
    out.gradient(d) = 0.5 * s / l2;
  }
  out.gradient(D) = M.sum();                                             // ∂K/∂log σ_f = 2K
  out.gradient(D + 1) = hp.noise_sd * hp.noise_sd * W.diagonal().sum();  // ∂Σ/∂log σ_n = 2σ_n² I
  return out;
}

SeArdHyperParams FitHyperParameters(const SeArdHyperParams& initial, const Eigen::MatrixXd& X,
                                    const Eigen::VectorXd& y, const GpHyperFitOptions& options,
                                    const Eigen::VectorXd& mean, const Eigen::MatrixXd& extra_cov,
                                    int* iterations, Convergence* convergence) {
  CheckInputs(X, y, initial);
  const Eigen::Index D = X.cols(), P = D + 2;
  Eigen::VectorXd mask = Eigen::VectorXd::Zero(P);
  if (options.fit_length_scales) mask.head(D).setOnes();
  if (options.fit_signal) mask(D) = 1.0;
  if (options.fit_noise) mask(D + 1) = 1.0;
  const double log_min_noise = std::log(options.min_noise_sd);
  auto clamp = [&](Eigen::VectorXd t) {
    t(D + 1) = std::max(t(D + 1), log_min_noise);
    return t;
  };
  // Minimise f = −L over the masked θ.
  auto eval = [&](const Eigen::VectorXd& t, Eigen::VectorXd* grad) {
    const auto lml = GpLogMarginalLikelihood(FromLogVector(t), X, y, mean, extra_cov);
    *grad = -lml.gradient.cwiseProduct(mask);
    return -lml.value;
  };
  Eigen::VectorXd theta = clamp(ToLogVector(initial));
  Eigen::VectorXd g;
  double f = eval(theta, &g);
  if (!std::isfinite(f)) throw std::runtime_error("GP: kernel matrix not positive definite");
  Eigen::MatrixXd H = Eigen::MatrixXd::Identity(P, P);
  int it = 0;
  std::string stop_reason = "iteration_limit";
  bool converged = false;
  for (; it < options.max_iterations; ++it) {
    if (g.lpNorm<Eigen::Infinity>() < kGradTol) {
      stop_reason = "gradient_below_tolerance";
      converged = true;
      break;
    }
    Eigen::VectorXd p = -(H * g).cwiseProduct(mask);
    if (g.dot(p) >= 0.0) {  // not a descent direction: restart with steepest descent
      H.setIdentity();
      p = -g;
    }
    const double pmax = p.lpNorm<Eigen::Infinity>();
    if (pmax > kMaxLogStep) p *= kMaxLogStep / pmax;
    double step = 1.0, f_new = f;
    Eigen::VectorXd theta_new, g_new;
    bool ok = false;
    for (int ls = 0; ls < 40; ++ls) {
      theta_new = clamp(theta + step * p);
      f_new = eval(theta_new, &g_new);
      if (std::isfinite(f_new) && f_new <= f + kArmijo * step * g.dot(p)) {
        ok = true;
        break;
      }
      step *= 0.5;
    }
    if (!ok) {
      stop_reason = "line_search_failed";
      break;
    }
    const Eigen::VectorXd s = theta_new - theta, yk = g_new - g;
    const double sy = s.dot(yk);
    const double f_old = f;
    theta = theta_new;
    f = f_new;
    g = g_new;
    if (sy > 1e-12) {  // BFGS update of the inverse Hessian
      const double rho = 1.0 / sy;
      const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(P, P);
      H = (I - rho * s * yk.transpose()) * H * (I - rho * yk * s.transpose()) +
          rho * s * s.transpose();
    }
    if (std::abs(f_old - f) <= kRelFTol * std::max(1.0, std::abs(f))) {
      stop_reason = "relative_objective_change_below_tolerance";
      converged = true;
      break;
    }
  }
  if (iterations != nullptr) *iterations = it;
  if (convergence != nullptr) *convergence = {converged, stop_reason, it};
  return FromLogVector(theta);
}

GaussianProcess::GaussianProcess(const SeArdHyperParams& hp, const Eigen::MatrixXd& X,
                                 const Eigen::VectorXd& y)
    : hp_(hp), X_(X) {
  CheckInputs(X, y, hp);
  llt_.compute(NoisyKernel(hp, X));
  if (llt_.info() != Eigen::Success) throw std::runtime_error("GP: K_y not positive definite");
  alpha_ = llt_.solve(y);
}

GpPrediction GaussianProcess::Predict(const Eigen::VectorXd& x) const {
  const Eigen::VectorXd ks = SeArdKernelMatrix(hp_, X_, x.transpose());
  GpPrediction p;
  p.mean = ks.dot(alpha_);
  const Eigen::VectorXd v = llt_.matrixL().solve(ks);
  p.variance = std::max(hp_.signal_sd * hp_.signal_sd - v.squaredNorm(), 0.0);
  return p;
}

Eigen::VectorXd GaussianProcess::PredictMean(const Eigen::MatrixXd& Xs) const {
  return ChunkedKernelTimes(hp_, Xs, X_, alpha_);
}

Eigen::VectorXd GaussianProcess::LooResiduals() const {
  const Eigen::MatrixXd Kinv = llt_.solve(Eigen::MatrixXd::Identity(X_.rows(), X_.rows()));
  return alpha_.cwiseQuotient(Kinv.diagonal());
}

Eigen::VectorXd GaussianProcess::LooVariances() const {
  const Eigen::MatrixXd Kinv = llt_.solve(Eigen::MatrixXd::Identity(X_.rows(), X_.rows()));
  return Kinv.diagonal().cwiseInverse();
}

SemiparametricGp::SemiparametricGp(const SeArdHyperParams& hp, const Eigen::MatrixXd& X,
                                   const Eigen::VectorXd& y, const Eigen::MatrixXd& Phi,
                                   const Eigen::VectorXd& b, const Eigen::MatrixXd& B)
    : hp_(hp), X_(X), Phi_(Phi) {
  CheckInputs(X, y, hp);
  if (Phi.rows() != X.rows() || b.size() != Phi.cols() || B.rows() != b.size() ||
      B.cols() != b.size()) {
    throw std::invalid_argument("semiparametric GP: basis sizes do not match");
  }
  llt_.compute(NoisyKernel(hp, X));
  if (llt_.info() != Eigen::Success) throw std::runtime_error("GP: K_y not positive definite");
  const Eigen::LDLT<Eigen::MatrixXd> b_ldlt(B);
  const Eigen::MatrixXd Binv = b_ldlt.solve(Eigen::MatrixXd::Identity(b.size(), b.size()));
  const Eigen::MatrixXd KinvPhi = llt_.solve(Phi);
  const Eigen::MatrixXd A = Binv + Phi.transpose() * KinvPhi;
  a_ldlt_.compute(A);
  beta_bar_ = a_ldlt_.solve(KinvPhi.transpose() * y + Binv * b);
  alpha_ = llt_.solve(y - Phi * beta_bar_);
}

GpPrediction SemiparametricGp::Predict(const Eigen::VectorXd& x, const Eigen::VectorXd& h) const {
  const Eigen::VectorXd ks = SeArdKernelMatrix(hp_, X_, x.transpose());
  GpPrediction p;
  p.mean = h.dot(beta_bar_) + ks.dot(alpha_);
  const Eigen::VectorXd Kinv_ks = llt_.solve(ks);
  const Eigen::VectorXd r = h - Phi_.transpose() * Kinv_ks;
  p.variance =
      std::max(hp_.signal_sd * hp_.signal_sd - ks.dot(Kinv_ks), 0.0) + r.dot(a_ldlt_.solve(r));
  return p;
}

Eigen::VectorXd SemiparametricGp::PredictMean(const Eigen::MatrixXd& Xs,
                                              const Eigen::MatrixXd& Hs) const {
  return Hs * beta_bar_ + ChunkedKernelTimes(hp_, Xs, X_, alpha_);
}

}  // namespace fesim::identification
