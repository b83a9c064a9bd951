// Helpers shared by the Eigen-only identification methods of [Hand Hammerstein], [Copur 2016]
// and [Le 2010]: checked access to trial columns, sampling period, option overrides from trial
// metadata, YAML parameter lines, and the discrete transfer-function filter B(q)/A(q) of [Le 2010]
// eq. (1) / [Copur 2016] eq. (8).
#pragma once

#include <Eigen/Dense>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "base/json.h"
#include "base/trial.h"

namespace fesim::identification {

/// The columns `names` of `trial` as an N×k matrix. Throws std::runtime_error naming the trial
/// (`label`) and column when a column is missing or holds NaN / inf.
Eigen::MatrixXd RequireColumns(const Trial& trial, const std::vector<std::string>& names,
                               const std::string& label);

/// The output column `name` of `trial`; NaN samples (tracker dropouts) are kept and counted in
/// *missing. Throws std::runtime_error naming the trial and column when it is absent.
Eigen::VectorXd OutputColumn(const Trial& trial, const std::string& name, const std::string& label,
                             std::size_t* missing);

/// Keeps the pairs (y_i, ŷ_i) whose measured y_i is finite: the fit metrics of a record with
/// missing samples are over the samples it has.
void KeepMeasuredPairs(std::vector<double>* y, std::vector<double>* yhat);

/// Tolerance of a time stamp about the uniform grid t_0 + i T, as a fraction of T: rounded
/// (a 60 Hz log written to 4 decimals is off by ≤ 0.3 %) or jittered tracker time stamps pass,
/// a missing or doubled row does not.
inline constexpr double kTimeStampTolerance = 0.25;

/// The rows of `trial` that belong to the sensor of the `needed` columns. A measured record's
/// time column is the union of its sensors' grids (`fesim simulate` on the hand rig interleaves
/// 60 Hz angle rows with 100 Hz torque rows, NaN where a sensor did not sample): a row where some
/// needed column is finite is kept; one where none is but another measured column (not an input
/// u.*) is belongs to another sensor and is dropped; one where no measured column is finite is a
/// dropout of this sensor, kept, when it lies on the sensor's grid (continued from the last kept
/// row by the median step between rows with a needed value, within kTimeStampTolerance of a
/// step), and dropped otherwise. Returns a copy of `trial` when every row is kept.
Trial SensorRows(const Trial& trial, const std::vector<std::string>& needed);
/// SensorRows of each trial.
std::vector<Trial> SensorRows(const std::vector<Trial>& trials,
                              const std::vector<std::string>& needed);

/// Plausible sample periods of a measured trial, s: 10 µs (100 kHz) to 1 s (1 Hz). A record
/// outside them has its time column in other units (ms) or is not a sensor log.
inline constexpr double kMinSamplePeriodS = 1e-5;
inline constexpr double kMaxSamplePeriodS = 1.0;

/// Sampling period T, s, of a uniformly sampled trial: (t_last − t_0)/(N − 1). Throws
/// std::runtime_error naming `label` (and the trial's file, its `source` metadata) and column
/// time when T is outside [kMinSamplePeriodS, kMaxSamplePeriodS] or a time stamp is off its grid
/// point t_0 + i T by more than kTimeStampTolerance·T. Needs ≥ 2 samples.
double UniformSamplePeriod(const Trial& trial, const std::string& label);

/// Throws std::runtime_error naming `what` (e.g. "train") and the column when `column` holds the
/// same value in every finite sample of every trial: nothing to identify, and the fit would stop
/// at a rank-deficient regressor matrix without saying why.
void RequireVaryingOutput(const std::vector<Trial>& trials, const std::string& column,
                          const std::string& what);

/// Throws std::runtime_error unless `trial` has at least `min_samples` samples.
void RequireSamples(const Trial& trial, std::size_t min_samples, const std::string& label,
                    const std::string& why);

/// Method options overridable from the first training trial's metadata as
/// `<prefix>.<key>: value` (e.g. `spline.poles: 2`). Unknown `<prefix>.` keys are rejected.
class MetadataOptions {
 public:
  MetadataOptions(const std::map<std::string, std::string>& metadata, std::string prefix);
  /// Integer option in [min, max]; throws std::runtime_error naming the key and range.
  int Int(const std::string& key, int fallback, int min, int max);
  /// Real option in [min, max]; throws std::runtime_error naming the key and range.
  double Real(const std::string& key, double fallback, double min, double max);
  /// Throws std::runtime_error naming the first `<prefix>.` key that was never asked for.
  void RejectUnknown() const;

 private:
  const std::map<std::string, std::string>& metadata_;
  std::string prefix_;
  std::set<std::string> used_;
};

/// One YAML mapping line `name: {value: v, unit: "u"[, ci95: [lo, hi]]}` indented by `indent`
/// spaces; the interval is omitted when `ci_half_width` is NaN.
std::string YamlParam(const std::string& name, double value, const std::string& unit,
                      double ci_half_width, int indent);

/// How one iterative optimisation (one local run) ended, for metrics and the model YAML (issue 10:
/// an optimiser that fails to converge says so, never silently returns its start point).
struct Convergence {
  bool converged = false;
  /// snake_case reason, e.g. "relative_cost_decrease_below_tolerance", "step_below_tolerance",
  /// "iteration_limit", "damping_overflow_no_decrease_possible", "line_search_failed".
  std::string stop_reason;
  int iterations = 0;  ///< iterations (accepted steps) the run took.
};

/// {"best_run": best, "converged": …, "stop_reason": …, "runs": [{converged, stop_reason,
/// iterations} …]} — the best run's flag and reason at the top. `best` < runs.size().
Json ConvergenceJson(const std::vector<Convergence>& runs, std::size_t best);

/// YAML mapping `key:` with best_run, converged, stop_reason and one flow mapping per run,
/// indented by `indent` spaces.
std::string ConvergenceYaml(const std::string& key, const std::vector<Convergence>& runs,
                            std::size_t best, int indent);

/// "" when runs[best] converged, else one line "<what>: the best local run (k of n) did not
/// converge (<reason> after <iterations> iterations)" for `fesim identify` to print.
std::string NotConvergedWarning(const std::string& what, const std::vector<Convergence>& runs,
                                std::size_t best);

/// Formats a double with 10 significant digits (C locale).
std::string Num(double v);

/// Discrete filter with zero initial conditions ([Le 2010] eq. 1):
///   y(k) = −Σ_{i=1}^{l} a_i y(k−i) + Σ_{j=0}^{n} b_j x(k−d−j),  x(k<0) = y(k<0) = 0,
/// a = [a_1 … a_l], b = [b_0 … b_n].
Eigen::VectorXd FilterBA(const Eigen::VectorXd& b, const Eigen::VectorXd& a, int delay,
                         const Eigen::VectorXd& x);

/// Ordinary least squares min ‖Φθ − Y‖ with 95 % half-widths 1.96 √diag(σ²(ΦᵀΦ)⁻¹),
/// σ² = ‖r‖²/(N − p) (conditional on any other parameter block held fixed). Rows holding a NaN
/// (in Y or Φ: a missing output sample or one of its lags) are left out; N counts the others.
struct LinearLsResult {
  Eigen::VectorXd theta;
  Eigen::VectorXd ci95_half_width;
  double cost = 0.0;  ///< ‖Φθ − Y‖².
};
LinearLsResult SolveLinearLs(const Eigen::MatrixXd& Phi, const Eigen::VectorXd& Y);

}  // namespace fesim::identification
