#include "identification/shoulder_models.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

#include "identification/metrics.h"

namespace fesim::identification {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
/// Velocities below this are treated as "at rest" when building the equation-error start, rad/s.
constexpr double kRestVelocity = 1e-3;
constexpr int kMaxLmIterations = 200;
constexpr double kLmMaxLambda = 1e12;
constexpr double kLmStepTolerance = 1e-9;      // stop when ‖Δp‖ ≤ this × ‖p‖
constexpr double kLmRelativeTolerance = 1e-8;  // stop when a step gains less than this × cost
constexpr double kFdRelativeStep = 1e-6;
constexpr double kZ95 = 1.959963984540054;

double Sign(double v) { return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0); }

std::string Num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

std::vector<double> Column(const Trial& trial, const std::string& name) {
  const auto& c = trial.Column(name);
  for (double v : c) {
    if (std::isnan(v)) throw std::runtime_error("column " + name + ": NaN sample");
  }
  return c;
}

/// The column named for one deltoid part: containing `word` ("anterior") or ending in `suffix`
/// ("_ant", as the rig's channel u.delt_ant); else names[index].
std::string Pick(const std::vector<std::string>& names, const std::string& word,
                 const std::string& suffix, std::size_t index) {
  for (const auto& n : names) {
    const bool ends = n.size() >= suffix.size() &&
                      n.compare(n.size() - suffix.size(), suffix.size(), suffix) == 0;
    if (n.find(word) != std::string::npos || ends) return n;
  }
  return index < names.size() ? names[index] : std::string();
}

double MetadataNumber(const std::string& key, const std::string& value) {
  try {
    std::size_t used = 0;
    const double v = std::stod(value, &used);
    if (used == value.size() && std::isfinite(v)) return v;
  } catch (const std::exception&) {
  }
  throw std::runtime_error("metadata " + key + ": not a number: " + value);
}

std::vector<double> LowerBounds(ShoulderModel model) {
  if (model == ShoulderModel::kModel1) return {-kInf, -kInf, 0, 0, 0, 0, 0, 0, 0};
  return {0, 0, 0, 0, 0, 0, 0};
}

std::string Unit(ShoulderModel model, std::size_t i) {
  const std::vector<std::string> u1 = {"rad/s^2", "rad/s^2", "1/s^2", "1/s^2",  "1/s",
                                       "1/s",     "1/s^2",   "1/s",   "rad/s^2"};
  const std::vector<std::string> u2 = {"1/s^2", "1/s^2", "1/s", "1/s", "1/s^2", "1/s", "rad/s^2"};
  return model == ShoulderModel::kModel1 ? u1[i] : u2[i];
}

/// Output-error residuals (ω_sim − ω) / ‖ω − ω̄‖ per trial, concatenated: Σ r² = Σ_trials J_L(ω).
Eigen::VectorXd VelocityResiduals(ShoulderModel model, const Eigen::VectorXd& p, double tm_ant,
                                  double tm_post, const std::vector<ShoulderData>& trials) {
  std::size_t n = 0;
  for (const auto& t : trials) n += t.time.size();
  Eigen::VectorXd r(n);
  std::size_t row = 0;
  for (const auto& t : trials) {
    const auto sim = SimulateShoulder(model, p, tm_ant, tm_post, t, true);
    double mean = 0.0;
    for (double w : t.omega) mean += w;
    mean /= static_cast<double>(t.omega.size());
    double dev2 = 0.0;
    for (double w : t.omega) dev2 += (w - mean) * (w - mean);
    const double scale = dev2 > 0.0 ? 1.0 / std::sqrt(dev2) : 1.0;
    for (std::size_t k = 0; k < t.omega.size(); ++k) r(row++) = (sim.omega[k] - t.omega[k]) * scale;
  }
  return r;
}

