// Antagonistic shoulder models for horizontal shoulder abduction/adduction under FES, and their
// offline identification ([Spagnol 2013], docs/papers.md).
//
// Both models are normalised so that αJ = 1 ([Spagnol 2013] §III-B): every coefficient is divided
// by the rotational inertia and is therefore an acceleration coefficient. Index "ant" is the
// anterior deltoid (paper index 1, horizontal adduction), "post" the posterior deltoid (paper index
// 2, horizontal abduction). θ is the horizontal shoulder angle, rad, 0 at rest; ω = dθ/dt, rad/s.
//
// Model 1 ([Spagnol 2013] eq. 2, written "eq. 1" in issue 5):
//   θ̈ = a_ant σ_ant + a_post σ_post − (K_m + K_ant σ_ant + K_post σ_post) θ
//        − (R_m + R_ant σ_ant + R_post σ_post) ω − c sign(ω)
// Model 2 ([Spagnol 2013] eq. 3, muscle as a variable spring about its maximum angle):
//   θ̈ = K_ant σ_ant (θmax_ant − θ) + K_post σ_post (θmax_post − θ)
//        − (R_m + R_ant σ_ant + R_post σ_post) ω − K_m θ − c sign(ω)
// Both are linear in their identified parameters: θ̈ = φ(σ, θ, ω)ᵀ p (ModelRegressors).
//
// Departures from the paper:
//  * The numeric values of θmax were lost in the text extraction of [Spagnol 2013] ("6 5π", "3 π");
//    we read them as |θmax_ant| = 5π/16 and |θmax_post| = π/3 with signs chosen so that the
//    anterior deltoid drives θ negative, as ã1 < 0 in [Spagnol 2013] Table I. They are trial
//    metadata `theta_max_ant` / `theta_max_post` (rad) when present. The paper calls them "the
//    maximum reachable angles" — of its rig: on another rig whose arm travels beyond them the
//    torque K σ (θmax − θ) turns around and the fit fails, so `fesim benchmark` sets them to the
//    ends of the rig's joint range (ThetaMaxFromJointRange).
//  * Simulation is forward Euler at the sample times (as the EKF discretisation, eq. 7–10), with a
//    Karnopp-style stick rule for the Coulomb friction: the velocity stops at zero instead of
//    reversing, and stays at zero while |drive| ≤ c. The paper's friction model is sign(ω) only.
//  * Offline fitting: equation-error linear least squares (θ̈ from differenced velocity) gives the
//    start, then Levenberg–Marquardt on the simulated angular velocity ([Spagnol 2013] §III-A) with
//    finite-difference Jacobian and bounds K, R, c ≥ 0.
//
// Trial conventions (fesim::Trial):
//  * activations a.<muscle> (0–1): the column whose name contains "anterior" (else the first a.*)
//    is σ_ant, the one containing "posterior" (else the second) is σ_post. Without a.* columns the
//    u.<channel> pulse widths (µs) are used the same way, σ = u / 300 µs (no recruitment curve).
//  * q.<joint> (rad): the first q.* column unless metadata `joint` names one; optional qd.<joint>
//    (rad/s), else central differences of q.
//  * the model's frame is [Spagnol 2013]'s (§II-A, Table I): θ = 0 at the rest position and the
//    anterior deltoid (adduction) drives θ negative. A trial's joint angle q may be measured from
//    another zero and with the other sign (fesim's shoulder_elv_plane: rest 14°, adduction
//    positive), so θ = s (q − q_rest), ω = s q̇ with q_rest = metadata `theta_rest` (rad, in
//    the trial's frame) else q at the first sample (the trials start at rest), and s = metadata
//    `theta_direction` (+1 or −1) else −sign Σ (σ_ant − σ_post) q̇ (the sign that makes the
//    anterior deltoid drive θ negative on this trial). Predictions go back to the trial's frame.
//    Model 1 (free-signed a) is indifferent to s; model 2's fixed θmax are not.
//  * optional metadata `friction_c` (rad/s²): known Coulomb friction, then c is not identified.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "base/trial.h"
#include "identification/method.h"

