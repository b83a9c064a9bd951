// Extended Kalman filter steps (generic, fixed-size Eigen) and the online identification of the
// antagonistic shoulder model 2 ([Spagnol 2013] §IV, eq. 4–17).
//
// Generic filter, for x(k+1) = f(x(k), u(k)) + η_x, y(k) = C x(k) + η_y with Cov η_x = Q,
// Cov η_y = R and no cross-covariance ([Spagnol 2013]: V12 = 0):
//   measurement update   L = P⁻Cᵀ (C P⁻ Cᵀ + R)⁻¹,  x⁺ = x⁻ + L (y − C x⁻),
//                        P⁺ = (I − L C) P⁻ (I − L C)ᵀ + L R Lᵀ          (Joseph form)
//   time update          x⁻(k+1) = f(x⁺(k), u(k)),  P⁻(k+1) = F P⁺ Fᵀ + Q,  F = ∂f/∂x at x⁺(k)
// [Spagnol 2013] eq. 11, 16–17 write the same filter in one-step predictor form (gain applied to
// the prediction); with V12 = 0 the two give the same predictions. We use the filter form so that
// the estimate at k already uses y(k), and the Joseph form so that P stays symmetric positive
// definite in floating point.
//
// Shoulder EKF ([Spagnol 2013] eq. 4–10, 13–15): augmented state
//   x = [θ (rad), ω (rad/s), K_ant (s⁻²), K_post (s⁻²), R_m (s⁻¹), K_m (s⁻²)],
//   u = [σ_ant, σ_post, f_s(ω) = c sign(ω_measured) (rad/s²)], y = [θ, ω],
// forward Euler with the sample interval Δt:
//   θ⁺ = θ + Δt ω
//   ω⁺ = ω + Δt (−(K_m + K_ant σ_ant + K_post σ_post) θ − R_m ω + θmax_ant K_ant σ_ant
//                 + θmax_post K_post σ_post − f_s)
//   parameters⁺ = parameters (random walk through Q, which lets the filter follow fatigue).
// Departures: R_ant = R_post = 0 ([Spagnol 2013] Table II found them zero and §IV drops them); Q is
// given as rates (variance per second, Q = q Δt) so tuning does not depend on the sample rate;
// samples with a NaN measurement skip the measurement update. The friction input f_s = c sign(ω)
// takes the sign of the filter's ω estimate, not of the measured ω as eq. 6 does: at rest the
// measured ω is noise (fesim's shoulder_exo gyroscope: 1°/s) whose sign flips from sample to
// sample, and ±c (0.5–0.8 rad/s² fitted on the full benchmark study) then kicks the model at
// every step, which the filter explains with its parameters. On that study the estimates' mean
// differences from the offline fit of the same trial went from −51 … +9 % (measured sign) to
// −18 … +14 % (estimated sign); the offline fit simulates with its own ω too.
//
// Trial conventions: as shoulder_models.h (a.* or u.* activations, q.<joint>, optional qd.<joint>,
// the model frame θ = s (q − q_rest); the filtered θ, ω are reported back in the trial's frame).
// Optional metadata: ekf.<tuning field> (e.g. `ekf.r_omega: 1e-4`, `ekf.q_k_ant: 1e-3`, fields and
// units of ShoulderEkfTuning; `ekf.k_ant` etc. set the initial guess) overrides the defaults, and
// an unknown ekf.* key is an error; friction_c (rad/s²; else the offline model-2 fit provides c),
// theta_max_ant / theta_max_post (rad), and ground truth for reports: true_k_ant, true_k_post
// (s⁻²), true_r_m (s⁻¹), true_k_m (s⁻²).
#pragma once

#include <Eigen/Dense>
#include <array>
#include <string>
#include <vector>

#include "identification/method.h"
#include "identification/shoulder_models.h"