/// Equation-error least squares: (ω(k+1) − ω(k))/Δt = φ(k)ᵀ p, samples at rest excluded. Only
/// the entries `free` of p are solved for; the others keep their values in `fixed` (units of
/// ModelRegressors; `fixed` is zero at the free entries).
Eigen::VectorXd EquationErrorStart(ShoulderModel model, double tm_ant, double tm_post,
                                   const std::vector<ShoulderData>& trials,
                                   const Eigen::VectorXd& fixed, const std::vector<int>& free) {
  const int np = static_cast<int>(fixed.size());
  std::vector<Eigen::VectorXd> rows;
  std::vector<double> ys;
  for (const auto& t : trials) {
    for (std::size_t k = 0; k + 1 < t.time.size(); ++k) {
      if (std::abs(t.omega[k]) < kRestVelocity || std::abs(t.omega[k + 1]) < kRestVelocity) {
        continue;
      }
      const double dt = t.time[k + 1] - t.time[k];
      rows.push_back(ModelRegressors(model, tm_ant, tm_post, t.sigma_ant[k], t.sigma_post[k],
                                     t.theta[k], t.omega[k]));
      ys.push_back((t.omega[k + 1] - t.omega[k]) / dt);
    }
  }
  const int nfree = static_cast<int>(free.size());
  Eigen::VectorXd p = fixed;
  if (rows.size() < 2 * static_cast<std::size_t>(np)) return p;
  Eigen::MatrixXd A(rows.size(), nfree);
  Eigen::VectorXd y(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    y(i) = ys[i] - rows[i].dot(fixed);
    for (int j = 0; j < nfree; ++j) A(i, j) = rows[i](free[j]);
  }
  Eigen::VectorXd scale = A.colwise().norm().transpose();
  for (int j = 0; j < nfree; ++j) scale(j) = scale(j) > 0.0 ? scale(j) : 1.0;
  const Eigen::VectorXd sol =
      (A * scale.cwiseInverse().asDiagonal()).colPivHouseholderQr().solve(y).cwiseQuotient(scale);
  const auto lb = LowerBounds(model);
  for (int j = 0; j < nfree; ++j) p(free[j]) = std::max(sol(j), lb[free[j]]);
  return p;
}

/// Indices of p an offline fit identifies: all but c when it is known, and but R̃_ant, R̃_post of
/// model 2 when they are held at zero.
std::vector<int> FreeParameters(ShoulderModel model, bool friction_known,
                                bool zero_activation_damping) {
  const int np = model == ShoulderModel::kModel1 ? 9 : 7;
  std::vector<int> free;
  for (int j = 0; j < np; ++j) {
    if (j == np - 1 && friction_known) continue;
    if (model == ShoulderModel::kModel2 && zero_activation_damping && (j == 2 || j == 3)) continue;
    free.push_back(j);
  }
  return free;
}

}  // namespace

