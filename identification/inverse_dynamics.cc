#include "identification/inverse_dynamics.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <stdexcept>

#include "identification/method_support.h"
#include "identification/metrics.h"

namespace fesim::identification {
namespace {

constexpr double kZ95 = 1.959963984540054;
constexpr double kMinNoiseFraction = 1e-4;  // σ_n ≥ this × std(τ)

std::vector<double> CheckedColumn(const Trial& trial, const std::string& name) {
  if (!trial.Has(name)) throw std::runtime_error("reaching trial: column " + name + " missing");
  const auto& c = trial.Column(name);
  for (double v : c) {
    if (std::isnan(v)) throw std::runtime_error("reaching trial: column " + name + ": NaN sample");
  }
  return c;
}

std::vector<double> Differentiate(const std::vector<double>& t, const std::vector<double>& v) {
  const std::size_t n = v.size();
  std::vector<double> d(n, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t lo = k == 0 ? 0 : k - 1, hi = k + 1 == n ? k : k + 1;
    d[k] = (v[hi] - v[lo]) / (t[hi] - t[lo]);
  }
  return d;
}

double StdDev(const Eigen::VectorXd& v) {
  if (v.size() < 2) return 0.0;
  return std::sqrt((v.array() - v.mean()).square().sum() / static_cast<double>(v.size() - 1));
}

std::vector<Eigen::Index> EvenSubsample(Eigen::Index n, std::size_t max_points) {
  std::vector<Eigen::Index> idx;
  const auto m = std::min<Eigen::Index>(n, static_cast<Eigen::Index>(max_points));
  for (Eigen::Index i = 0; i < m; ++i) idx.push_back(m == n ? i : (i * n) / m);
  return idx;
}

Eigen::MatrixXd Rows(const Eigen::MatrixXd& A, const std::vector<Eigen::Index>& idx) {
  Eigen::MatrixXd out(static_cast<Eigen::Index>(idx.size()), A.cols());
  for (std::size_t i = 0; i < idx.size(); ++i)
    out.row(static_cast<Eigen::Index>(i)) = A.row(idx[i]);
  return out;
}

Eigen::MatrixXd BasisMatrix(const Eigen::MatrixXd& X, std::size_t j, std::size_t J) {
  Eigen::MatrixXd Phi(X.rows(), 3);
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    Phi.row(i) = JointBasis(X(i, j), X(i, J + j)).transpose();
  }
  return Phi;
}

const char* KindName(InvDynKind kind) {
  switch (kind) {
    case InvDynKind::kParametric:
      return "invdyn-parametric";
    case InvDynKind::kGp:
      return "invdyn-gp";
    case InvDynKind::kSemiparametric:
      return "invdyn-semiparametric";
  }
  return "";
}

}  // namespace

ReachingData ExtractReachingData(const std::vector<Trial>& trials, std::size_t min_samples) {
  if (trials.empty()) throw std::runtime_error("reaching data: no trials");
  ReachingData d;
  for (const auto& name : trials[0].NamesWithPrefix("tau.")) d.joints.push_back(name.substr(4));
  if (d.joints.empty()) throw std::runtime_error("reaching trial: column tau.<joint> missing");
  const std::size_t J = d.joints.size();
  std::size_t n = 0;
  for (const auto& t : trials) {
    if (t.size() < min_samples) {
      throw std::runtime_error("reaching trial: column time has " + std::to_string(t.size()) +
                               " samples, at least " + std::to_string(min_samples) + " needed");
    }
    n += t.size();
  }
  d.X.resize(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(3 * J));
  d.tau.resize(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(J));
  std::map<std::string, int> groups;
  Eigen::Index row = 0;
  for (std::size_t k = 0; k < trials.size(); ++k) {
    const Trial& t = trials[k];
    if (t.NamesWithPrefix("tau.").size() != J) {
      throw std::runtime_error("reaching trial " + std::to_string(k) +
                               ": column tau.<joint> set differs from the first trial");
    }
    const auto it = t.metadata.find("trajectory");
    const std::string gid = it != t.metadata.end() ? it->second : "file" + std::to_string(k);
    const auto g = groups.emplace(gid, static_cast<int>(groups.size()));
    if (g.second) d.group_names.push_back(gid);
    d.trial_begin.push_back(row);
    for (std::size_t j = 0; j < J; ++j) {
      const auto& name = d.joints[j];
      const auto q = CheckedColumn(t, "q." + name);
      const auto qd = CheckedColumn(t, "qd." + name);
      const auto qdd =
          t.Has("qdd." + name) ? CheckedColumn(t, "qdd." + name) : Differentiate(t.time, qd);
      const auto tau = CheckedColumn(t, "tau." + name);
      for (std::size_t i = 0; i < t.size(); ++i) {
        const auto r = row + static_cast<Eigen::Index>(i);
        d.X(r, j) = q[i];
        d.X(r, J + j) = qd[i];
        d.X(r, 2 * J + j) = qdd[i];
        d.tau(r, j) = tau[i];
      }
    }
    for (std::size_t i = 0; i < t.size(); ++i) d.group.push_back(g.first->second);
    row += static_cast<Eigen::Index>(t.size());
  }
  d.trial_begin.push_back(row);
  return d;
}

