// Person calibration, the first stage of `fesim diagnose` (PRODUCT.md "Diagnosis" step 1): the
// full model (12) of papers/000_0a6c0de9fc69df7c.txt identified on the training trials of a person
// it has never seen, before any mechanism is tested.
//
// Parameters (PersonParameters; all kModel, applied to the rig in this order; "log-normal × f":
// a prior on ln(x / nominal) of 1σ ln f, so that × f and ÷ f are equally likely):
//   per muscle group g — the muscles a stimulated channel reaches most (electrode matrix A of
//   eq. 1, ≥ 2 % of the channel's largest entry), split into those that cross an output finger
//   joint ("<channel>.finger") and the others ("<channel>"):
//     strength.g   F_max of the group's muscles × s (eq. 7), dimensionless, [0.05, 20],
//                  log-normal × 2
//     beta.g       recruitment steepness β × s (eq. 3; with A, the channel's gain on the group),
//                  dimensionless, [0.1, 10], log-normal × 2
//     gamma.g      recruitment shape γ × s (eq. 3), dimensionless, [0.05, 20], log-normal × 3
//   per free output joint j (eq. 14 of paper 000, sim/passive_joint.h):
//     k.j          stiffness k_j, N·m/rad, [0.1, 10] × nominal, log-normal × 2
//     k3.j         cubic stiffness k₃ (mid-range stiffening), N·m/rad³, [−0.5, 20] × k_j,
//                  normal 2 k_j (at 0.5 rad from rest ±½ the linear moment)
//     b.j          damping b_j, N·m·s/rad, [0.05, 20] × nominal, log-normal × 2
//     rest.j       rest angle q₀_j, rad, nominal ± 0.6, normal 10°
//   omega_scale    activation natural frequency Ω_i × s of every muscle of the groups (eq. 6;
//                  one scale: unequal rates are the mechanism unequal_muscle_dynamics),
//                  dimensionless, [0.3, 3], log-normal × 1.35
//   arm.g@j        for a group crossing several output joints, the moment arms (eq. 9–10) of its
//                  crossings of every output joint after its most proximal one × s, l_MT at the
//                  rest posture kept, dimensionless, [0.5, 2], log-normal × 1.25
//   mass.hand      mass and inertia of the hand and index phalanges × s, when the wrist is an
//                  output, dimensionless, [0.5, 2], log-normal × 1.2
// One group per channel side, not per muscle: per-muscle strength and recruitment (44 parameters
// on the hand rig) ended in worse local minima of foreign persons (Σr² 5.9–79 against 4.5–10.5).
// Not calibrated: the electrode array's reach of the other group (crosstalk), posture-dependent
// moment arms, the force–velocity curve, unequal activation rates, passive nonlinearity —
// the candidate mechanisms (mechanisms/), which must stay distinguishable from the person.
// A reduced model (`--model NAME`) has no joints or muscles: u_scale.<channel> (kInputScale,
// [0.3, 3], no prior) per stimulated channel only.
//
// Method (CalibratePerson):
//  1. Noise: σ_o of each output from the measured data alone (NoiseFromSecondDifferences), σ_p
//     their RMS — the scale of the prior rows (extended_model.h: Σr² + σ_p² Σ((x − x₀)/w)² is
//     σ_p² times the negative log posterior).
//  2. Identifiability: the Jacobian of every parameter at the nominal point, columns scaled by
//     their prior widths and rows by 1/σ_p (data information in prior units), ranked by QR with
//     column pivoting (a rank-revealing subset selection, Golub & Van Loan 2013 §5.4.2): a
//     parameter is kept while the diagonal of R in pivot order is ≥ kIdentifiableInformation,
//     i.e. the data determine it beyond what the parameters before it explain at least that
//     many times better than its prior. The others stay at nominal and the report says so.
//  3. MAP fit of the kept parameters by bounded LM (PersonCalibrationOptions::iterations steps at
//     most; active bounds held and MINPACK's stop, PersonCalibrationOptions::converged_stop) from
//     the nominal values and, when an output is the elbow or a shoulder coordinate (the
//     forearm's weight makes Σr² multimodal over strength and stiffness), from the four corners
//     stiffness × {0.8, 1.25}, strength × {0.8, 1.25} (FitOverStarts); the lowest posterior cost
//     is kept.
//  4. 95 % intervals from the Gauss–Newton posterior covariance (JᵀJ + prior); flags: at a
//     bound, and prior-dominated (posterior half-width above 0.7 × the prior's at the value).
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "diagnosis/extended_model.h"
#include "diagnosis/mechanisms/mechanism.h"
#include "sim/model_params.h"