ShoulderData ExtractShoulderData(const Trial& trial, std::size_t min_samples, double direction) {
  ShoulderData d;
  if (trial.size() < min_samples) {
    throw std::runtime_error("shoulder trial: column time has " + std::to_string(trial.size()) +
                             " samples, at least " + std::to_string(min_samples) + " needed");
  }
  d.time = trial.time;
  const auto a = trial.NamesWithPrefix("a.");
  const auto u = trial.NamesWithPrefix("u.");
  const bool use_a = a.size() >= 2;
  const auto& names = use_a ? a : u;
  if (names.size() < 2) {
    throw std::runtime_error(
        "shoulder trial: column a.<anterior>/a.<posterior> (or u.<channel>) missing: two "
        "activation columns needed");
  }
  std::string ant = Pick(names, "anterior", "_ant", 0);
  std::string post = Pick(names, "posterior", "_post", 1);
  if (ant == post) post = names[ant == names[0] ? 1 : 0];
  d.sigma_ant = Column(trial, ant);
  d.sigma_post = Column(trial, post);
  if (!use_a) {
    for (auto& s : d.sigma_ant) s /= kShoulderFullActivationPulseWidthUs;
    for (auto& s : d.sigma_post) s /= kShoulderFullActivationPulseWidthUs;
  }
  std::string joint;
  const auto it = trial.metadata.find("joint");
  if (it != trial.metadata.end()) {
    joint = it->second;
  } else {
    const auto q = trial.NamesWithPrefix("q.");
    if (q.empty()) throw std::runtime_error("shoulder trial: column q.<joint> missing");
    joint = q[0].substr(2);
  }
  if (!trial.Has("q." + joint))
    throw std::runtime_error("shoulder trial: column q." + joint + " missing");
  d.joint = joint;
  d.theta = Column(trial, "q." + joint);
  if (trial.Has("qd." + joint)) {
    d.omega = Column(trial, "qd." + joint);
  } else {
    const std::size_t n = d.time.size();
    d.omega.assign(n, 0.0);
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t lo = k == 0 ? 0 : k - 1, hi = k + 1 == n ? k : k + 1;
      d.omega[k] = (d.theta[hi] - d.theta[lo]) / (d.time[hi] - d.time[lo]);
    }
  }
  // The model frame of [Spagnol 2013] (header): θ = s (q − q_rest).
  d.theta_rest = d.theta[0];
  const auto rest = trial.metadata.find("theta_rest");
  if (rest != trial.metadata.end()) d.theta_rest = MetadataNumber("theta_rest", rest->second);
  if (direction != 0.0) {
    d.direction = direction > 0.0 ? 1.0 : -1.0;
  } else if (const auto dir = trial.metadata.find("theta_direction"); dir != trial.metadata.end()) {
    const double s = MetadataNumber("theta_direction", dir->second);
    if (s != 1.0 && s != -1.0) {
      throw std::runtime_error("metadata theta_direction: must be 1 or -1, got " + dir->second);
    }
    d.direction = s;
  } else {
    // The anterior deltoid drives θ negative ([Spagnol 2013] Table I: ã1 < 0).
    double drive = 0.0;
    for (std::size_t k = 0; k < d.time.size(); ++k) {
      drive += (d.sigma_ant[k] - d.sigma_post[k]) * d.omega[k];
    }
    d.direction = drive > 0.0 ? -1.0 : 1.0;
  }
  for (double& q : d.theta) q = d.direction * (q - d.theta_rest);
  for (double& w : d.omega) w *= d.direction;
  return d;
}

std::vector<double> AngleToTrialFrame(const ShoulderData& data, const std::vector<double>& theta) {
  std::vector<double> q(theta.size());
  for (std::size_t k = 0; k < theta.size(); ++k) q[k] = data.theta_rest + data.direction * theta[k];
  return q;
}

std::vector<double> VelocityToTrialFrame(const ShoulderData& data,
                                         const std::vector<double>& omega) {
  std::vector<double> qd(omega.size());
  for (std::size_t k = 0; k < omega.size(); ++k) qd[k] = data.direction * omega[k];
  return qd;
}

Eigen::VectorXd ModelRegressors(ShoulderModel model, double theta_max_ant, double theta_max_post,
                                double sigma_ant, double sigma_post, double theta, double omega) {
  const double s = Sign(omega);
  if (model == ShoulderModel::kModel1) {
    Eigen::VectorXd phi(9);
    phi << sigma_ant, sigma_post, -sigma_ant * theta, -sigma_post * theta, -sigma_ant * omega,
        -sigma_post * omega, -theta, -omega, -s;
    return phi;
  }
  Eigen::VectorXd phi(7);
  phi << sigma_ant * (theta_max_ant - theta), sigma_post * (theta_max_post - theta),
      -sigma_ant * omega, -sigma_post * omega, -theta, -omega, -s;
  return phi;
}

Eigen::VectorXd ToVector(const ShoulderModel1Params& p) {
  Eigen::VectorXd v(9);
  v << p.a_ant, p.a_post, p.k_ant, p.k_post, p.r_ant, p.r_post, p.k_m, p.r_m, p.c;
  return v;
}

Eigen::VectorXd ToVector(const ShoulderModel2Params& p) {
  Eigen::VectorXd v(7);
  v << p.k_ant, p.k_post, p.r_ant, p.r_post, p.k_m, p.r_m, p.c;
  return v;
}

