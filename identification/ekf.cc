#include "identification/ekf.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <utility>

#include "identification/metrics.h"

namespace fesim::identification {
namespace {

constexpr double kConvergenceBand = 0.05;  // ±5 % (issue 5)

double Sign(double v) { return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0); }

std::string Num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

std::vector<double> Series(const ShoulderEkfRun& run, double ShoulderEkfParams::*field) {
  std::vector<double> v;
  v.reserve(run.params.size());
  for (const auto& p : run.params) v.push_back(p.*field);
  return v;
}

}  // namespace

ShoulderEkfVector ShoulderEkfTransition(const ShoulderEkfVector& x, double sigma_ant,
                                        double sigma_post, double friction, double dt,
                                        double theta_max_ant, double theta_max_post) {
  // x = [θ, ω, K_ant, K_post, R_m, K_m]  ([Spagnol 2013] eq. 4, 9–10).
  ShoulderEkfVector next = x;
  next(0) = x(0) + x(1) * dt;
  next(1) =
      x(1) + (-(x(5) + x(2) * sigma_ant + x(3) * sigma_post) * x(0) - x(4) * x(1) +
              theta_max_ant * x(2) * sigma_ant + theta_max_post * x(3) * sigma_post - friction) *
                 dt;
  return next;
}

ShoulderEkfMatrix ShoulderEkfJacobian(const ShoulderEkfVector& x, double sigma_ant,
                                      double sigma_post, double dt, double theta_max_ant,
                                      double theta_max_post) {
  // [Spagnol 2013] eq. 14–15.
  ShoulderEkfMatrix F = ShoulderEkfMatrix::Identity();
  F(0, 1) = dt;
  F(1, 0) = -dt * (x(5) + x(2) * sigma_ant + x(3) * sigma_post);
  F(1, 1) = 1.0 - x(4) * dt;
  F(1, 2) = (theta_max_ant - x(0)) * sigma_ant * dt;
  F(1, 3) = (theta_max_post - x(0)) * sigma_post * dt;
  F(1, 4) = -x(1) * dt;
  F(1, 5) = -x(0) * dt;
  return F;
}

ShoulderEkf::ShoulderEkf(const ShoulderEkfConfig& config, double theta0, double omega0)
    : config_(config) {
  x_ << theta0, omega0, config.initial.k_ant, config.initial.k_post, config.initial.r_m,
      config.initial.k_m;
  const auto& t = config.tuning;
  P_ = ShoulderEkfMatrix::Zero();
  P_.diagonal() << t.p0_theta, t.p0_omega, t.p0_param, t.p0_param, t.p0_param, t.p0_param;
}

void ShoulderEkf::Update(double theta, double omega) {
  if (std::isnan(theta) || std::isnan(omega)) return;
  Eigen::Matrix<double, 2, 6> C = Eigen::Matrix<double, 2, 6>::Zero();  // [Spagnol 2013] eq. 8
  C(0, 0) = 1.0;
  C(1, 1) = 1.0;
  Eigen::Matrix2d R = Eigen::Matrix2d::Zero();
  R(0, 0) = config_.tuning.r_theta;
  R(1, 1) = config_.tuning.r_omega;
  KalmanMeasurementUpdate<6, 2>(C, R, Eigen::Vector2d(theta, omega), &x_, &P_);
}

void ShoulderEkf::Predict(double sigma_ant, double sigma_post, double omega_measured, double dt) {
  const bool measured = config_.friction_sign_from_measurement && !std::isnan(omega_measured);
  const double fs = config_.friction_c * Sign(measured ? omega_measured : x_(1));
  const ShoulderEkfMatrix F = ShoulderEkfJacobian(x_, sigma_ant, sigma_post, dt,
                                                  config_.theta_max_ant, config_.theta_max_post);
  const ShoulderEkfVector next = ShoulderEkfTransition(
      x_, sigma_ant, sigma_post, fs, dt, config_.theta_max_ant, config_.theta_max_post);
  const auto& t = config_.tuning;
  ShoulderEkfMatrix Q = ShoulderEkfMatrix::Zero();
  Q.diagonal() << t.q_theta, t.q_omega, t.q_k_ant, t.q_k_post, t.q_r_m, t.q_k_m;
  KalmanTimeUpdate<6>(next, F, Q * dt, &x_, &P_);
}