Eigen::Vector3d JointBasis(double theta, double theta_dot) { return {1.0, theta, theta_dot}; }

JointStiffnessDamping ParametricJointModel::Params() const {
  JointStiffnessDamping p;
  p.k_s = beta(1);
  p.k_d = beta(2);
  p.theta0 = beta(1) != 0.0 ? -beta(0) / beta(1) : 0.0;
  return p;
}

GpPrediction ParametricJointModel::Predict(double theta, double theta_dot) const {
  const Eigen::Vector3d h = JointBasis(theta, theta_dot);
  return {h.dot(beta), noise_variance * (1.0 + h.dot(gram_inverse * h))};
}

ParametricJointModel FitParametricJoint(const Eigen::VectorXd& theta,
                                        const Eigen::VectorXd& theta_dot,
                                        const Eigen::VectorXd& tau) {
  const Eigen::Index n = tau.size();
  if (theta.size() != n || theta_dot.size() != n) {
    throw std::invalid_argument("parametric joint fit: size mismatch");
  }
  if (n < 4) throw std::runtime_error("parametric joint fit: fewer than 4 samples");
  Eigen::MatrixXd Phi(n, 3);
  Phi.col(0).setOnes();
  Phi.col(1) = theta;
  Phi.col(2) = theta_dot;
  const Eigen::Matrix3d G = Phi.transpose() * Phi;
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(G);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Phi);
  const auto& sv = svd.singularValues();
  if (sv(2) <= 1e-10 * sv(0)) {
    throw std::runtime_error("parametric joint fit: q/qd columns give a rank-deficient basis");
  }
  ParametricJointModel m;
  m.beta = ldlt.solve(Phi.transpose() * tau);
  m.gram_inverse = ldlt.solve(Eigen::Matrix3d::Identity());
  m.noise_variance = (tau - Phi * m.beta).squaredNorm() / static_cast<double>(n - 3);
  return m;
}