ShoulderModel1Params Model1FromVector(const Eigen::VectorXd& v) {
  if (v.size() != 9) throw std::invalid_argument("shoulder model 1: 9 parameters expected");
  ShoulderModel1Params p;
  p.a_ant = v(0);
  p.a_post = v(1);
  p.k_ant = v(2);
  p.k_post = v(3);
  p.r_ant = v(4);
  p.r_post = v(5);
  p.k_m = v(6);
  p.r_m = v(7);
  p.c = v(8);
  return p;
}

ShoulderModel2Params Model2FromVector(const Eigen::VectorXd& v, const ShoulderModel2Params& fixed) {
  if (v.size() != 7) throw std::invalid_argument("shoulder model 2: 7 parameters expected");
  ShoulderModel2Params p = fixed;
  p.k_ant = v(0);
  p.k_post = v(1);
  p.r_ant = v(2);
  p.r_post = v(3);
  p.k_m = v(4);
  p.r_m = v(5);
  p.c = v(6);
  return p;
}

std::vector<std::string> ParameterNames(ShoulderModel model) {
  if (model == ShoulderModel::kModel1) {
    return {"a_ant", "a_post", "k_ant", "k_post", "r_ant", "r_post", "k_m", "r_m", "c"};
  }
  return {"k_ant", "k_post", "r_ant", "r_post", "k_m", "r_m", "c"};
}

double Model1DriveAcceleration(const ShoulderModel1Params& p, double sigma_ant, double sigma_post,
                               double theta, double omega) {
  return p.a_ant * sigma_ant + p.a_post * sigma_post -
         (p.k_m + p.k_ant * sigma_ant + p.k_post * sigma_post) * theta -
         (p.r_m + p.r_ant * sigma_ant + p.r_post * sigma_post) * omega;
}

double Model2DriveAcceleration(const ShoulderModel2Params& p, double sigma_ant, double sigma_post,
                               double theta, double omega) {
  return p.k_ant * sigma_ant * (p.theta_max_ant - theta) +
         p.k_post * sigma_post * (p.theta_max_post - theta) -
         (p.r_m + p.r_ant * sigma_ant + p.r_post * sigma_post) * omega - p.k_m * theta;
}

void EulerFrictionStep(double drive, double c, double dt, bool stick_slip, double* theta,
                       double* omega) {
  const double w = *omega;
  double w_next;
  if (!stick_slip) {
    w_next = w + dt * (drive - c * Sign(w));
  } else if (w == 0.0) {
    w_next = std::abs(drive) <= c ? 0.0 : dt * (drive - c * Sign(drive));
  } else {
    w_next = w + dt * (drive - c * Sign(w));
    if (w_next * w < 0.0) w_next = 0.0;
  }
  *theta += dt * w;
  *omega = w_next;
}

ShoulderSimulation SimulateShoulder(ShoulderModel model, const Eigen::VectorXd& p,
                                    double theta_max_ant, double theta_max_post,
                                    const ShoulderData& data, bool stick_slip) {
  const std::size_t n = data.time.size();
  const int np = static_cast<int>(p.size());
  ShoulderSimulation sim;
  sim.theta.resize(n);
  sim.omega.resize(n);
  double theta = data.theta[0], omega = data.omega[0];
  for (std::size_t k = 0; k < n; ++k) {
    sim.theta[k] = theta;
    sim.omega[k] = omega;
    if (k + 1 == n) break;
    const Eigen::VectorXd phi = ModelRegressors(
        model, theta_max_ant, theta_max_post, data.sigma_ant[k], data.sigma_post[k], theta, omega);
    const double drive = phi.head(np - 1).dot(p.head(np - 1));
    EulerFrictionStep(drive, p(np - 1), data.time[k + 1] - data.time[k], stick_slip, &theta,
                      &omega);
  }
  return sim;
}

double PerformanceIndexJL(const std::vector<double>& y, const std::vector<double>& y_hat) {
  const double e = NormalisedError(y, y_hat);
  return e * e;
}