ShoulderEkfParams ShoulderEkf::params() const {
  ShoulderEkfParams p;
  p.k_ant = x_(2);
  p.k_post = x_(3);
  p.r_m = x_(4);
  p.k_m = x_(5);
  return p;
}

ShoulderEkfRun RunShoulderEkf(const ShoulderEkfConfig& config, const ShoulderData& data) {
  const std::size_t n = data.time.size();
  if (n < 2) throw std::runtime_error("shoulder EKF: column time has fewer than 2 samples");
  ShoulderEkf ekf(config, data.theta[0], data.omega[0]);
  ShoulderEkfRun run;
  run.time = data.time;
  run.theta.resize(n);
  run.omega.resize(n);
  run.params.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    ekf.Update(data.theta[k], data.omega[k]);
    run.theta[k] = ekf.state()(0);
    run.omega[k] = ekf.state()(1);
    run.params[k] = ekf.params();
    if (k + 1 < n) {
      ekf.Predict(data.sigma_ant[k], data.sigma_post[k], data.omega[k],
                  data.time[k + 1] - data.time[k]);
    }
  }
  return run;
}

double ConvergenceTime(const std::vector<double>& time, const std::vector<double>& values,
                       double band) {
  if (values.empty() || time.size() != values.size()) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const double final_value = values.back();
  const double tol = band * std::abs(final_value);
  std::size_t first = values.size() - 1;
  for (std::size_t k = values.size(); k-- > 0;) {
    if (std::abs(values[k] - final_value) > tol) break;
    first = k;
  }
  return time[first];
}

double MeanFrom(const std::vector<double>& time, const std::vector<double>& values, double t_from) {
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < values.size(); ++k) {
    if (time[k] >= t_from) {
      sum += values[k];
      ++n;
    }
  }
  return n == 0 ? std::numeric_limits<double>::quiet_NaN() : sum / static_cast<double>(n);
}

void ApplyEkfMetadata(const Trial& trial, ShoulderEkfConfig* config) {
  auto& t = config->tuning;
  auto& p = config->initial;
  const std::vector<std::pair<std::string, double*>> fields = {
      {"q_theta", &t.q_theta},   {"q_omega", &t.q_omega},   {"q_k_ant", &t.q_k_ant},
      {"q_k_post", &t.q_k_post}, {"q_r_m", &t.q_r_m},       {"q_k_m", &t.q_k_m},
      {"r_theta", &t.r_theta},   {"r_omega", &t.r_omega},   {"p0_theta", &t.p0_theta},
      {"p0_omega", &t.p0_omega}, {"p0_param", &t.p0_param}, {"k_ant", &p.k_ant},
      {"k_post", &p.k_post},     {"r_m", &p.r_m},           {"k_m", &p.k_m}};
  for (const auto& [key, value] : trial.metadata) {
    if (key.rfind("ekf.", 0) != 0) continue;
    const std::string field = key.substr(4);
    double* target = nullptr;
    for (const auto& f : fields) {
      if (f.first == field) target = f.second;
    }
    if (target == nullptr) throw std::runtime_error("metadata " + key + ": unknown EKF setting");
    double v;
    try {
      v = std::stod(value);
    } catch (const std::exception&) {
      throw std::runtime_error("metadata " + key + ": not a number: " + value);
    }
    if (!(v >= 0.0)) throw std::runtime_error("metadata " + key + ": must be >= 0");
    *target = v;
  }
  if (!(t.r_theta > 0.0) || !(t.r_omega > 0.0)) {
    throw std::runtime_error("metadata ekf.r_theta / ekf.r_omega: must be > 0");
  }
}

