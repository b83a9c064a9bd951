#include "diagnosis/diagnose.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <map>
#include <stdexcept>

#include "diagnosis/extension.h"
#include "diagnosis/mechanisms/library.h"
#include "diagnosis/reduced_model.h"
#include "diagnosis/screening.h"
#include "diagnosis/stages.h"
#include "diagnosis/verdict.h"

namespace fesim::diagnosis {
namespace {

using Clock = std::chrono::steady_clock;

void CheckSettings(const DiagnoseSettings& s, const DiagnoseExecution& e) {
  const auto fail = [](const std::string& what) {
    throw std::invalid_argument("DiagnoseSettings: " + what);
  };
  if (s.max_fitted < 1 || s.max_screened < 1 || s.max_accepted < 1) {
    fail("max_fitted, max_screened and max_accepted must be >= 1");
  }
  if (!(s.alpha > 0.0 && s.alpha < 1.0)) fail("alpha must be in (0, 1)");
  if (!(s.reference_gate >= 1.0) || !(s.reference_margin >= 0.0) || !(s.profile_gate >= 1.0)) {
    fail("reference_gate and profile_gate must be >= 1 and reference_margin >= 0");
  }
  if (s.person.iterations < 1 || s.screen_iterations < 1 || s.refit_iterations < 1) {
    fail("iteration counts must be >= 1");
  }
  if (s.heldout_trials < 1) fail("heldout_trials must be >= 1");
  if (e.threads < 1) throw std::invalid_argument("DiagnoseExecution: threads must be >= 1");
}

/// Identifies a reduced model on the training part and makes it the simulation (reduced_model.h).
void UseReducedModel(const DiagnoseSettings& settings, const MeasuredData& data, FitOptions* fo,
                     Diagnosis* d) {
  identification::FitSimulatorFn fit;
  std::string allowed = "full";
  for (const auto& m : ReducedModelMethods()) {
    allowed += ", " + m.name;
    if (m.name == settings.model) fit = m.fit_simulator;
  }
  if (!fit) {
    throw std::invalid_argument("--model: '" + settings.model +
                                "' is not a model diagnose can calibrate (allowed: " + allowed +
                                ")");
  }
  std::map<std::string, double> u_ref;
  const std::vector<Trial> train = ReducedTrainingTrials(data.train, data.channels, &u_ref);
  identification::FittedSimulator fitted;
  try {
    fitted = fit(train, nullptr);
  } catch (const std::exception& e) {
    throw std::runtime_error("--model " + settings.model + ": " + e.what());
  }
  for (const auto& o : data.train.outputs) {
    if (std::find(fitted.outputs.begin(), fitted.outputs.end(), o) == fitted.outputs.end()) {
      throw std::runtime_error("--model " + settings.model + ": does not predict " + o);
    }
  }
  d->model_yaml = fitted.model_yaml;
  for (const auto& w : fitted.warnings) d->notes.push_back(settings.model + ": " + w);
  fo->simulator = ReducedSimulator(fitted, u_ref);
}

/// The candidates' test figures and evidence lines (library order).
std::vector<CandidateResult> TestResults(const std::vector<Candidate>& library,
                                         const ScreenStage& screen,
                                         const std::vector<OutputSignature>& signatures) {
  const int m = ApplicableCount(library);
  std::vector<CandidateResult> out;
  for (std::size_t c = 0; c < library.size(); ++c) {
    CandidateResult cr;
    cr.id = library[c].id;
    cr.joint = library[c].joint;
    cr.label = library[c].label;
    cr.control = library[c].control;
    cr.applicable = library[c].applicable;
    cr.not_applicable_reason = library[c].not_applicable_reason;
    if (!cr.applicable) {
      cr.evidence = "not tested: " + cr.not_applicable_reason;
      cr.decision = "not applicable";
      out.push_back(cr);
      continue;
    }
    cr.evidence = "; ";  // SetScoreTest writes the test part before it
    SetScoreTest(screen.tests[c], m, &cr);
    // The signature of the output it acts on, else of the output with the largest residual.
    std::size_t s = 0;
    for (std::size_t k = 0; k < signatures.size(); ++k) {
      if (!cr.joint.empty() ? signatures[k].output == "q." + cr.joint
                            : signatures[k].rms_rad > signatures[s].rms_rad) {
        s = k;
      }
    }
    cr.evidence += signatures[s].output + ": " + FindMechanism(cr.id).evidence(signatures[s]);
    out.push_back(cr);
  }
  return out;
}

/// Largest structured variance share of the held-out residual per output (signatures.h).
std::vector<double> HeldoutStructure(const DataView& held, const std::vector<Trial>& pred) {
  std::vector<double> out;
  for (const auto& o : held.outputs) {
    double s_out = 0.0;
    for (std::size_t t = 0; t < held.trials.size(); ++t) {
      const auto& y = held.trials[t].Column(o);
      const auto& yh = pred[t].Column(o);
      std::vector<double> r(y.size(), NAN);
      for (std::size_t i = 0; i < y.size(); ++i) {
        if (held.use[t][i]) r[i] = y[i] - yh[i];
      }
      s_out = std::max(s_out, StructuredVarianceFraction(r));
    }
    out.push_back(s_out);
  }
  return out;
}

/// The values and intervals of the fitted person parameters `person` from `fit` (its x in their
/// order) into `table`.
void UpdatePersonTable(const std::vector<ModelParameter>& person, const FitResult& fit,
                       std::vector<PersonValue>* table) {
  for (std::size_t k = 0; k < person.size(); ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    if (i >= fit.x.size()) break;
    for (PersonValue& v : *table) {
      if (v.name == person[k].name)
        SetFittedValue(person[k], fit.x(i), i < fit.ci95.size() ? fit.ci95(i) : NAN, &v);
    }
  }
}

}  // namespace

std::string DiagnoseSettings::KeyText() const {
  std::string s;
  for (const double v :
       {holdout_fraction, alpha, min_heldout_gain, clear_heldout_gain, reference_gate,
        reference_margin, profile_gate, person.identifiable_information, fit.relative_tolerance,
        fit.fd_step, fit.tolerance, fit.speed_time_scale_s, fit.max_steps_per_s,
        fit.jacobian_tolerance_factor}) {
    s += ExactNumberText(v) + ",";
  }
  for (const int v : {max_fitted, max_screened, max_accepted, person.iterations, screen_iterations,
                      refit_iterations, fit.max_iterations}) {
    s += std::to_string(v) + ",";
  }
  // More than one held-out trial, the articulated-body right-hand side and the LM stop rules
  // enter as markers, so that caches written before these choices existed (one held-out trial,
  // Simbody's right-hand side, the plain stop) keep their keys.
  if (heldout_trials != 1) s += "heldout" + std::to_string(heldout_trials) + ",";
  return s + (fit.sensitivities ? "sens," : "fd,") + (fit.simbody_right_hand_side ? "" : "chain,") +
         (person.converged_stop ? "converged," : "") + (fit.hold_active_bounds ? "held," : "") +
         (fit.stop_needs_predicted_decrease ? "minpack," : "") + model;
}

Diagnosis Diagnose(const sim::ModelParams& rig, const std::vector<Trial>& measured,
                   const DiagnoseSettings& settings, const DiagnoseExecution& execution) {
  CheckSettings(settings, execution);
  const auto t0 = Clock::now();
  Diagnosis d;
  d.model = settings.model;
  // split
  const MeasuredData data =
      PrepareMeasured(rig, measured, settings.holdout_fraction, settings.heldout_trials);
  d.split = data.split;
  d.notes = data.notes;
  d.heldout = data.heldout;
  LibraryContext library_ctx;
  library_ctx.outputs = data.outputs;
  library_ctx.channels = data.channels;
  library_ctx.training_trials = static_cast<int>(data.train.trials.size());
  library_ctx.heldout_recordings_apart = measured.size() > 1;  // PrepareMeasured's split
  FitOptions fo = settings.fit;
  fo.threads = execution.threads;
  if (settings.model != "full") {
    if (execution.progress)
      execution.progress(0.0, "identifying the reduced model " + settings.model);
    library_ctx.reduced_model = settings.model;
    UseReducedModel(settings, data, &fo, &d);
  }
  const StageCache cache(execution.cache, {"diagnose", execution.cache_inputs, settings.KeyText()},
                         &d.cached_results);
  std::atomic<int> simulations{0};
  const StageContext ctx{rig,
                         data,
                         library_ctx,
                         settings,
                         fo,
                         cache,
                         execution.map,
                         execution.progress,
                         LayoutOf(data.train),
                         LayoutOf(data.heldout),
                         &simulations};
  // calibrate
  CalibrationStage calibration = Calibrate(ctx);
  const auto set_baseline = [&](const CalibrationStage& c) {
    d.person = c.table;
    d.person_converged = c.fit.converged;
    d.noise_rad = c.noise_rad;
    d.heldout_baseline = c.heldout_predictions;
    d.baseline_heldout_nrmse_per_output = ViewNrmsePerOutput(data.heldout, d.heldout_baseline);
    d.baseline_heldout_nrmse = ViewNrmse(data.heldout, d.heldout_baseline);
  };
  set_baseline(calibration);
  // reference (a reduced model is its own black box)
  if (settings.model == "full") d.reference = Reference(ctx);
  // A calibration from one start that misses the black box may sit in a poor minimum
  // (docs/diagnosis.md, Known limits): it is fitted again from the corner starts, and the lower
  // posterior cost of the two is kept (chosen on the training data alone).
  if (settings.model == "full" && calibration.starts == 1 &&
      !ReferenceGaps(d.baseline_heldout_nrmse_per_output, d.reference, settings).empty()) {
    CalibrationStage corners;
    bool retried = true;
    try {
      corners = Calibrate(ctx, true);
    } catch (const std::runtime_error&) {
      retried = false;  // no corner start (or its held-out prediction) simulates: keep the first
    }
    if (retried && corners.fit.map_cost < calibration.fit.map_cost) {
      d.notes.push_back(Fmt(
          "the calibration from nominal missed the black box; from the corner starts it reached a "
          "lower posterior cost (%.4g against %.4g), which is the calibrated person",
          corners.fit.map_cost, calibration.fit.map_cost));
      calibration = std::move(corners);
      set_baseline(calibration);
    }
  }
  const std::vector<ModelParameter> person = FittedPersonParameters(ctx, calibration);
  // signatures
  ctx.Report(0.3, "residual signatures");
  d.signatures = ResidualSignatures(data.train, calibration.train_predictions);
  for (const auto& s : d.signatures) {
    library_ctx.tremor_frequency_hz.push_back(s.spectrum_peak_hz > 0 ? s.spectrum_peak_hz : 6.0);
  }
  // screen
  const std::vector<Candidate> library = CandidateLibrary(rig, library_ctx);
  ModelPoint base;
  base.params = person;
  base.x = calibration.fit.x;
  base.train_predictions = calibration.train_predictions;
  base.residual = StackResiduals(data.train, calibration.train_predictions);
  base.jacobian = calibration.jacobian;
  if (base.jacobian.rows() != base.residual.size()) {
    throw std::runtime_error("diagnose: cached calibration Jacobian has the wrong size");
  }
  ctx.Report(0.35, "robust score tests");
  std::map<int, Eigen::MatrixXd> directions;
  const ScreenStage screen = Screen(ctx, library, base, {}, {"score_tests"}, {}, &directions);
  d.candidates = TestResults(library, screen, d.signatures);
  // extend, refit
  const bool reference_gap =
      !ReferenceGaps(d.baseline_heldout_nrmse_per_output, d.reference, settings.profile_gate, 0.0)
           .empty();
  const ExtensionOutcome extension = Extend(ctx, library, calibration, person, screen,
                                            std::move(directions), reference_gap, &d.candidates);
  if (extension.baseline_refit) {
    d.notes.push_back(extension.baseline_note);
    UpdatePersonTable(person, extension.baseline_fit, &d.person);
    d.heldout_baseline = extension.baseline_heldout_predictions;
    d.baseline_heldout_nrmse_per_output = ViewNrmsePerOutput(data.heldout, d.heldout_baseline);
    d.baseline_heldout_nrmse = ViewNrmse(data.heldout, d.heldout_baseline);
  }
  if (extension.accepted.empty()) {
    d.heldout_extended = d.heldout_baseline;
  } else {
    d.heldout_extended = extension.heldout_predictions;
  }
  d.extended_heldout_nrmse_per_output = ViewNrmsePerOutput(data.heldout, d.heldout_extended);
  d.extended_heldout_nrmse = ViewNrmse(data.heldout, d.heldout_extended);
  d.gain = (d.baseline_heldout_nrmse - d.extended_heldout_nrmse) / d.baseline_heldout_nrmse;
  const std::vector<double> s_base = HeldoutStructure(data.heldout, d.heldout_baseline);
  const std::vector<double> s_ext = HeldoutStructure(data.heldout, d.heldout_extended);
  for (std::size_t k = 0; k < d.signatures.size(); ++k) {
    d.signatures[k].structure_heldout_baseline = s_base[k];
    d.signatures[k].structure_heldout_extended = s_ext[k];
  }
  // verdict
  ctx.Report(0.95, "verdict");
  MakeVerdict(library, extension, static_cast<int>(person.size()), settings, &d);
  std::stable_sort(d.candidates.begin(), d.candidates.end(),
                   [](const CandidateResult& a, const CandidateResult& b) {
                     if (a.accepted != b.accepted) return a.accepted;
                     return a.score > b.score;
                   });
  d.simulations = simulations.load();
  d.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  ctx.Report(1.0, "done");
  return d;
}

}  // namespace fesim::diagnosis
