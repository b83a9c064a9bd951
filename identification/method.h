// The interface `fesim identify` uses to run any identification method on plain trial records.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "base/json.h"
#include "base/trial.h"

namespace fesim::identification {

/// What a method returns: the identified model, its predictions and its fit measures.
/// A discrete-time model in the terms of MATLAB's System Identification Toolbox (idpoly,
/// idnlhw): A(q) y(t) = Σ_k B_k(q)/F(q) f_k(u_k(t)) + e(t) + offset, polynomials in q⁻¹ with
/// the leading coefficient of A and F equal to 1 and the input delay as leading zeros of B_k;
/// f_k the static input nonlinearity of a Hammerstein model (breakpoints), absent when linear.
/// `fesim identify` writes it to model.mat (apps/matfile.h).
struct DiscreteModel {
  double sample_time_s = 0.0;  ///< Ts, s.
  std::vector<std::string> inputs, input_units;
  std::string output, output_unit;
  std::vector<double> a = {1.0}, f = {1.0};
  std::vector<std::vector<double>> b;  ///< per input.
  /// Per input: breakpoints u (input unit) and f(u) (output unit) of the input nonlinearity,
  /// sampled finely enough to be linearly interpolated; empty: linear in u.
  std::vector<std::vector<double>> nonlinearity_u, nonlinearity_f;
  double output_offset = 0.0;  ///< added to the simulated output, output unit.
};

struct MethodResult {
  /// The identified model as YAML text: every parameter with its unit and, where the optimiser
  /// provides one, a 95 % confidence interval.
  std::string model_yaml;
  /// Simulated (not one-step-ahead) predictions, one trial per evaluated trial, in the trial
  /// format with the same column names as the data they predict.
  std::vector<Trial> predictions;
  /// Fit measures (Best Fit %, normalised error per output, wall times, iterations, ...).
  Json metrics = Json::Object();
  /// One line each, printed on stderr by `fesim identify` (e.g. the best local optimisation did
  /// not converge; the reason is also in `metrics` and `model_yaml`).
  std::vector<std::string> warnings;
  /// The identified model as discrete-time polynomials, for the methods that identify one
  /// (spline-arx, spline-oe); empty for the others.
  std::vector<DiscreteModel> discrete_models;
};

/// Reports progress in [0, 1] with a short stage label (printed on stderr by the CLI).
using ProgressFn = std::function<void(double fraction, const std::string& stage)>;

/// A method fits on `train` and evaluates on `test` (or on `train` when `test` is empty).
/// It throws std::runtime_error with a one-line reason for unusable data (missing columns,
/// too few samples, NaN where it cannot cope).
using MethodFn = std::function<MethodResult(const std::vector<Trial>& train,
                                            const std::vector<Trial>& test, const ProgressFn&)>;

/// A model fitted once and then simulated on any inputs (`fesim diagnose --model NAME` calibrates
/// a reduced model this way and simulates it many times under model extensions).
struct FittedSimulator {
  std::string model_yaml;            ///< as MethodResult::model_yaml.
  std::vector<std::string> inputs;   ///< u.* columns read.
  std::vector<std::string> outputs;  ///< columns predicted (e.g. q.*).
  /// The predicted `outputs` (same time column) for the inputs of `trial`. Methods whose
  /// simulation starts from the measured initial output (e.g. the spline methods' baseline) read
  /// it from `trial` too; inputs outside the training range are allowed (no range check).
  std::function<Trial(const Trial& trial)> simulate;
  std::vector<std::string> warnings;  ///< as MethodResult::warnings.
};

/// Fits on `train` (same rules and metadata options as the method's MethodFn).
using FitSimulatorFn =
    std::function<FittedSimulator(const std::vector<Trial>& train, const ProgressFn&)>;

struct MethodEntry {
  std::string name;     ///< CLI name, e.g. "spline-oe".
  std::string summary;  ///< one line for `fesim identify --help`.
  MethodFn run;
  /// Set by the methods that map u.* inputs to outputs by simulation (the Hammerstein family);
  /// empty for the others.
  FitSimulatorFn fit_simulator = nullptr;
};

/// Every Eigen-only method compiled into identification/ (the full-model fit registers itself
/// from its own target).
std::vector<MethodEntry> BuiltinMethods();

}  // namespace fesim::identification