MethodResult RunShoulderEkfMethod(const std::vector<Trial>& train, const std::vector<Trial>& test,
                                  const ProgressFn& progress) {
  if (train.empty()) throw std::runtime_error("shoulder-ekf: no training trials");
  std::vector<ShoulderData> data;
  data.reserve(train.size());
  for (const auto& t : train) {
    data.push_back(ExtractShoulderData(t, 10, data.empty() ? 0.0 : data[0].direction));
  }
  ShoulderEkfConfig config;
  ThetaMaxFromMetadata(train[0], &config.theta_max_ant, &config.theta_max_post);
  ApplyEkfMetadata(train[0], &config);
  const double known_c = KnownFrictionFromMetadata(train[0]);

  // Offline fit of the filter's model (model 2 with R_ant = R_post = 0) on the training data: c
  // when the friction is not given (the paper takes c from pendulum tests).
  if (progress) progress(0.0, "offline model-2 fit");
  const ShoulderFit offline =
      FitShoulderModel(ShoulderModel::kModel2, data, config.theta_max_ant, config.theta_max_post,
                       known_c, Eigen::VectorXd(), true);
  const ShoulderModel2Params off = Model2FromVector(offline.p, ShoulderModel2Params());
  config.friction_c = known_c >= 0.0 ? known_c : off.c;

  struct Named {
    const char* name;
    const char* unit;
    double ShoulderEkfParams::*field;
    double ShoulderModel2Params::*offline;
  };
  const std::vector<Named> fields = {
      {"k_ant", "1/s^2", &ShoulderEkfParams::k_ant, &ShoulderModel2Params::k_ant},
      {"k_post", "1/s^2", &ShoulderEkfParams::k_post, &ShoulderModel2Params::k_post},
      {"r_m", "1/s", &ShoulderEkfParams::r_m, &ShoulderModel2Params::r_m},
      {"k_m", "1/s^2", &ShoulderEkfParams::k_m, &ShoulderModel2Params::k_m}};

  MethodResult result;
  Json per = Json::Array();
  const auto& eval = test.empty() ? train : test;
  ShoulderEkfParams last;
  double ns_per_sample = 0.0;
  for (std::size_t i = 0; i < eval.size(); ++i) {
    if (progress) progress(0.5 + 0.5 * i / eval.size(), "EKF");
    const ShoulderData d = ExtractShoulderData(eval[i], 10, data[0].direction);
    // [Spagnol 2013] Table IV compares the filter with the offline fit of the same data set and
    // model: the reference is the offline fit of this trial, with the filter's c.
    const ShoulderFit same_trial =
        FitShoulderModel(ShoulderModel::kModel2, {d}, config.theta_max_ant, config.theta_max_post,
                         config.friction_c, Eigen::VectorXd(), true);
    const ShoulderModel2Params ref = Model2FromVector(same_trial.p, ShoulderModel2Params());
    const auto t0 = std::chrono::steady_clock::now();
    const ShoulderEkfRun run = RunShoulderEkf(config, d);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ns_per_sample = 1e9 * wall / static_cast<double>(d.time.size());
    last = run.params.back();
    Trial pred;
    pred.metadata["method"] = "shoulder-ekf";
    pred.time = d.time;
    pred.AddColumn("q." + d.joint, AngleToTrialFrame(d, run.theta));
    pred.AddColumn("qd." + d.joint, VelocityToTrialFrame(d, run.omega));
    Json m = Json::Object();
    m.Set("J_L_velocity_percent", 100.0 * PerformanceIndexJL(d.omega, run.omega));
    m.Set("J_L_position_percent", 100.0 * PerformanceIndexJL(d.theta, run.theta));
    m.Set("wall_time_per_sample_ns", ns_per_sample);
    Json params = Json::Object();
    for (const auto& f : fields) {
      const auto series = Series(run, f.field);
      pred.AddColumn(std::string("param.") + f.name, series);
      const double tc = ConvergenceTime(d.time, series, kConvergenceBand);
      const double mean = MeanFrom(d.time, series, tc);
      Json p = Json::Object();
      p.Set("final", series.back());
      p.Set("mean_after_convergence", mean);
      p.Set("convergence_time_s", tc - d.time.front());
      p.Set("offline_same_trial", ref.*(f.offline));
      p.Set("error_vs_offline_percent", 100.0 * (mean - ref.*(f.offline)) / ref.*(f.offline));
      const auto it = eval[i].metadata.find(std::string("true_") + f.name);
      if (it != eval[i].metadata.end()) {
        const double truth = std::stod(it->second);
        p.Set("error_vs_truth_percent", 100.0 * (mean - truth) / truth);
      }
      params.Set(f.name, std::move(p));
    }
    m.Set("parameters", std::move(params));
    per.Push(std::move(m));
    result.predictions.push_back(std::move(pred));
  }

  const auto& t = config.tuning;
  std::string yaml = "method: shoulder-ekf\n";
  yaml += "paper: 003_7182ceb830858ebb.txt eq. 4-17 (model eq. 3)\n";
  yaml += "normalisation: alpha_J = 1\n";
  yaml +=
      "parameters:  # final EKF estimate of the last evaluated trial; offline: fit of the "
      "training data, R_ant = R_post = 0\n";
  for (const auto& f : fields) {
    yaml += std::string("  ") + f.name + ": {value: " + Num(last.*(f.field)) + ", unit: \"" +
            f.unit + "\", offline: " + Num(off.*(f.offline)) + "}\n";
  }
  yaml += "known_input:\n  friction_c: {value: " + Num(config.friction_c) +
          ", unit: \"rad/s^2\", source: " + (known_c >= 0.0 ? "metadata" : "offline fit") + "}\n";
  yaml += "fixed:\n  theta_max_ant: {value: " + Num(config.theta_max_ant) + ", unit: rad}\n";
  yaml += "  theta_max_post: {value: " + Num(config.theta_max_post) + ", unit: rad}\n";
  yaml += "initial_guess: {k_ant: " + Num(config.initial.k_ant) +
          ", k_post: " + Num(config.initial.k_post) + ", r_m: " + Num(config.initial.r_m) +
          ", k_m: " + Num(config.initial.k_m) + "}\n";
  yaml += "tuning:  # Q = rate * dt (random walk), R per sample, P0 diagonal\n";
  yaml += "  process_noise_rate: {theta: " + Num(t.q_theta) + ", omega: " + Num(t.q_omega) +
          ", k_ant: " + Num(t.q_k_ant) + ", k_post: " + Num(t.q_k_post) + ", r_m: " + Num(t.q_r_m) +
          ", k_m: " + Num(t.q_k_m) + "}\n";
  yaml +=
      "  measurement_variance: {theta: " + Num(t.r_theta) + ", omega: " + Num(t.r_omega) + "}\n";
  yaml += "  initial_covariance: {theta: " + Num(t.p0_theta) + ", omega: " + Num(t.p0_omega) +
          ", parameter: " + Num(t.p0_param) + "}\n";
  result.model_yaml = yaml;
  result.metrics.Set("method", "shoulder-ekf");
  result.metrics.Set("evaluated_on", test.empty() ? "train" : "test");
  result.metrics.Set("convergence_band_percent", 100.0 * kConvergenceBand);
  result.metrics.Set("trials", std::move(per));
  if (progress) progress(1.0, "done");
  return result;
}

MethodEntry ShoulderEkfMethod() {
  return {"shoulder-ekf", "paper 003 eq. 4-17: online EKF of model 2, tracks parameter drift",
          RunShoulderEkfMethod};
}

}  // namespace fesim::identification