InvDynModel FitInvDyn(InvDynKind kind, const std::vector<std::string>& joints,
                      const Eigen::MatrixXd& X, const Eigen::MatrixXd& tau,
                      const InvDynOptions& options,
                      const std::vector<SeArdHyperParams>* fixed_hyper) {
  const std::size_t J = joints.size();
  InvDynModel m;
  m.kind = kind;
  m.joints = joints;
  for (std::size_t j = 0; j < J; ++j) {
    m.parametric.push_back(FitParametricJoint(X.col(j), X.col(J + j), tau.col(j)));
  }
  if (kind == InvDynKind::kParametric) return m;
  const auto idx = EvenSubsample(X.rows(), options.max_training_points);
  const Eigen::MatrixXd Xs = Rows(X, idx);
  const Eigen::MatrixXd Ts = Rows(tau, idx);
  m.training_points = idx.size();
  m.gp.resize(J);
  m.spgp.resize(J);
  for (std::size_t j = 0; j < J; ++j) {
    const Eigen::VectorXd y = Ts.col(j);
    const double sy = std::max(StdDev(y), 1e-9);
    SeArdHyperParams hp;
    hp.length_scales.resize(X.cols());
    for (Eigen::Index d = 0; d < X.cols(); ++d) {
      const double s = StdDev(Xs.col(d));
      hp.length_scales(d) = s > 0.0 ? s : 1.0;
    }
    GpHyperFitOptions fo;
    fo.min_noise_sd = kMinNoiseFraction * sy;
    fo.max_iterations = options.max_hyper_iterations;
    if (kind == InvDynKind::kGp) {
      hp.signal_sd = sy;
      hp.noise_sd = 0.1 * sy;
      if (fixed_hyper != nullptr) {
        hp = (*fixed_hyper)[j];
      } else {
        Convergence c;
        hp = FitHyperParameters(hp, Xs, y, fo, Eigen::VectorXd(), Eigen::MatrixXd(), nullptr, &c);
        m.hyper_convergence.push_back(c);
      }
      m.gp[j].emplace(hp, Xs, y);
    } else {
      const auto& par = m.parametric[j];
      const Eigen::MatrixXd Phi = BasisMatrix(Xs, j, J);
      const Eigen::Vector3d b = par.beta;
      const Eigen::Matrix3d B = par.BetaCovariance();
      hp.length_scales *= options.semiparametric_length_scale_factor;
      const double res_sd = std::max(std::sqrt(par.noise_variance), 1e-9);
      hp.signal_sd = res_sd;
      hp.noise_sd = 0.1 * res_sd;
      if (fixed_hyper != nullptr) {
        hp = (*fixed_hyper)[j];
      } else {
        fo.fit_length_scales = false;  // chosen a priori ([Schearer 2014] §II-B3)
        fo.min_noise_sd = kMinNoiseFraction * res_sd;
        Convergence c;
        hp = FitHyperParameters(hp, Xs, y, fo, Phi * b, Phi * B * Phi.transpose(), nullptr, &c);
        m.hyper_convergence.push_back(c);
      }
      m.spgp[j].emplace(hp, Xs, y, Phi, b, B);
    }
    m.hyper.push_back(hp);
  }
  return m;
}

InvDynPrediction PredictInvDyn(const InvDynModel& model, const Eigen::MatrixXd& X,
                               bool with_variance) {
  const std::size_t J = model.joints.size();
  if (X.cols() != static_cast<Eigen::Index>(3 * J)) {
    throw std::invalid_argument("inverse dynamics: X must have 3 columns per joint");
  }
  InvDynPrediction p;
  p.mean.resize(X.rows(), static_cast<Eigen::Index>(J));
  p.variance = Eigen::MatrixXd::Zero(X.rows(), static_cast<Eigen::Index>(J));
  if (!with_variance) {
    for (std::size_t j = 0; j < J; ++j) {
      const auto jj = static_cast<Eigen::Index>(j);
      const Eigen::MatrixXd Phi = BasisMatrix(X, j, J);
      switch (model.kind) {
        case InvDynKind::kParametric:
          p.mean.col(jj) = Phi * model.parametric[j].beta;
          break;
        case InvDynKind::kGp:
          p.mean.col(jj) = model.gp[j]->PredictMean(X);
          break;
        case InvDynKind::kSemiparametric:
          p.mean.col(jj) = model.spgp[j]->PredictMean(X, Phi);
          break;
      }
    }
    return p;
  }
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    const Eigen::VectorXd x = X.row(i).transpose();
    for (std::size_t j = 0; j < J; ++j) {
      GpPrediction g;
      if (model.kind == InvDynKind::kParametric) {
        g = model.parametric[j].Predict(x(j), x(J + j));
      } else {
        const double s2 = model.hyper[j].noise_sd * model.hyper[j].noise_sd;
        g = model.kind == InvDynKind::kGp ? model.gp[j]->Predict(x)
                                          : model.spgp[j]->Predict(x, JointBasis(x(j), x(J + j)));
        g.variance += s2;
      }
      p.mean(i, static_cast<Eigen::Index>(j)) = g.mean;
      p.variance(i, static_cast<Eigen::Index>(j)) = g.variance;
    }
  }
  return p;
}