ShoulderFit FitShoulderModel(ShoulderModel model, const std::vector<ShoulderData>& trials,
                             double theta_max_ant, double theta_max_post, double known_c,
                             const Eigen::VectorXd& initial, bool zero_activation_damping) {
  if (trials.empty()) throw std::runtime_error("shoulder fit: no trials");
  const int np = model == ShoulderModel::kModel1 ? 9 : 7;
  ShoulderFit fit;
  fit.model = model;
  fit.theta_max_ant = theta_max_ant;
  fit.theta_max_post = theta_max_post;
  fit.friction_known = known_c >= 0.0;
  fit.zero_activation_damping = model == ShoulderModel::kModel2 && zero_activation_damping;
  const std::vector<int> free =
      FreeParameters(model, fit.friction_known, fit.zero_activation_damping);
  const int nfree = static_cast<int>(free.size());
  Eigen::VectorXd fixed = Eigen::VectorXd::Zero(np);
  if (fit.friction_known) fixed(np - 1) = known_c;
  Eigen::VectorXd p =
      initial.size() == np
          ? initial
          : EquationErrorStart(model, theta_max_ant, theta_max_post, trials, fixed, free);
  for (int j = 0; j < np; ++j) {
    if (std::find(free.begin(), free.end(), j) == free.end()) p(j) = fixed(j);
  }
  const auto lb = LowerBounds(model);
  auto residuals = [&](const Eigen::VectorXd& q) {
    return VelocityResiduals(model, q, theta_max_ant, theta_max_post, trials);
  };
  auto jacobian = [&](const Eigen::VectorXd& q, const Eigen::VectorXd& r0) {
    Eigen::MatrixXd J(r0.size(), nfree);
    for (int j = 0; j < nfree; ++j) {
      const double h = kFdRelativeStep * std::max(std::abs(q(free[j])), 1e-2);
      Eigen::VectorXd qp = q;
      qp(free[j]) += h;
      J.col(j) = (residuals(qp) - r0) / h;
    }
    return J;
  };
  Eigen::VectorXd r = residuals(p);
  double cost = r.squaredNorm();
  double lambda = 1e-3;
  Eigen::MatrixXd J = jacobian(p, r);
  int it = 0;
  bool converged = false;
  std::string stop_reason = "iteration_limit";
  for (; it < kMaxLmIterations && !converged; ++it) {
    const Eigen::MatrixXd A = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * r;
    bool accepted = false;
    while (!accepted && lambda < kLmMaxLambda) {
      Eigen::MatrixXd M = A;
      M.diagonal() += lambda * A.diagonal() + Eigen::VectorXd::Constant(nfree, 1e-15);
      const Eigen::VectorXd step = M.ldlt().solve(-g);
      Eigen::VectorXd trial = p;
      for (int j = 0; j < nfree; ++j) trial(free[j]) = std::max(p(free[j]) + step(j), lb[free[j]]);
      const Eigen::VectorXd r_new = residuals(trial);
      const double c_new = r_new.squaredNorm();
      if (c_new < cost) {
        const double gain = cost - c_new;
        const double moved = (trial - p).norm();
        p = trial;
        r = r_new;
        cost = c_new;
        lambda = std::max(lambda / 3.0, 1e-12);
        accepted = true;
        const bool small_gain = gain <= kLmRelativeTolerance * cost;
        const bool small_step = moved <= kLmStepTolerance * (p.norm() + kLmStepTolerance);
        converged = small_gain || small_step;
        if (converged) {
          stop_reason =
              small_gain ? "relative_cost_decrease_below_tolerance" : "step_below_tolerance";
        }
      } else {
        lambda *= 4.0;
      }
    }
    if (!accepted) {
      // No descent step left at this resolution: a local minimum — unless not a single step
      // was accepted, in which case the start point would be returned as the fit.
      converged = it > 0;
      stop_reason = "no_decrease_at_damping_limit";
      break;
    }
    J = jacobian(p, r);
  }
  fit.converged = converged;
  fit.stop_reason = stop_reason;
  fit.iterations = it;
  fit.p = p;
  fit.cost = cost;
  // Gauss–Newton covariance s² (JᵀJ)⁻¹ in parameter units; fixed parameters get 0.
  fit.ci95 = Eigen::VectorXd::Zero(np);
  const double dof = static_cast<double>(r.size()) - nfree;
  if (dof > 0) {
    const Eigen::MatrixXd A = J.transpose() * J;
    const Eigen::MatrixXd cov = (cost / dof) * A.completeOrthogonalDecomposition().pseudoInverse();
    for (int j = 0; j < nfree; ++j) fit.ci95(free[j]) = kZ95 * std::sqrt(std::max(cov(j, j), 0.0));
  }
  return fit;
}

