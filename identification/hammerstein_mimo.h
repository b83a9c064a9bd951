// MIMO Hammerstein model of the hand and wrist under electrode-array FES, and its two-step
// identification.
//
// Paper: [Hand Hammerstein] (docs/papers.md), §3–5.
//   Ỹ(s) = H(s, Θ) D(d) L(h(u, Φ)),  ỹ = r − y                                        eq. (16)
//   H = diag(H̃(s, θ_1) … H̃(s, θ_q)),
//   H̃(s, θ_i) = 1 / ((μ_i/Ω²) s³ + (2μ_i/Ω + 1/Ω²) s² + (μ_i + 2/Ω) s + 1)
//             = 1 / ((1 + μ_i s)(1 + s/Ω)²)                                          eq. (17)–(18)
//   Θ = [Ω, μ_1 … μ_q]                                                                 eq. (19)
//   D ∈ R^{q×l}, h_j = h̃(u, φ_j) (sigmoid, see recruitment_bijection.h)                eq.
//   (21)–(24)
// Identification (§4, Fig. 4): step 1, static d and Ψ on the steady-state set 𝒳 (eq. 35, 42)
// through the bijection M (eq. 37–41); step 2, Θ by gradient-based (Levenberg–Marquardt) fitting
// of the simulated response to the dynamic data (eq. 43–44 in the time domain, cost eq. 32).
// Bounds of §5.1: Ω ∈ [0, 10] rad/s, d ∈ [−150°, 150°] (paper's angles in degrees, here
// ±2.618 rad), u^db ∈ [20, 280] µs, u^sat ∈ [42, 600] µs. The number of muscle units l is a
// hyper-parameter (Remark 9), default l = n.
//
// Trial conventions: inputs = every u.<channel> column (pulse width, µs), outputs = every
// q.<joint> column (rad), same names in all trials, uniformly sampled. 𝒳 is built from the
// step-grid protocol (§5.1): each run of identical input vectors lasting ≥ min_step_s contributes
// one point, the mean of its last ss_window_s of samples. The resting angle r (eq. 16) is the mean
// output of the zero-input points of 𝒳 (the first sample of the first trial if there are none).
//
// Departures, stated:
// * Eq. (20) writes μ_i = b_i/(η_i − k_i); with the stiffness dominating gravity (k_i > η_i) that
//   is negative and the pole −1/μ_i unstable, a sign slip of eq. (27)–(28). μ_i ≥ 0 (s) here, the
//   joint time constant b_i/(k_i − η_i); bound μ_i ∈ [0, 5] s (not given in the paper).
// * Costs are sums of squares (eq. 32) also in the static step, where eq. (36)/(42) sums norms;
//   the two share the noiseless optimum. d is eliminated by bounded linear least squares for each
//   Ψ (variable projection), so the global search runs over Ψ only: multi-start bounded LM from
//   `starts` points drawn uniformly in the bounds (fixed seed), as §5.1 does with interior point.
// * Ω lower bound 0.01 rad/s instead of 0 (Ω = 0 makes eq. 18 singular).
// * Simulation: exact zero-order-hold discretisation of H̃ at the trial sample period, started
//   at the steady state of the first input sample.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "identification/method.h"
#include "identification/method_support.h"
#include "identification/recruitment_bijection.h"