InvDynCv LeaveOneTrajectoryOut(InvDynKind kind, const ReachingData& data,
                               const InvDynOptions& options, const InvDynModel& full_fit) {
  const std::size_t J = data.joints.size();
  const int G = static_cast<int>(data.group_names.size());
  if (G < 2) throw std::runtime_error("LOOCV: metadata trajectory gives fewer than 2 trajectories");
  InvDynCv cv;
  cv.max_torque = data.tau.cwiseAbs().colwise().maxCoeff().transpose();
  cv.nrmse.resize(G, static_cast<Eigen::Index>(J));
  cv.training_nrmse = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(J));
  const std::vector<SeArdHyperParams>* hyper =
      kind == InvDynKind::kParametric || options.refit_hyper_per_fold ? nullptr : &full_fit.hyper;
  for (int g = 0; g < G; ++g) {
    std::vector<Eigen::Index> tr, te;
    for (Eigen::Index i = 0; i < data.X.rows(); ++i) {
      (data.group[static_cast<std::size_t>(i)] == g ? te : tr).push_back(i);
    }
    const Eigen::MatrixXd Xtr = Rows(data.X, tr), Ttr = Rows(data.tau, tr);
    const Eigen::MatrixXd Xte = Rows(data.X, te), Tte = Rows(data.tau, te);
    const InvDynModel m = FitInvDyn(kind, data.joints, Xtr, Ttr, options, hyper);
    for (const Convergence& c : m.hyper_convergence) {
      ++cv.fold_hyper_fits;
      if (!c.converged) ++cv.fold_hyper_not_converged;
    }
    const auto pte = PredictInvDyn(m, Xte, false);
    const auto ptr = PredictInvDyn(m, Xtr, false);
    cv.folds.push_back(data.group_names[static_cast<std::size_t>(g)]);
    for (std::size_t j = 0; j < J; ++j) {
      const auto jj = static_cast<Eigen::Index>(j);
      const double scale = cv.max_torque(jj) > 0.0 ? cv.max_torque(jj) : 1.0;
      const double rms_te = std::sqrt((Tte.col(jj) - pte.mean.col(jj)).squaredNorm() /
                                      static_cast<double>(te.size()));
      const double rms_tr = std::sqrt((Ttr.col(jj) - ptr.mean.col(jj)).squaredNorm() /
                                      static_cast<double>(tr.size()));
      cv.nrmse(g, jj) = rms_te / scale;
      cv.training_nrmse(jj) += rms_tr / scale / G;
    }
  }
  return cv;
}

BoxStats BoxPlotStats(std::vector<double> v) {
  if (v.empty()) throw std::invalid_argument("box plot: no values");
  std::sort(v.begin(), v.end());
  auto pct = [&](double p) {
    const double pos = p * static_cast<double>(v.size() - 1);
    const auto lo = static_cast<std::size_t>(std::floor(pos));
    const auto hi = std::min(lo + 1, v.size() - 1);
    return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
  };
  return {pct(0.05), pct(0.25), pct(0.5), pct(0.75), pct(0.95)};
}