void ThetaMaxFromMetadata(const Trial& trial, double* theta_max_ant, double* theta_max_post) {
  const ShoulderModel2Params defaults;
  *theta_max_ant = defaults.theta_max_ant;
  *theta_max_post = defaults.theta_max_post;
  auto get = [&](const std::string& key, double* out) {
    const auto it = trial.metadata.find(key);
    if (it == trial.metadata.end()) return;
    try {
      *out = std::stod(it->second);
    } catch (const std::exception&) {
      throw std::runtime_error("metadata " + key + ": not a number: " + it->second);
    }
  };
  get("theta_max_ant", theta_max_ant);
  get("theta_max_post", theta_max_post);
}

void ThetaMaxFromJointRange(double q_min, double q_max, const ShoulderData& data,
                            double* theta_max_ant, double* theta_max_post) {
  if (!(q_min < data.theta_rest && data.theta_rest < q_max)) {
    throw std::invalid_argument("shoulder model 2: rest angle " + Num(data.theta_rest) +
                                " rad outside the joint range (" + Num(q_min) + ", " + Num(q_max) +
                                ") rad");
  }
  const double a = data.direction * (q_min - data.theta_rest);
  const double b = data.direction * (q_max - data.theta_rest);
  *theta_max_ant = std::min(a, b);
  *theta_max_post = std::max(a, b);
}

double KnownFrictionFromMetadata(const Trial& trial) {
  const auto it = trial.metadata.find("friction_c");
  if (it == trial.metadata.end()) return -1.0;
  double c;
  try {
    c = std::stod(it->second);
  } catch (const std::exception&) {
    throw std::runtime_error("metadata friction_c: not a number: " + it->second);
  }
  if (!(c >= 0.0)) throw std::runtime_error("metadata friction_c: must be >= 0 rad/s^2");
  return c;
}