namespace fesim::identification {

/// Pulse width that maps to full activation when only u.* columns are present, µs.
constexpr double kShoulderFullActivationPulseWidthUs = 300.0;

/// [Spagnol 2013] eq. 2 coefficients, normalised by αJ (αJ = 1).
struct ShoulderModel1Params {
  double a_ant = 0.0;   ///< ã1, active torque coefficient of the anterior deltoid, rad/s².
  double a_post = 0.0;  ///< ã2, active torque coefficient of the posterior deltoid, rad/s².
  double k_ant = 0.0;   ///< K̃1, activation-dependent stiffness, s⁻², ≥ 0.
  double k_post = 0.0;  ///< K̃2, activation-dependent stiffness, s⁻², ≥ 0.
  double r_ant = 0.0;   ///< R̃1, activation-dependent damping, s⁻¹, ≥ 0.
  double r_post = 0.0;  ///< R̃2, activation-dependent damping, s⁻¹, ≥ 0.
  double k_m = 0.0;     ///< K̃m, passive (exoskeleton) stiffness, s⁻², ≥ 0.
  double r_m = 0.0;     ///< R̃m, passive damping, s⁻¹, ≥ 0.
  double c = 0.0;       ///< c̃, Coulomb friction, rad/s², ≥ 0.
};

/// [Spagnol 2013] eq. 3 coefficients, normalised by αJ (αJ = 1).
struct ShoulderModel2Params {
  double k_ant = 0.0;   ///< K̃1, stiffness per unit anterior activation, s⁻², ≥ 0.
  double k_post = 0.0;  ///< K̃2, stiffness per unit posterior activation, s⁻², ≥ 0.
  double r_ant = 0.0;   ///< R̃1, damping per unit anterior activation, s⁻¹, ≥ 0.
  double r_post = 0.0;  ///< R̃2, damping per unit posterior activation, s⁻¹, ≥ 0.
  double k_m = 0.0;     ///< K̃m, passive stiffness, s⁻², ≥ 0.
  double r_m = 0.0;     ///< R̃m, passive damping, s⁻¹, ≥ 0.
  double c = 0.0;       ///< c̃, Coulomb friction, rad/s², ≥ 0.
  double theta_max_ant = -5.0 * 3.14159265358979323846 / 16.0;  ///< θmax,1, rad (fixed).
  double theta_max_post = 3.14159265358979323846 / 3.0;         ///< θmax,2, rad (fixed).
};

enum class ShoulderModel { kModel1, kModel2 };

/// One shoulder trial in SI units, extracted from a fesim::Trial.
struct ShoulderData {
  std::vector<double> time;        ///< s, strictly increasing.
  std::vector<double> sigma_ant;   ///< anterior activation, 0–1.
  std::vector<double> sigma_post;  ///< posterior activation, 0–1.
  std::vector<double> theta;       ///< angle, rad.
  std::vector<double> omega;       ///< angular velocity, rad/s.
  std::string joint;               ///< joint name (the q.<joint> suffix).
  double theta_rest = 0.0;         ///< q at θ = 0, rad, in the trial's frame.
  double direction = 1.0;          ///< s of θ = s (q − theta_rest), ±1.
};

/// Reads a trial by the conventions above into the model's frame; `direction` ±1 replaces the
/// metadata / inferred s (a test trial takes its training trial's s), 0 leaves it to them.
/// Throws std::runtime_error naming the column when a column is missing, fewer than
/// `min_samples` samples are present or a value is NaN, and naming the key when metadata
/// theta_rest / theta_direction is malformed.
ShoulderData ExtractShoulderData(const Trial& trial, std::size_t min_samples = 10,
                                 double direction = 0.0);

/// Back to the trial's frame: q = q_rest + s θ (rad), q̇ = s ω (rad/s).
std::vector<double> AngleToTrialFrame(const ShoulderData& data, const std::vector<double>& theta);
std::vector<double> VelocityToTrialFrame(const ShoulderData& data,
                                         const std::vector<double>& omega);

/// Regressor vector φ with θ̈ = φᵀ p (friction included as its last element, −sign(ω)).
/// Model 1: p = (a_ant, a_post, k_ant, k_post, r_ant, r_post, k_m, r_m, c).
/// Model 2: p = (k_ant, k_post, r_ant, r_post, k_m, r_m, c); θmax enter through φ.
Eigen::VectorXd ModelRegressors(ShoulderModel model, double theta_max_ant, double theta_max_post,
                                double sigma_ant, double sigma_post, double theta, double omega);

/// Conversions between the named structs and the ordered vector p of ModelRegressors.
Eigen::VectorXd ToVector(const ShoulderModel1Params& p);
Eigen::VectorXd ToVector(const ShoulderModel2Params& p);
ShoulderModel1Params Model1FromVector(const Eigen::VectorXd& v);
/// θmax are not in v; they are copied from `fixed`.
ShoulderModel2Params Model2FromVector(const Eigen::VectorXd& v, const ShoulderModel2Params& fixed);
/// Names of the entries of p, in order (for reports).
std::vector<std::string> ParameterNames(ShoulderModel model);

/// θ̈ without the friction term, rad/s² ([Spagnol 2013] eq. 2 / eq. 3 solved for θ̈, c = 0).
double Model1DriveAcceleration(const ShoulderModel1Params& p, double sigma_ant, double sigma_post,
                               double theta, double omega);
double Model2DriveAcceleration(const ShoulderModel2Params& p, double sigma_ant, double sigma_post,
                               double theta, double omega);

/// One forward-Euler step of θ̈ = drive − c sign(ω): θ⁺ = θ + Δt ω,
/// ω⁺ = ω + Δt (drive − c sign ω). With `stick_slip` the velocity stops at 0 instead of changing
/// sign and stays 0 while |drive| ≤ c. drive, c in rad/s²; dt in s.
void EulerFrictionStep(double drive, double c, double dt, bool stick_slip, double* theta,
                       double* omega);

/// Simulated (θ, ω) from the measured initial state with the measured activations.
struct ShoulderSimulation {
  std::vector<double> theta;  ///< rad
  std::vector<double> omega;  ///< rad/s
};
ShoulderSimulation SimulateShoulder(ShoulderModel model, const Eigen::VectorXd& p,
                                    double theta_max_ant, double theta_max_post,
                                    const ShoulderData& data, bool stick_slip);

/// [Spagnol 2013] eq. 1: J_L(y, ŷ) = Σ (y − ŷ)² / Σ (y − ȳ)² (as a fraction; ×100 for %).
double PerformanceIndexJL(const std::vector<double>& y, const std::vector<double>& y_hat);

/// Result of an offline fit.
struct ShoulderFit {
  ShoulderModel model = ShoulderModel::kModel2;
  Eigen::VectorXd p;                     ///< identified p (ModelRegressors order).
  Eigen::VectorXd ci95;                  ///< 95 % half-widths from the Gauss–Newton covariance.
  double theta_max_ant = 0.0;            ///< rad
  double theta_max_post = 0.0;           ///< rad
  bool friction_known = false;           ///< c was given (metadata friction_c), not fitted.
  bool zero_activation_damping = false;  ///< model 2 with R̃_ant = R̃_post = 0 held fixed.
  double cost = 0.0;                     ///< Σ J_L(ω) over trials at the optimum.
  int iterations = 0;                    ///< Levenberg–Marquardt iterations.
  bool converged = false;                ///< false when the iteration limit stopped the fit.
  /// "relative_cost_decrease_below_tolerance", "step_below_tolerance", "iteration_limit", or
  /// "no_decrease_at_damping_limit" (converged after ≥ 1 accepted step; not converged when no
  /// step from the start point lowered the cost, so the start is never returned as a fit).
  std::string stop_reason;
};

/// Offline nonlinear least squares on angular velocity ([Spagnol 2013] §III-A). `initial`
/// (optional, may be empty) replaces the equation-error start. `known_c` < 0 means "fit c".
/// `zero_activation_damping` (model 2 only) holds R̃_ant = R̃_post = 0: the simplified model 2
/// that [Spagnol 2013] §III-C arrives at (Table II(a): both zero) and §IV's EKF (eq. 4) tracks.
ShoulderFit FitShoulderModel(ShoulderModel model, const std::vector<ShoulderData>& trials,
                             double theta_max_ant, double theta_max_post, double known_c,
                             const Eigen::VectorXd& initial = Eigen::VectorXd(),
                             bool zero_activation_damping = false);

/// `fesim identify` entries: shoulder-model1 and shoulder-model2.
MethodResult RunShoulderModelMethod(ShoulderModel model, const std::vector<Trial>& train,
                                    const std::vector<Trial>& test, const ProgressFn& progress);

/// Registry entries for `fesim identify --method shoulder-model1 | shoulder-model2`.
MethodEntry ShoulderModel1Method();
MethodEntry ShoulderModel2Method();

/// θmax from trial metadata (theta_max_ant / theta_max_post, rad), else the defaults above.
void ThetaMaxFromMetadata(const Trial& trial, double* theta_max_ant, double* theta_max_post);

/// Model 2's θmax on a given rig. [Spagnol 2013] eq. 3 defines θmax,1 and θmax,2 as "the maximum
/// reachable angles": a property of the paper's exoskeleton and subject, not a constant. On
/// another rig they are the ends q_min < q_max (rad, the trial's frame) of its joint range, taken
/// into the model's frame θ = s (q − q_rest) of `data`: the anterior deltoid's θmax is the end
/// with θ < 0, the posterior's the end with θ > 0 (rad). Throws std::invalid_argument unless
/// q_min < data.theta_rest < q_max.
void ThetaMaxFromJointRange(double q_min, double q_max, const ShoulderData& data,
                            double* theta_max_ant, double* theta_max_post);

/// Known friction from metadata friction_c (rad/s²), or −1 when absent.
double KnownFrictionFromMetadata(const Trial& trial);

}  // namespace fesim::identification