namespace {

/// One BFGS hyper-parameter optimisation per joint, each its own "best run"; a warning per joint
/// whose optimisation did not converge.
Json HyperConvergence(const std::string& name, const std::vector<std::string>& joints,
                      const InvDynModel& model, std::vector<std::string>* warnings) {
  Json conv = Json::Object();
  for (std::size_t j = 0; j < model.hyper_convergence.size(); ++j) {
    const std::vector<Convergence> one = {model.hyper_convergence[j]};
    conv.Set(joints[j], ConvergenceJson(one, 0));
    const std::string w = NotConvergedWarning(name + " hyper-parameters of " + joints[j], one, 0);
    if (!w.empty()) warnings->push_back(w);
  }
  return conv;
}

/// Closed-form leave-one-sample-out residuals of each joint's GP on its training points
/// (Rasmussen & Williams eq. 5.12), RMS normalised by the joint's maximum |τ|.
Json ClosedFormLoo(const ReachingData& data, const InvDynModel& model) {
  Json loo = Json::Object();
  for (std::size_t j = 0; j < data.joints.size(); ++j) {
    const double max_tau = data.tau.col(static_cast<Eigen::Index>(j)).cwiseAbs().maxCoeff();
    const Eigen::VectorXd r = model.gp[j]->LooResiduals();
    loo.Set(data.joints[j],
            std::sqrt(r.squaredNorm() / static_cast<double>(r.size())) / std::max(max_tau, 1e-12));
  }
  return loo;
}

/// The leave-one-trajectory-out figures per joint: every fold's normalised RMS error, its box
/// plot statistics, and the mean training error.
Json LoocvJson(const InvDynCv& cv, double cv_s, const std::vector<std::string>& joints) {
  Json jcv = Json::Object();
  jcv.Set("wall_time_s", cv_s);
  jcv.Set("normalisation", "RMS error / max |tau| of the joint over the data set");
  Json folds = Json::Array();
  for (const auto& f : cv.folds) folds.Push(f);
  jcv.Set("folds", std::move(folds));
  jcv.Set("fold_hyper_fits", cv.fold_hyper_fits);
  jcv.Set("fold_hyper_not_converged", cv.fold_hyper_not_converged);
  Json per = Json::Object();
  for (std::size_t j = 0; j < joints.size(); ++j) {
    const auto jj = static_cast<Eigen::Index>(j);
    std::vector<double> vals(cv.nrmse.rows());
    for (Eigen::Index g = 0; g < cv.nrmse.rows(); ++g) vals[g] = cv.nrmse(g, jj);
    const BoxStats b = BoxPlotStats(vals);
    Json box = Json::Object();
    box.Set("p05", b.p05);
    box.Set("p25", b.p25);
    box.Set("median", b.median);
    box.Set("p75", b.p75);
    box.Set("p95", b.p95);
    Json jj_json = Json::Object();
    jj_json.Set("max_torque_Nm", cv.max_torque(jj));
    jj_json.Set("loocv_nrmse", vals);
    jj_json.Set("box", std::move(box));
    jj_json.Set("mean_training_nrmse", cv.training_nrmse(jj));
    per.Set(joints[j], std::move(jj_json));
  }
  jcv.Set("joints", std::move(per));
  return jcv;
}

/// Predictions of `model` on every trial of `eval` (the torque with its 95 % band per joint,
/// appended to *predictions) and their errors (results' "trials").
Json PredictTrials(const std::string& name, const std::vector<std::string>& joints,
                   const InvDynModel& model, const std::vector<Trial>& eval,
                   std::vector<Trial>* predictions) {
  Json trials = Json::Array();
  for (const auto& t : eval) {
    const ReachingData d = ExtractReachingData({t});
    if (d.joints != joints) throw std::runtime_error("test trial: tau.<joint> columns differ");
    const auto p = PredictInvDyn(model, d.X);
    const Eigen::VectorXd max_tau = d.tau.cwiseAbs().colwise().maxCoeff().transpose();
    Trial pred;
    pred.metadata["method"] = name;
    pred.time = t.time;
    Json m = Json::Object();
    for (std::size_t j = 0; j < joints.size(); ++j) {
      const auto jj = static_cast<Eigen::Index>(j);
      std::vector<double> mean(p.mean.rows()), lo(p.mean.rows()), hi(p.mean.rows()),
          y(p.mean.rows());
      for (Eigen::Index i = 0; i < p.mean.rows(); ++i) {
        const double half = kZ95 * std::sqrt(p.variance(i, jj));
        mean[i] = p.mean(i, jj);
        lo[i] = mean[i] - half;
        hi[i] = mean[i] + half;
        y[i] = d.tau(i, jj);
      }
      pred.AddColumn("tau." + joints[j], mean);
      pred.AddColumn("tau_lo95." + joints[j], lo);
      pred.AddColumn("tau_hi95." + joints[j], hi);
      Json jm = Json::Object();
      jm.Set("rms_over_max_torque", Rms(y, mean) / std::max(max_tau(jj), 1e-12));
      jm.Set("best_fit_percent", BestFitPercent(y, mean));
      m.Set(joints[j], std::move(jm));
    }
    trials.Push(std::move(m));
    predictions->push_back(std::move(pred));
  }
  return trials;
}

/// The identified model as YAML: per joint the parametric part with 95 % intervals, the GP
/// kernel and the semiparametric posterior mean where the kind has them, BFGS's stops.
std::string ModelYaml(InvDynKind kind, const std::string& name,
                      const std::vector<std::string>& joints, const InvDynModel& model) {
  const std::size_t J = joints.size();
  std::string yaml = "method: " + name + "\npaper: 004_7ee2989736d21d4b.txt eq. " +
                     (kind == InvDynKind::kParametric
                          ? "3-4"
                          : (kind == InvDynKind::kGp ? "5-6" : "7-8 (prior from eq. 3-4)")) +
                     "\ninput: \"[q (rad), qd (rad/s), qdd (rad/s^2)] of joints [";
  for (std::size_t j = 0; j < J; ++j) yaml += (j ? ", " : "") + joints[j];
  // Quoted: a flow sequence followed by more text is not YAML, and the whole file failed to parse.
  yaml += "]\"\njoints:\n";
  for (std::size_t j = 0; j < J; ++j) {
    const auto& par = model.parametric[j];
    const auto p = par.Params();
    const Eigen::Matrix3d C = par.BetaCovariance();
    // θ0 = −β0/β1: delta-method variance with ∇ = [−1/β1, β0/β1², 0].
    const Eigen::Vector3d grad(-1.0 / par.beta(1), par.beta(0) / (par.beta(1) * par.beta(1)), 0.0);
    yaml += "  " + joints[j] + ":\n    parametric:\n";
    yaml += "      theta0: {value: " + Num(p.theta0) +
            ", unit: rad, ci95: " + Num(kZ95 * std::sqrt(grad.dot(C * grad))) + "}\n";
    yaml += "      k_s: {value: " + Num(p.k_s) +
            ", unit: \"N*m/rad\", ci95: " + Num(kZ95 * std::sqrt(C(1, 1))) + "}\n";
    yaml += "      k_d: {value: " + Num(p.k_d) +
            ", unit: \"N*m*s/rad\", ci95: " + Num(kZ95 * std::sqrt(C(2, 2))) + "}\n";
    yaml += "      noise_sd: {value: " + Num(std::sqrt(par.noise_variance)) + ", unit: \"N*m\"}\n";
    if (kind != InvDynKind::kParametric) {
      const auto& hp = model.hyper[j];
      yaml += "    kernel: {type: squared_exponential_ard, signal_sd: " + Num(hp.signal_sd) +
              ", noise_sd: " + Num(hp.noise_sd) + ", unit: \"N*m\", length_scales: [";
      for (Eigen::Index d = 0; d < hp.length_scales.size(); ++d) {
        yaml += (d ? ", " : "") + Num(hp.length_scales(d));
      }
      yaml += "]}\n";
    }
    if (kind == InvDynKind::kSemiparametric) {
      const auto& bb = model.spgp[j]->beta_bar();
      yaml += "    beta_posterior: [" + Num(bb(0)) + ", " + Num(bb(1)) + ", " + Num(bb(2)) + "]\n";
    }
  }
  if (kind != InvDynKind::kParametric) {
    yaml += "gp_training_points: " + std::to_string(model.training_points) + "\n";
    if (!model.hyper_convergence.empty()) yaml += "# how BFGS stopped per joint\nconvergence:\n";
    for (std::size_t j = 0; j < model.hyper_convergence.size(); ++j) {
      const Convergence& c = model.hyper_convergence[j];
      yaml += "  " + joints[j] + ": {converged: " + (c.converged ? "true" : "false") +
              ", stop_reason: " + c.stop_reason + ", iterations: " + std::to_string(c.iterations) +
              "}\n";
    }
  }
  return yaml;
}

}  // namespace