MethodResult RunShoulderModelMethod(ShoulderModel model, const std::vector<Trial>& train,
                                    const std::vector<Trial>& test, const ProgressFn& progress) {
  if (train.empty()) throw std::runtime_error("shoulder model: no training trials");
  std::vector<ShoulderData> data;
  data.reserve(train.size());
  for (const auto& t : train) {
    data.push_back(ExtractShoulderData(t, 10, data.empty() ? 0.0 : data[0].direction));
  }
  double tm_ant, tm_post;
  ThetaMaxFromMetadata(train[0], &tm_ant, &tm_post);
  const double known_c = KnownFrictionFromMetadata(train[0]);
  if (progress) progress(0.0, "fitting");
  const auto t0 = std::chrono::steady_clock::now();
  const ShoulderFit fit = FitShoulderModel(model, data, tm_ant, tm_post, known_c);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (progress) progress(0.9, "evaluating");

  const std::string name = model == ShoulderModel::kModel1 ? "shoulder-model1" : "shoulder-model2";
  std::string yaml = "method: " + name + "\n";
  yaml += std::string("paper: 003_7182ceb830858ebb.txt eq. ") +
          (model == ShoulderModel::kModel1 ? "2" : "3") + "\n";
  yaml += "normalisation: alpha_J = 1 (coefficients are accelerations)\n";
  yaml += "joint: " + data[0].joint + "\n";
  yaml += "frame: {theta_rest: " + Num(data[0].theta_rest) +
          ", unit: rad, direction: " + Num(data[0].direction) +
          "}  # theta = direction (q - theta_rest); anterior deltoid drives theta < 0\n";
  yaml += "fit: output-error Levenberg-Marquardt on angular velocity\n";
  yaml += "parameters:\n";
  const auto names = ParameterNames(model);
  for (std::size_t i = 0; i < names.size(); ++i) {
    yaml += "  " + names[i] + ": {value: " + Num(fit.p(i)) + ", unit: \"" + Unit(model, i) + "\"";
    if (i + 1 == names.size() && fit.friction_known) {
      yaml += ", known: true}\n";
    } else {
      yaml += ", ci95: " + Num(fit.ci95(i)) + "}\n";
    }
  }
  if (model == ShoulderModel::kModel2) {
    yaml += "fixed:\n  theta_max_ant: {value: " + Num(tm_ant) + ", unit: rad}\n";
    yaml += "  theta_max_post: {value: " + Num(tm_post) + ", unit: rad}\n";
  }
  yaml += "convergence: {converged: " + std::string(fit.converged ? "true" : "false") +
          ", stop_reason: " + fit.stop_reason + ", iterations: " + std::to_string(fit.iterations) +
          "}\n";

  MethodResult result;
  result.model_yaml = yaml;
  Json per = Json::Array();
  const auto& eval = test.empty() ? train : test;
  for (const auto& t : eval) {
    const ShoulderData d = ExtractShoulderData(t, 10, data[0].direction);
    const auto sim = SimulateShoulder(model, fit.p, tm_ant, tm_post, d, true);
    Trial pred;
    pred.metadata["method"] = name;
    pred.time = d.time;
    pred.AddColumn("q." + d.joint, AngleToTrialFrame(d, sim.theta));
    pred.AddColumn("qd." + d.joint, VelocityToTrialFrame(d, sim.omega));
    result.predictions.push_back(std::move(pred));
    Json m = Json::Object();
    m.Set("J_L_velocity_percent", 100.0 * PerformanceIndexJL(d.omega, sim.omega));
    m.Set("J_L_position_percent", 100.0 * PerformanceIndexJL(d.theta, sim.theta));
    m.Set("best_fit_velocity_percent", BestFitPercent(d.omega, sim.omega));
    m.Set("best_fit_position_percent", BestFitPercent(d.theta, sim.theta));
    per.Push(std::move(m));
  }
  result.metrics.Set("method", name);
  result.metrics.Set("evaluated_on", test.empty() ? "train" : "test");
  result.metrics.Set("trials", std::move(per));
  result.metrics.Set("training_cost_sum_J_L_velocity", fit.cost);
  result.metrics.Set("iterations", fit.iterations);
  result.metrics.Set("converged", fit.converged);
  result.metrics.Set("stop_reason", fit.stop_reason);
  if (!fit.converged) {
    result.warnings.push_back(name + " fit: did not converge (" + fit.stop_reason + " after " +
                              std::to_string(fit.iterations) + " iterations)");
  }
  result.metrics.Set("fit_wall_time_s", wall);
  if (progress) progress(1.0, "done");
  return result;
}

MethodEntry ShoulderModel1Method() {
  return {"shoulder-model1",
          "paper 003 eq. 2: activation torque, variable stiffness/damping; NLS on velocity",
          [](const std::vector<Trial>& train, const std::vector<Trial>& test,
             const ProgressFn& progress) {
            return RunShoulderModelMethod(ShoulderModel::kModel1, train, test, progress);
          }};
}

MethodEntry ShoulderModel2Method() {
  return {"shoulder-model2", "paper 003 eq. 3: muscles as variable springs; NLS on velocity",
          [](const std::vector<Trial>& train, const std::vector<Trial>& test,
             const ProgressFn& progress) {
            return RunShoulderModelMethod(ShoulderModel::kModel2, train, test, progress);
          }};
}

}  // namespace fesim::identification