namespace fesim::identification {

/// Parameters of eq. (16).
struct HammersteinMimoParams {
  std::vector<CutoffParams> psi;  ///< Ψ = M(Φ), one per muscle unit (l), µs.
  Eigen::MatrixXd d_rad;          ///< D, q×l, rad per unit activation.
  double omega_rad_s = 5.0;       ///< Ω, rad/s, (0, 10].
  Eigen::VectorXd mu_s;           ///< μ_i, s, ≥ 0, one per joint (q).
  Eigen::VectorXd rest_rad;       ///< r, rad, one per joint (q).
};

/// Bounds of §5.1 and the ones this implementation adds.
struct HammersteinMimoBounds {
  double omega_min_rad_s = 0.01, omega_max_rad_s = 10.0;
  double d_abs_max_rad = 150.0 * 3.14159265358979323846 / 180.0;
  double u_db_min_us = 20.0, u_db_max_us = 280.0;
  double u_sat_min_us = 42.0, u_sat_max_us = 600.0;
  double mu_min_s = 0.0, mu_max_s = 5.0;
};

/// How the dynamic step obtains JᵀJ and Jᵀr of its residual.
enum class DynamicJacobian {
  /// Exact discrete sensitivities ∂ŷ/∂Ω, ∂ŷ/∂μ_i propagated in the residual's simulation pass
  /// (DiscretiseJointSensitivities); the default.
  kExactSensitivities,
  /// Structured forward differences, relative step 1e-7 (Ω stepped inwards): two perturbed
  /// simulations per trial and joint at each accepted step.
  kForwardDifference,
};

struct HammersteinMimoOptions {
  int muscles_l = 0;       ///< l; 0 means l = number of inputs n.
  int starts = 20;         ///< multi-start local optimisations of the static step, ≥ 1.
  int dynamic_starts = 3;  ///< local optimisations of Θ (Ω spread over its range), ≥ 1.
  unsigned seed = 1;       ///< start points.
  DynamicJacobian dynamic_jacobian = DynamicJacobian::kExactSensitivities;
  double min_step_s = 1.0;   ///< shortest constant-input segment used for 𝒳, s.
  double ss_window_s = 0.2;  ///< averaging window at each segment's end, s.
  HammersteinMimoBounds bounds;
};

/// The steady-state set 𝒳 (eq. 35–36).
struct SteadyStateSet {
  Eigen::MatrixXd u_us;   ///< S×n inputs, µs.
  Eigen::MatrixXd y_rad;  ///< S×q measured outputs y (not ỹ), rad.
};

/// Input/output samples of one trial.
struct MimoTrialData {
  Eigen::MatrixXd u_us;        ///< N×n, µs.
  Eigen::MatrixXd y_rad;       ///< N×q, rad.
  double sample_period_s = 0;  ///< T, s.
};

struct HammersteinMimoFit {
  HammersteinMimoParams params;
  std::vector<double> static_step_wall_s;   ///< wall time of each static local optimisation, s.
  std::vector<double> dynamic_step_wall_s;  ///< wall time of each dynamic local optimisation, s.
  /// CPU time of the calling thread for each static / dynamic local optimisation, s (the steadier
  /// figure on a loaded machine; the fit is single-threaded).
  std::vector<double> static_step_cpu_s, dynamic_step_cpu_s;
  std::vector<int> static_step_iterations;   ///< LM iterations per static start.
  std::vector<int> dynamic_step_iterations;  ///< LM iterations per dynamic start.
  /// Simulation passes over all trials per dynamic start: residual evaluations (fused with the
  /// sensitivities on the exact path) plus, on the forward-difference path, two per Jacobian.
  std::vector<int> dynamic_step_evaluations;
  std::vector<Convergence> static_step_convergence;   ///< per static start: converged, why.
  std::vector<Convergence> dynamic_step_convergence;  ///< per dynamic start: converged, why.
  std::size_t static_best_run = 0;   ///< index of the static start whose Ψ is kept.
  std::size_t dynamic_best_run = 0;  ///< index of the dynamic start whose Θ is kept.
  double static_cost = 0.0;          ///< Σ‖ỹ − D h‖² on 𝒳, rad².
  double dynamic_cost = 0.0;         ///< Σ‖y − ŷ‖² on the dynamic data, rad².
  double total_wall_s = 0.0;
  Eigen::VectorXd psi_ci95;    ///< half-widths of Ψ in the order of PackCutoffs, µs.
  Eigen::MatrixXd d_ci95;      ///< half-widths of D (conditional on Ψ), rad.
  Eigen::VectorXd theta_ci95;  ///< half-widths of [Ω, μ_1 … μ_q].
};

/// h(u, Φ) = [h̃(u, φ_1) … h̃(u, φ_l)] (eq. 22–23).
Eigen::VectorXd MuscleActivations(const std::vector<SigmoidParams>& phi,
                                  const Eigen::VectorXd& u_us);

/// Static model ỹ_ss = D h(u, M⁻¹(Ψ)) (eq. 35), rad.
Eigen::VectorXd StaticDeflection(const HammersteinMimoParams& p, const Eigen::VectorXd& u_us);

/// Zero-order-hold discretisation of H̃(s, θ_i) (eq. 18): x⁺ = Ad x + Bd z, ỹ = C x.
struct JointFilter {
  Eigen::Matrix3d Ad;
  Eigen::Vector3d Bd;
  Eigen::RowVector3d C;
};
JointFilter DiscretiseJointDynamics(double omega_rad_s, double mu_s, double sample_period_s);

/// The ZOH discretisation of H̃(s, θ_i) (eq. 18) augmented with two states whose outputs are
/// its exact parameter sensitivities. With y the joint's filter output and P(s) = 1/(1 + s/Ω),
/// L(s) = 1/(1 + μ_i s), so H̃ = L P²:
///   ∂H̃/∂Ω = (2/Ω) (H̃ − P H̃)           (∂P/∂Ω = P (1 − P)/Ω),
///   ∂H̃/∂μ = −(1/μ) (H̃ − L H̃)           (∂L/∂μ = −L (1 − L)/μ),
/// so with v = P y and u = L y (v̇ = Ω(y − v), u̇ = (y − u)/μ) the states a = y − v and
/// b = y − u (ȧ = ẏ − Ω a, ḃ = ẏ − b/μ) give
///   ∂y/∂Ω = (2/Ω) a,  ∂y/∂μ = −b/μ.
/// States x1, x2, x3, a, b; y = x3 always (for μ ≤ kMuNegligible_s, where the model is P², x3
/// follows x2's equation, x3 ≡ x2). At μ = 0 the right derivative is ∂y/∂μ = −ẏ = −Ω(x1 − x2), so
/// b = x1 − x2 and ∂y/∂μ = −Ω b there; the same limit is used for 0 < μ ≤ 5e-7 s, where b/μ
/// would lose its digits (relative error ≲ 3e-5 there; ≤ 1e-6 for μ = 0 and μ ≥ 2e-6 s).
/// The ZOH of the augmented system is exact for piecewise-constant z, so the sampled a, b (and the
/// sensitivities) are exact samples of the continuous ones: the derivatives of the discrete
/// simulation, not approximations. A constant z is the steady state x1 = x2 = x3 = z, a = b = 0
/// (H̃(0) = 1), so Φ s₁ + Γ = s₁ with s₁ = [1 1 1 0 0]ᵀ: the deviation e(k) = x(k) − z(k) s₁
/// follows e(k+1) = Φ e(k) − (z(k+1) − z(k)) s₁, y(k) = z(k) + e₃(k), without Γ (what the dynamic
/// step propagates; all states start at the steady state of z(0), e(0) = 0). Units: Ω rad/s, μ s,
/// T s.
struct JointSensitivityFilter {
  Eigen::Matrix<double, 5, 5> Phi;    ///< lower triangular, Φ(4, 3) = 0; states x1, x2, x3, a, b.
  Eigen::Matrix<double, 5, 1> Gamma;  ///< input column (s₁ − Φ s₁ up to rounding).
  double k_omega = 0.0;               ///< ∂(ỹ − y)/∂Ω = k_omega a: −2/Ω, s/rad.
  double k_mu = 0.0;  ///< ∂(ỹ − y)/∂μ = k_mu b: 1/μ, or Ω for μ ≤ 5e-7 s, 1/s.
};
JointSensitivityFilter DiscretiseJointSensitivities(double omega_rad_s, double mu_s,
                                                    double sample_period_s);

/// One joint's filter response y(k) to z (N samples, from the steady state of z(0)) with its
/// exact derivatives: N×3, columns y, ∂y/∂Ω, ∂y/∂μ (the deviation recursion of
/// JointSensitivityFilter one sample at a time: a scalar reference of what the dynamic step
/// propagates).
Eigen::MatrixXd SimulateJointSensitivities(double omega_rad_s, double mu_s,
                                           const Eigen::VectorXd& z, double sample_period_s);

/// The dynamic step's least-squares problem at Θ = [p.omega_rad_s, p.mu_s]: residual
/// r = ŷ − y over all trials, rows grouped by joint (joint-major, then trial, then sample; ŷ as
/// SimulateHammersteinMimo), with the exact JᵀJ ((q+1)×(q+1)) and Jᵀr of r over Θ — what
/// FitHammersteinDynamic uses with DynamicJacobian::kExactSensitivities.
struct DynamicNormalEquations {
  Eigen::VectorXd residual;
  Eigen::MatrixXd jtj;
  Eigen::VectorXd jtr;
};
DynamicNormalEquations HammersteinDynamicNormalEquations(const std::vector<MimoTrialData>& trials,
                                                         const HammersteinMimoParams& p);

/// Simulated joint angles y = r − H D h(u) (eq. 33) for an N×n input; N×q, rad.
Eigen::MatrixXd SimulateHammersteinMimo(const HammersteinMimoParams& p, const Eigen::MatrixXd& u_us,
                                        double sample_period_s);

/// 𝒳 from constant-input segments (see the header comment).
SteadyStateSet ExtractSteadyState(const std::vector<MimoTrialData>& trials, double min_step_s,
                                  double ss_window_s);

/// Ψ as one vector [u^db_{1,1} … u^db_{1,n}, u^sat_1, u^db_{2,1} …] and back.
Eigen::VectorXd PackCutoffs(const std::vector<CutoffParams>& psi);
std::vector<CutoffParams> UnpackCutoffs(const Eigen::VectorXd& x, int inputs_n);

/// Step 1: static d, Ψ on 𝒳 (eq. 42) by multi-start bounded LM with d projected out. `rest_rad`
/// is r. Muscle units are returned sorted by u^db_{j,1}.
HammersteinMimoFit FitHammersteinStatic(const SteadyStateSet& set, const Eigen::VectorXd& rest_rad,
                                        const HammersteinMimoOptions& options);

/// Step 2: Θ on dynamic data (eq. 44 as the time-domain cost eq. 32), d and Ψ fixed from `fit`.
void FitHammersteinDynamic(const std::vector<MimoTrialData>& trials,
                           const HammersteinMimoOptions& options, HammersteinMimoFit* fit);

/// Both steps on the same trials: 𝒳 from their constant segments, Θ on the whole trials.
HammersteinMimoFit FitHammersteinMimo(const std::vector<MimoTrialData>& trials,
                                      const HammersteinMimoOptions& options);

/// CLI entry "hammerstein-mimo". Options from the first training trial's metadata:
/// hammerstein.muscles_l, .starts, .dynamic_starts, .seed, .min_step_s, .ss_window_s.
MethodEntry HammersteinMimoMethod();

}  // namespace fesim::identification