MethodResult RunInvDynMethod(InvDynKind kind, const std::vector<Trial>& train,
                             const std::vector<Trial>& test, const ProgressFn& progress) {
  const std::string name = KindName(kind);
  const ReachingData data = ExtractReachingData(train);
  InvDynOptions options;
  if (!train.empty()) {
    const auto it = train[0].metadata.find("invdyn.fold_hyper");
    if (it != train[0].metadata.end()) {
      if (it->second != "refit" && it->second != "full") {
        throw std::runtime_error("metadata invdyn.fold_hyper: '" + it->second +
                                 "' is not one of refit|full");
      }
      options.refit_hyper_per_fold = it->second == "refit";
    }
    const auto ls = train[0].metadata.find("invdyn.length_scale_factor");
    if (ls != train[0].metadata.end()) {
      char* end = nullptr;
      const double v = std::strtod(ls->second.c_str(), &end);
      if (end == ls->second.c_str() || *end != '\0' || !(v > 0.0 && v <= 100.0)) {
        throw std::runtime_error("metadata invdyn.length_scale_factor: '" + ls->second +
                                 "' is not a number in (0, 100]");
      }
      options.semiparametric_length_scale_factor = v;
    }
    const auto it_max = train[0].metadata.find("invdyn.max_hyper_iterations");
    if (it_max != train[0].metadata.end()) {
      char* end = nullptr;
      const long v = std::strtol(it_max->second.c_str(), &end, 10);
      if (end == it_max->second.c_str() || *end != '\0' || v < 1 || v > 10000) {
        throw std::runtime_error("metadata invdyn.max_hyper_iterations: '" + it_max->second +
                                 "' is not an integer in [1, 10000]");
      }
      options.max_hyper_iterations = static_cast<int>(v);
    }
  }
  if (progress) progress(0.0, "fitting");
  auto t0 = std::chrono::steady_clock::now();
  const InvDynModel model = FitInvDyn(kind, data.joints, data.X, data.tau, options);
  const double fit_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  MethodResult result;
  result.metrics.Set("method", name);
  result.metrics.Set("fit_wall_time_s", fit_s);
  result.metrics.Set("training_samples", static_cast<unsigned long>(data.X.rows()));
  if (kind != InvDynKind::kParametric) {
    result.metrics.Set("gp_training_points", static_cast<unsigned long>(model.training_points));
    result.metrics.Set("hyper_parameter_convergence",
                       HyperConvergence(name, data.joints, model, &result.warnings));
  }
  if (kind == InvDynKind::kGp) {
    result.metrics.Set("loo_sample_nrmse_closed_form", ClosedFormLoo(data, model));
  }
  if (data.group_names.size() >= 2) {
    if (progress) progress(0.3, "leave-one-trajectory-out CV");
    t0 = std::chrono::steady_clock::now();
    const InvDynCv cv = LeaveOneTrajectoryOut(kind, data, options, model);
    const double cv_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    result.metrics.Set("loocv", LoocvJson(cv, cv_s, data.joints));
    result.metrics.Set("loocv_fold_hyper", options.refit_hyper_per_fold ? "refit" : "full");
  }

  if (progress) progress(0.9, "predicting");
  const auto& eval = test.empty() ? train : test;
  Json trials = PredictTrials(name, data.joints, model, eval, &result.predictions);
  result.metrics.Set("evaluated_on", test.empty() ? "train" : "test");
  result.metrics.Set("trials", std::move(trials));
  result.model_yaml = ModelYaml(kind, name, data.joints, model);
  if (progress) progress(1.0, "done");
  return result;
}

MethodEntry InvDynParametricMethod() {
  return {"invdyn-parametric", "paper 004 eq. 3-4: per-joint stiffness/damping regression, LOOCV",
          [](const std::vector<Trial>& train, const std::vector<Trial>& test,
             const ProgressFn& progress) {
            return RunInvDynMethod(InvDynKind::kParametric, train, test, progress);
          }};
}

MethodEntry InvDynGpMethod() {
  return {"invdyn-gp", "paper 004 eq. 5-6: GP, SE-ARD kernel, marginal likelihood, LOOCV",
          [](const std::vector<Trial>& train, const std::vector<Trial>& test,
             const ProgressFn& progress) {
            return RunInvDynMethod(InvDynKind::kGp, train, test, progress);
          }};
}

MethodEntry InvDynSemiparametricMethod() {
  return {"invdyn-semiparametric", "paper 004 eq. 7-8: GP with parametric mean prior, LOOCV",
          [](const std::vector<Trial>& train, const std::vector<Trial>& test,
             const ProgressFn& progress) {
            return RunInvDynMethod(InvDynKind::kSemiparametric, train, test, progress);
          }};
}

}  // namespace fesim::identification