namespace fesim::diagnosis {

/// Step 2's threshold: information beyond the earlier pivots, in prior units (dimensionless).
inline constexpr double kIdentifiableInformation = 2.0;

/// The person parameters of a rig and data (see the header), start = nominal.
std::vector<ModelParameter> PersonParameters(const sim::ModelParams& rig,
                                             const LibraryContext& ctx);

/// σ of white measurement noise on a smoothly moving signal, from its second differences
/// Δ²y_i = y_{i+1} − 2y_i + y_{i−1} of consecutive finite samples: median |Δ²y| / 0.6745 / √6
/// (var Δ²e = 6σ² for white e; the median ignores the few large accelerations of the motion).
/// 0 when fewer than 10 such triples. Unit of y.
double NoiseFromSecondDifferences(const std::vector<double>& y);

/// One calibrated person parameter as reported.
struct PersonValue {
  std::string name, unit;
  double nominal = 0.0, value = 0.0;
  double ci95 = NAN;  ///< 95 % half-width; NaN when held or not estimable.
  double prior_width = NAN;
  bool fitted = false;           ///< identifiable (step 2) and calibrated.
  bool at_bound = false;         ///< ended within 0.1 % of its range at a bound.
  bool prior_dominated = false;  ///< fitted, but the posterior is ≥ 0.7 × the prior width.
  double information = 0.0;      ///< step 2's R diagonal (0 for the reduced model's scales).
};

/// `v` as calibrated: `value` and its 95 % half-width `ci95` of parameter `p`, with its bound
/// and prior-dominance flags.
void SetFittedValue(const ModelParameter& p, double value, double ci95, PersonValue* v);

struct PersonCalibration {
  std::vector<ModelParameter> fitted;  ///< the calibrated parameters (the rest stay nominal).
  FitResult fit;                       ///< over `fitted` (cost, intervals, Jacobian, predictions).
  std::vector<PersonValue> table;      ///< every person parameter, PersonParameters' order.
  std::vector<double> noise_rad;       ///< σ_o per output (view order), rad.
  double prior_sigma_rad = 0.0;        ///< σ_p, rad.
  int starts = 0;                      ///< LM starts run.
};

struct PersonCalibrationOptions {
  /// LM steps per start, ≥ 1: from the nominal values a foreign person's calibration (25
  /// parameters) converged after ≈ 33 steps; 10 left its cost 7× higher.
  int iterations = 40;
  /// Identifiability threshold (step 2), ≥ 0; 0 keeps every parameter.
  double identifiable_information = kIdentifiableInformation;
  /// Step 3 from the four corner starts alone (stiffness × {0.8, 1.25}, strength × {0.8, 1.25}),
  /// not from nominal: the retry of a calibration that misses the black box (diagnose.h).
  bool corner_starts_only = false;
  /// Step 3 with active bounds held and MINPACK's stop (FitOptions::hold_active_bounds,
  /// stop_needs_predicted_decrease). With the plain relative-decrease stop a step clamped at a
  /// bound, or taken at a large damping, ended calibrations far from a minimum, and candidate
  /// fits freeing the person then found better persons along a path that round-off decides
  /// (docs/diagnosis.md, The person, step 3).
  bool converged_stop = true;
};

/// Steps 1–4 on the training view. `fo` as for every fit (threads, integrator, simulator).
/// Throws std::runtime_error when no parameter can be simulated.
PersonCalibration CalibratePerson(const sim::ModelParams& rig, const LibraryContext& ctx,
                                  const DataView& train, const FitOptions& fo,
                                  const PersonCalibrationOptions& options);

}  // namespace fesim::diagnosis