namespace fesim::identification {

/// Joseph-form measurement update (see header comment). Sizes are compile-time.
template <int N, int M>
void KalmanMeasurementUpdate(const Eigen::Matrix<double, M, N>& C,
                             const Eigen::Matrix<double, M, M>& R,
                             const Eigen::Matrix<double, M, 1>& y, Eigen::Matrix<double, N, 1>* x,
                             Eigen::Matrix<double, N, N>* P) {
  const Eigen::Matrix<double, N, M> PCt = (*P) * C.transpose();
  const Eigen::Matrix<double, M, M> S = C * PCt + R;
  const Eigen::Matrix<double, N, M> L = S.llt().solve(PCt.transpose()).transpose();
  *x += L * (y - C * (*x));
  const Eigen::Matrix<double, N, N> IminusLC = Eigen::Matrix<double, N, N>::Identity() - L * C;
  *P = IminusLC * (*P) * IminusLC.transpose() + L * R * L.transpose();
}

/// Time update: x ← x_next, P ← F P Fᵀ + Q (symmetrised).
template <int N>
void KalmanTimeUpdate(const Eigen::Matrix<double, N, 1>& x_next,
                      const Eigen::Matrix<double, N, N>& F, const Eigen::Matrix<double, N, N>& Q,
                      Eigen::Matrix<double, N, 1>* x, Eigen::Matrix<double, N, N>* P) {
  *x = x_next;
  const Eigen::Matrix<double, N, N> Pn = F * (*P) * F.transpose() + Q;
  *P = 0.5 * (Pn + Pn.transpose());
}

using ShoulderEkfVector = Eigen::Matrix<double, 6, 1>;
using ShoulderEkfMatrix = Eigen::Matrix<double, 6, 6>;

/// The four parameters the EKF tracks ([Spagnol 2013] eq. 4), model-2 units.
struct ShoulderEkfParams {
  double k_ant = 1.0;   ///< K̃1, s⁻²
  double k_post = 1.0;  ///< K̃2, s⁻²
  double r_m = 1.0;     ///< R̃m, s⁻¹
  double k_m = 1.0;     ///< K̃m, s⁻²
};

/// Filter tuning (the paper tunes V1 iteratively, V2 from data and P(0) "very high").
struct ShoulderEkfTuning {
  double q_theta = 1e-8;    ///< process noise rate on θ, rad²/s
  double q_omega = 1e-6;    ///< process noise rate on ω, (rad/s)²/s
  double q_k_ant = 1e-4;    ///< random-walk rate on K_ant, s⁻⁴/s
  double q_k_post = 1e-4;   ///< random-walk rate on K_post, s⁻⁴/s
  double q_r_m = 1e-4;      ///< random-walk rate on R_m, s⁻²/s
  double q_k_m = 1e-4;      ///< random-walk rate on K_m, s⁻⁴/s
  double r_theta = 1e-2;    ///< measurement variance of θ, rad² (large: position weighted low)
  double r_omega = 1e-4;    ///< measurement variance of ω, (rad/s)²
  double p0_theta = 1e-4;   ///< initial variance of θ, rad²
  double p0_omega = 1e-4;   ///< initial variance of ω, (rad/s)²
  double p0_param = 100.0;  ///< initial variance of each parameter, its unit squared
};

/// Everything fixed for one filter run.
struct ShoulderEkfConfig {
  double theta_max_ant = ShoulderModel2Params().theta_max_ant;    ///< rad
  double theta_max_post = ShoulderModel2Params().theta_max_post;  ///< rad
  double friction_c = 0.0;                                        ///< rad/s², ≥ 0
  /// f_s = c sign(ω) with ω measured, as [Spagnol 2013] eq. 6; false (default): ω the filter's
  /// estimate after the measurement update (see the header: departure).
  bool friction_sign_from_measurement = false;
  ShoulderEkfParams initial;  ///< initial parameter guess
  ShoulderEkfTuning tuning;
};

/// [Spagnol 2013] eq. 9–10: f(x, u) with forward Euler, dt in s, friction input f_s in rad/s².
ShoulderEkfVector ShoulderEkfTransition(const ShoulderEkfVector& x, double sigma_ant,
                                        double sigma_post, double friction, double dt,
                                        double theta_max_ant, double theta_max_post);

/// [Spagnol 2013] eq. 13–15: F = ∂f/∂x.
ShoulderEkfMatrix ShoulderEkfJacobian(const ShoulderEkfVector& x, double sigma_ant,
                                      double sigma_post, double dt, double theta_max_ant,
                                      double theta_max_post);

/// The online estimator. Call Update(y(k)) then Predict(u(k), Δt) for each sample.
class ShoulderEkf {
 public:
  /// Starts at θ = theta0 (rad), ω = omega0 (rad/s) and the configured parameter guess.
  ShoulderEkf(const ShoulderEkfConfig& config, double theta0, double omega0);
  /// Measurement update with θ (rad), ω (rad/s); NaN in either skips the update.
  void Update(double theta, double omega);
  /// Time update over dt (s) with activations and the measured velocity (rad/s; its sign sets
  /// f_s only with friction_sign_from_measurement, and NaN falls back to the estimate).
  void Predict(double sigma_ant, double sigma_post, double omega_measured, double dt);

  const ShoulderEkfVector& state() const { return x_; }
  const ShoulderEkfMatrix& covariance() const { return P_; }
  ShoulderEkfParams params() const;

 private:
  ShoulderEkfConfig config_;
  ShoulderEkfVector x_;
  ShoulderEkfMatrix P_;
};

/// The filtered estimates over one trial (after each measurement update).
struct ShoulderEkfRun {
  std::vector<double> time;               ///< s
  std::vector<double> theta, omega;       ///< filtered θ (rad), ω (rad/s)
  std::vector<ShoulderEkfParams> params;  ///< parameter estimate per sample
};

/// Runs the filter over a trial.
ShoulderEkfRun RunShoulderEkf(const ShoulderEkfConfig& config, const ShoulderData& data);

/// First time (s) from which `values` stays within ±band·|final| of its final value
/// (band = 0.05 for the ±5 % of issue 5); NaN when empty.
double ConvergenceTime(const std::vector<double>& time, const std::vector<double>& values,
                       double band);

/// Mean of `values` over the samples with time ≥ t_from.
double MeanFrom(const std::vector<double>& time, const std::vector<double>& values, double t_from);

/// Applies the ekf.* metadata overrides of `trial` to `config`; throws std::runtime_error naming
/// the key when it is unknown, not a number or negative.
void ApplyEkfMetadata(const Trial& trial, ShoulderEkfConfig* config);

/// `fesim identify --method shoulder-ekf`: offline fit of `train` with the filter's model (model 2,
/// R_ant = R_post = 0) for c, then the filter on each trial of `test` (or `train`). Predictions
/// are the filtered θ, ω (q.<joint>, qd.<joint>) and the parameter tracks (param.k_ant,
/// param.k_post, param.r_m, param.k_m); metrics give J_L, per-parameter convergence time (±5 %
/// band), mean after convergence and % error against the offline fit of the same trial with the
/// same model and c ([Spagnol 2013] Table IV: "using the same data set"; `offline_same_trial`)
/// and against metadata true_* values.
MethodResult RunShoulderEkfMethod(const std::vector<Trial>& train, const std::vector<Trial>& test,
                                  const ProgressFn& progress);
/// Registry entry for `fesim identify --method shoulder-ekf`.
MethodEntry ShoulderEkfMethod();

}  // namespace fesim::identification
