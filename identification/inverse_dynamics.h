// Inverse arm dynamics from reaching data: parametric per-joint stiffness/damping regression,
// nonparametric GP and semiparametric GP, with leave-one-trajectory-out cross-validation
// ([Schearer 2014], eq. 1–8 and §II-C).
//
// Model input x = [q; q̇; q̈] of all joints ([Schearer 2014] eq. 2), output the torque of each
// joint, one independent model per joint.
//  * Parametric (eq. 3–4): τ_j = h(x)ᵀβ = k_s (θ − θ0) + k_d θ̇ with h = [1, θ, θ̇]ᵀ,
//    β = [−k_s θ0, k_s, k_d]ᵀ, β̂ = (ΦᵀΦ)⁻¹ Φᵀ y, v_p = σ_n² (1 + hᵀ (ΦᵀΦ)⁻¹ h) with
//    σ_n² = RSS / (n − 3).
//  * Nonparametric GP (eq. 5–6): zero mean, SE-ARD kernel over the whole x, all hyper-parameters by
//    maximising the marginal likelihood.
//  * Semiparametric GP (eq. 7–8): mean h(x)ᵀβ, β ~ N(b, B) with b = β̂ and B = σ_n² (ΦᵀΦ)⁻¹ of the
//    parametric fit on the same training data (as the paper); length scales fixed a priori
//    ("small") to `semiparametric_length_scale_factor` × the standard deviation of each input;
//    σ_f and σ_n by maximising the marginal likelihood of y ~ N(Φb, K_y + Φ B Φᵀ).
// 95 % intervals are for a new observation: mean ± 1.96 √(v + σ_n²) for the GPs (v latent),
// mean ± 1.96 √v_p for the parametric model (v_p already includes σ_n²).
//
// Departures from the paper: the GP training set is subsampled evenly to at most
// `max_training_points` samples (exact GP cost is O(n³)); in cross-validation, unless
// `refit_hyper_per_fold` (metadata `invdyn.fold_hyper: refit`), the GP hyper-parameters of the fit
// on all training data are kept and each fold re-conditions the GP (and re-fits the parametric
// prior) on its training trajectories only — those hyper-parameters have seen the left-out
// trajectory.
//
// Trial conventions: q.<joint> (rad), qd.<joint> (rad/s), optional qdd.<joint> (rad/s², else
// central differences of qd.<joint>), tau.<joint> (N·m); the joints are those with a tau.<joint>
// column. Metadata `trajectory` groups repeated trials of one trajectory for
// leave-one-trajectory-out CV; without it each file is its own trajectory.
#pragma once

#include <Eigen/Dense>
#include <optional>
#include <string>
#include <vector>

#include "base/trial.h"
#include "identification/gaussian_process.h"
#include "identification/method.h"
#include "identification/method_support.h"

namespace fesim::identification {

/// Reaching samples of several trials stacked.
struct ReachingData {
  std::vector<std::string> joints;        ///< joint names (tau.<joint> suffixes), J of them.
  Eigen::MatrixXd X;                      ///< n × 3J: q (rad), q̇ (rad/s), q̈ (rad/s²).
  Eigen::MatrixXd tau;                    ///< n × J, N·m.
  std::vector<int> group;                 ///< trajectory group of each sample.
  std::vector<std::string> group_names;   ///< trajectory id of each group.
  std::vector<Eigen::Index> trial_begin;  ///< first row of each trial (plus n at the end).
};

/// Stacks trials. Throws std::runtime_error naming the column when one is missing or NaN, when
/// joints differ between trials or when a trial has fewer than `min_samples` samples.
ReachingData ExtractReachingData(const std::vector<Trial>& trials, std::size_t min_samples = 5);

/// Stiffness/damping parameters of one joint ([Schearer 2014] eq. 3, Table I).
struct JointStiffnessDamping {
  double theta0 = 0.0;  ///< equilibrium angle θ0, rad.
  double k_s = 0.0;     ///< stiffness, N·m/rad.
  double k_d = 0.0;     ///< damping, N·m·s/rad.
};

/// h(x) = [1, θ, θ̇]ᵀ ([Schearer 2014] eq. 3).
Eigen::Vector3d JointBasis(double theta, double theta_dot);

/// Parametric linear regression of one joint ([Schearer 2014] eq. 3–4).
struct ParametricJointModel {
  Eigen::Vector3d beta = Eigen::Vector3d::Zero();          ///< [−k_s θ0 (N·m), k_s, k_d]
  Eigen::Matrix3d gram_inverse = Eigen::Matrix3d::Zero();  ///< (ΦᵀΦ)⁻¹
  double noise_variance = 0.0;                             ///< σ_n², (N·m)²
  JointStiffnessDamping Params() const;
  /// Covariance of β̂: σ_n² (ΦᵀΦ)⁻¹.
  Eigen::Matrix3d BetaCovariance() const { return noise_variance * gram_inverse; }
  /// Mean (N·m) and observation variance v_p ((N·m)²).
  GpPrediction Predict(double theta, double theta_dot) const;
};

/// Least squares on n ≥ 4 samples; throws std::runtime_error when Φ is rank deficient.
ParametricJointModel FitParametricJoint(const Eigen::VectorXd& theta,
                                        const Eigen::VectorXd& theta_dot,
                                        const Eigen::VectorXd& tau);

enum class InvDynKind { kParametric, kGp, kSemiparametric };

struct InvDynOptions {
  std::size_t max_training_points = 600;  ///< GP training subsample size.
  /// ℓ_d = factor × std(x_d); trial metadata `invdyn.length_scale_factor`, (0, 100].
  double semiparametric_length_scale_factor = 0.5;
  /// BFGS iterations per joint; trial metadata `invdyn.max_hyper_iterations`, [1, 10000].
  int max_hyper_iterations = 60;
  /// Leave-one-trajectory-out CV: re-optimise the GP hyper-parameters on each fold's training
  /// trajectories ([Schearer 2014] §II.C: each model identified on its training set) instead of
  /// keeping those of the fit on all data, which has seen the left-out trajectory (cheaper: one
  /// optimisation instead of one per fold). Trial metadata `invdyn.fold_hyper: refit | full`.
  bool refit_hyper_per_fold = false;
};

/// A fitted model for all joints.
struct InvDynModel {
  InvDynKind kind = InvDynKind::kParametric;
  std::vector<std::string> joints;
  std::vector<ParametricJointModel> parametric;  ///< per joint (all kinds: the GP prior/baseline)
  std::vector<SeArdHyperParams> hyper;           ///< per joint (GP kinds)
  /// per joint (GP kinds, when the hyper-parameters were optimised): how BFGS stopped.
  std::vector<Convergence> hyper_convergence;
  std::vector<std::optional<GaussianProcess>> gp;     ///< per joint (kGp)
  std::vector<std::optional<SemiparametricGp>> spgp;  ///< per joint (kSemiparametric)
  std::size_t training_points = 0;                    ///< GP training samples used
};

/// Fits on rows of X/tau (n × 3J, n × J). With `fixed_hyper` (one per joint) the
/// hyper-parameters are not optimised.
InvDynModel FitInvDyn(InvDynKind kind, const std::vector<std::string>& joints,
                      const Eigen::MatrixXd& X, const Eigen::MatrixXd& tau,
                      const InvDynOptions& options,
                      const std::vector<SeArdHyperParams>* fixed_hyper = nullptr);

/// Predicted torque (n × J, N·m) and observation variance (n × J, (N·m)²).
struct InvDynPrediction {
  Eigen::MatrixXd mean, variance;
};
/// With `with_variance` false only the means are computed (variance left zero), batched.
InvDynPrediction PredictInvDyn(const InvDynModel& model, const Eigen::MatrixXd& X,
                               bool with_variance = true);

/// Leave-one-trajectory-out CV: RMS error per fold and joint, normalised by the joint's maximum
/// |τ| over the whole data set ([Schearer 2014] §II-C, Fig. 5).
struct InvDynCv {
  std::vector<std::string> folds;  ///< left-out trajectory ids
  Eigen::MatrixXd nrmse;           ///< folds × J, dimensionless
  Eigen::VectorXd training_nrmse;  ///< J: mean training error over folds
  Eigen::VectorXd max_torque;      ///< J, N·m
  /// With refit_hyper_per_fold: the folds' hyper-parameter optimisations (folds × joints) and
  /// how many of them stopped without converging (e.g. at max_hyper_iterations).
  int fold_hyper_fits = 0;
  int fold_hyper_not_converged = 0;
};
InvDynCv LeaveOneTrajectoryOut(InvDynKind kind, const ReachingData& data,
                               const InvDynOptions& options, const InvDynModel& full_fit);

/// Box-plot statistics of a sample: 5, 25, 50, 75, 95 % percentiles (linear interpolation).
struct BoxStats {
  double p05 = 0, p25 = 0, median = 0, p75 = 0, p95 = 0;
};
BoxStats BoxPlotStats(std::vector<double> values);

/// `fesim identify --method invdyn-parametric | invdyn-gp | invdyn-semiparametric`.
MethodResult RunInvDynMethod(InvDynKind kind, const std::vector<Trial>& train,
                             const std::vector<Trial>& test, const ProgressFn& progress);
MethodEntry InvDynParametricMethod();
MethodEntry InvDynGpMethod();
MethodEntry InvDynSemiparametricMethod();

}  // namespace fesim::identification
