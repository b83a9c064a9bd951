// Issue 7: the planted-effect suite of `fesim diagnose`. For every mechanism of the library,
// datasets that differ in participant, protocol and seed at effect scales from 1 upward; clean
// datasets; two-mechanism datasets; an effect outside the library. Writes the confusion matrix,
// the rates and the parameter errors as Markdown (default docs/diagnosis.md).
//
//   diagnosis_suite [--per N] [--clean N] [--pairs N] [--outside N] [--trials T]
//                   [--duration S] [--mechanisms a,b,…] [--threads N] [--out FILE]
//                   [--seed S]   (datasets get seeds S+1, S+2, … in order; default 1000)
//                   [--model full|NAME] (diagnose a reduced model, diagnose --model)
//                   [--protocol steps|grid] (every dataset; default: alternate)
//                   [--pair-list a+b,c+d,…] (the pairs planted, cycled; default: fatigue+tremor,
//                   delay+sensor_drift, stiction+tremor, potentiation+delay,
//                   fatigue+sensor_drift)
//                   [--speed-time-scale S] (FitOptions::speed_time_scale_s; default 0)
//                   [--tolerance TOL] (FitOptions::tolerance, CVODES; default 1e-5)
//                   [--lm-tolerance R] (FitOptions::relative_tolerance, LM's stop; default 1e-3)
//                   [--fd-step H] (FitOptions::fd_step, difference steps; default 1e-2)
//                   [--baseline-fd-steps H,H,…] (DiagnoseOptions::baseline_fd_steps, the
//                   subject calibrations' difference steps, 0: --fd-step; default: the
//                   library's)
//                   [--baseline-iterations N] (DiagnoseOptions::baseline_iterations; default 4)
//                   [--max-screened N] (DiagnoseOptions::max_screened; default 6)
//                   [--batches-while-structured 0|1] (DiagnoseOptions::
//                   batches_while_structured; default 1)
//                   [--only SEED,SEED,…] (run only these datasets of the command, same scales
//                   and protocols as in the whole run)
//                   [--oracle ITERATIONS] (single datasets: OracleCheck below; default 0 = off)
//                   [--identifiable ITERATIONS] (single and clean datasets:
//                   EffectFromTrueCalibration below, on each dataset's line and in the rates
//                   table; default 0 = off)
//                   [--effect-floor R] (single datasets: the effect scale raised until the
//                   effect RMS is ≥ R × the noise RMS, MakePlantedDatasetAtLeast; default 1,
//                   the floor; 0 = the scales 1, 1.5, 2 as they are)
// Protocols alternate steps / grid over each mechanism's datasets (PlantedProtocols: spasticity
// steps only).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "diagnosis/candidates.h"
#include "diagnosis/diagnose.h"
#include "diagnosis/measured.h"
#include "diagnosis/planted.h"
#include "diagnosis/reduced_model.h"
#include "diagnosis/report.h"
#include "scenarios/scenario.h"
#include "scenarios/trial.h"

namespace {

using fesim::diagnosis::Diagnosis;
using fesim::diagnosis::PlantedSpec;

std::vector<std::string> Split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

struct Case {
  std::string kind;  // "single", "clean", "pair", "outside"
  PlantedSpec spec;
  fesim::diagnosis::PlantedDataset data;
  /// Pairs: effect RMS / noise RMS of each planted mechanism alone (same seed: same participant,
  /// protocol and noise), in spec.mechanisms order.
  std::vector<double> alone_effect;
  /// Pairs: RMS of measured(both) − measured(the other alone) / noise RMS for each mechanism: its
  /// effect on top of the other (the noise is the same draw and cancels).
  std::vector<double> marginal_effect;
  /// --identifiable: EffectFromTrueCalibration (NaN: not computed).
  double identifiable = NAN;
  Diagnosis result;
};

/// Relative error of the fitted parameter matching a planted one (by name), NaN when not fitted.
double ParamError(const Case& c, const fesim::diagnosis::NamedValue& planted) {
  for (const auto& p : c.result.extension_parameters) {
    if (p.name == planted.name) return std::abs(p.value - planted.value) / std::abs(planted.value);
  }
  return NAN;
}

/// RMS of a − b over the q.* columns of all trials (same layout), rad.
double RmsDifference(const std::vector<fesim::Trial>& a, const std::vector<fesim::Trial>& b) {
  double ss = 0.0;
  long n = 0;
  for (std::size_t t = 0; t < a.size() && t < b.size(); ++t) {
    for (const auto& o : a[t].NamesWithPrefix("q.")) {
      const auto& ya = a[t].Column(o);
      const auto& yb = b[t].Column(o);
      for (std::size_t i = 0; i < ya.size() && i < yb.size(); ++i) {
        if (std::isfinite(ya[i]) && std::isfinite(yb[i])) {
          ss += (ya[i] - yb[i]) * (ya[i] - yb[i]);
          ++n;
        }
      }
    }
  }
  return n ? std::sqrt(ss / static_cast<double>(n)) : 0.0;
}

/// What is left of the planted effect after the diagnosis calibrated the subject parameters,
/// over the noise RMS: √max(0, mean over outputs of the baseline's training residual RMS² − σ²)/σ
/// (residual = remaining effect + independent noise). Effects the subject parameters can mimic
/// (e.g. crosstalk on one-channel-at-a-time steps, absorbed by the channel gains) are large before
/// calibration and small here. Sampling error ≈ 0.15 for one 28 s training part at 60 Hz.
double EffectAfterCalibration(const Case& c) {
  double ms = 0.0;
  int n = 0;
  for (const auto& sg : c.result.signatures) {
    ms += sg.rms_rad * sg.rms_rad;
    ++n;
  }
  const double s2 = c.data.noise_rms_rad * c.data.noise_rms_rad;
  if (n == 0 || !(s2 > 0.0)) return NAN;
  return std::sqrt(std::max(0.0, ms / n - s2) / s2);
}

/// The participant's true values of the subject parameters (candidates.h SubjectParameters):
/// joint stiffness × the drawn stiffness scale, the drawn strength scale, input scales 1.
Eigen::VectorXd TrueSubjectValues(const std::vector<fesim::diagnosis::ModelParameter>& subject,
                                  const Case& c) {
  Eigen::VectorXd truth(static_cast<Eigen::Index>(subject.size()));
  for (std::size_t k = 0; k < subject.size(); ++k) {
    const std::string& name = subject[k].name;
    truth(static_cast<Eigen::Index>(k)) = name.rfind("k.", 0) == 0
                                              ? subject[k].start * c.data.stiffness_scale
                                          : name == "strength_scale" ? c.data.strength_scale
                                                                     : 1.0;
  }
  return truth;
}

/// The part of the planted effect that no subject calibration absorbs, over the noise RMS:
/// √max(0, Σr²/N − σ²)/σ of the baseline (the subject parameters alone) fitted by `iterations`
/// LM steps from the participant's true values on the diagnosis' training part. A mechanism the
/// subject parameters can mimic (e.g. a weight-compensation force at the forearm's centre of mass:
/// statically strength and stiffness × 1/(1 − f)) has a large effect before calibration and a
/// small one here; unlike EffectAfterCalibration this does not depend on the diagnosis'
/// calibration converging. Single-mechanism and clean datasets.
double EffectFromTrueCalibration(const fesim::Scenario& rig, const Case& c,
                                 const fesim::diagnosis::DiagnoseOptions& options, int iterations) {
  namespace dg = fesim::diagnosis;
  const dg::MeasuredData data =
      dg::PrepareMeasured(rig.model, c.data.trials, options.holdout_fraction);
  dg::LibraryContext ctx;
  ctx.outputs = data.outputs;
  ctx.channels = data.channels;
  const std::vector<dg::ModelParameter> subject = dg::SubjectParameters(rig.model, ctx);
  const dg::FitResult fit = dg::FitParameters(rig.model, subject, TrueSubjectValues(subject, c),
                                              data.train, options.fit, 0, iterations);
  const double s2 = c.data.noise_rms_rad * c.data.noise_rms_rad;
  const auto n = static_cast<double>(data.train.Count());
  return std::sqrt(std::max(0.0, fit.cost / n - s2) / s2);
}

/// --oracle N: what fits reach from the truth, to tell an identifiability limit (a fit from the
/// truth ends as far from it, at no higher cost, as the diagnosis) from an optimisation failure
/// (it ends much lower). On the diagnosis' training part, Σr² and values of: the true point
/// (participant's stiffness and strength, input scales 1, planted mechanism values); N LM steps
/// of subject ⊕ the planted candidate from there; N more steps of the baseline from the
/// diagnosis' calibration and from the true subject values, and Σr² on the segment between the
/// two (a barrier, or a stalled calibration?); the candidate from "off" with everything free;
/// the profile along the candidate (held at 0 … 1.25 × the way to the planted values, subject
/// fitted); N steps from the diagnosis' fitted values of that candidate (when it was fitted).
/// Single-mechanism datasets of library mechanisms only.
void OracleCheck(const fesim::Scenario& rig, const Case& c,
                 const fesim::diagnosis::DiagnoseOptions& options, int iterations) {
  namespace dg = fesim::diagnosis;
  if (c.kind != "single" || c.data.planted.empty()) return;
  const dg::MeasuredData data =
      dg::PrepareMeasured(rig.model, c.data.trials, options.holdout_fraction);
  dg::LibraryContext ctx;
  ctx.outputs = data.outputs;
  ctx.channels = data.channels;
  ctx.tremor_frequency_hz.assign(ctx.outputs.size(), 6.0);
  const std::vector<dg::ModelParameter> subject = dg::SubjectParameters(rig.model, ctx);
  const std::string label = c.data.planted[0].name.substr(0, c.data.planted[0].name.find(':'));
  const std::vector<dg::Candidate> library = dg::CandidateLibrary(rig.model, ctx);
  const dg::Candidate* cand = nullptr;
  for (const auto& k : library) {
    if (k.label == label) cand = &k;
  }
  const dg::CandidateResult* fitted = nullptr;
  for (const auto& cr : c.result.candidates) {
    if (cr.label == label && cr.fitted) fitted = &cr;
  }
  if (!cand) return;
  std::vector<dg::ModelParameter> params = subject;
  params.insert(params.end(), cand->params.begin(), cand->params.end());
  const auto ns = static_cast<Eigen::Index>(subject.size());
  Eigen::VectorXd truth(params.size()), from_diag(params.size());
  truth.head(ns) = TrueSubjectValues(subject, c);
  for (Eigen::Index k = 0; k < ns; ++k) from_diag(k) = c.result.subject_parameters[k].value;
  for (std::size_t p = 0; p < cand->params.size(); ++p) {
    const auto k = ns + static_cast<Eigen::Index>(p);
    truth(k) = from_diag(k) = cand->params[p].start;
    for (const auto& pl : c.data.planted) {
      if (pl.name == label + ":" + cand->params[p].name) truth(k) = pl.value;
    }
    if (fitted) from_diag(k) = fitted->parameters[p].value;
  }
  const auto cost_of = [&](const std::vector<dg::ModelParameter>& ps, const Eigen::VectorXd& x) {
    return dg::StackResiduals(data.train, dg::Predict(rig.model, ps, x, data.train, options.fit))
        .squaredNorm();
  };
  const auto cost_at = [&](const Eigen::VectorXd& x) { return cost_of(params, x); };
  const auto show = [&](const char* what, const Eigen::VectorXd& x, double cost) {
    std::string text;
    for (Eigen::Index k = 0; k < x.size(); ++k) {
      char b[96];
      std::snprintf(b, sizeof b, "%s%s %.4g", k ? ", " : "", params[k].name.c_str(), x(k));
      text += b;
    }
    std::fprintf(stderr, "    oracle %-22s cost %.6g  [%s]\n", what, cost, text.c_str());
  };
  const auto n = static_cast<double>(data.train.Count());
  std::fprintf(stderr, "    oracle N %.0f, N sigma^2 %.6g\n", n,
               n * c.data.noise_rms_rad * c.data.noise_rms_rad);
  show("truth", truth, cost_at(truth));
  const dg::FitResult a =
      dg::FitParameters(rig.model, params, truth, data.train, options.fit, 0, iterations);
  show("fit from truth", a.x, a.cost);
  // The baseline alone, fitted on from the diagnosis' calibration: is that calibration converged?
  const std::vector<dg::ModelParameter> only_subject(params.begin(), params.begin() + ns);
  const dg::FitResult base = dg::FitParameters(rig.model, only_subject, from_diag.head(ns),
                                               data.train, options.fit, 0, iterations);
  show("baseline fitted on", base.x, base.cost);
  const dg::FitResult base_t = dg::FitParameters(rig.model, only_subject, truth.head(ns),
                                                 data.train, options.fit, 0, iterations);
  show("baseline from truth", base_t.x, base_t.cost);
  {  // The cost on the segment between the two calibrations: a barrier, or a stalled fit?
    std::string text;
    for (const double t : {0.0, 0.001, 0.003, 0.01, 0.03, 0.1, 0.2, 0.4, 0.6, 0.8, 1.0}) {
      char b[32];
      std::snprintf(b, sizeof b, " %.4g", cost_of(only_subject, base.x + t * (base_t.x - base.x)));
      text += b;
    }
    std::fprintf(stderr, "    oracle segment calibration -> from truth:%s\n", text.c_str());
  }
  // The candidate from its "off" value with everything free: the basin of the truth or not?
  Eigen::VectorXd off = from_diag;
  for (std::size_t p = 0; p < cand->params.size(); ++p) {
    off(ns + static_cast<Eigen::Index>(p)) = cand->params[p].start;
  }
  const dg::FitResult c_off =
      dg::FitParameters(rig.model, params, off, data.train, options.fit, 0, iterations);
  show("fit from off, all free", c_off.x, c_off.cost);
  // Profile along the candidate's parameters: held at fractions of the way from "off" to the
  // planted values, the subject fitted (held parameters first: FitParameters' first_free).
  std::vector<dg::ModelParameter> held_first(cand->params.begin(), cand->params.end());
  held_first.insert(held_first.end(), subject.begin(), subject.end());
  const auto nc = static_cast<Eigen::Index>(cand->params.size());
  for (const double f : {0.0, 0.25, 0.5, 0.75, 1.0, 1.25}) {
    Eigen::VectorXd x(params.size());
    x.head(nc) = off.tail(nc) + f * (truth.tail(nc) - off.tail(nc));
    x.tail(ns) = from_diag.head(ns);
    const dg::FitResult pf = dg::FitParameters(rig.model, held_first, x, data.train, options.fit,
                                               static_cast<int>(nc), iterations);
    Eigen::VectorXd shown(params.size());
    shown << pf.x.tail(ns), pf.x.head(nc);
    char what[64];
    std::snprintf(what, sizeof what, "profile at %.2f", f);
    show(what, shown, pf.cost);
  }
  if (fitted) {
    show("diagnosis' point", from_diag, cost_at(from_diag));
    const dg::FitResult b =
        dg::FitParameters(rig.model, params, from_diag, data.train, options.fit, 0, iterations);
    show("fit from diagnosis", b.x, b.cost);
  }
}

}  // namespace

int main(int argc, char** argv) {
  int per = 10, clean = 20, pairs = 10, outside = 5, trials = 3, threads = 2, verbose = 0,
      effects_only = 0, oracle = 0, identifiable = 0;
  double duration = 60.0, effect_floor = 1.0;
  int baseline_iterations = fesim::diagnosis::DiagnoseOptions().baseline_iterations;
  int max_screened = fesim::diagnosis::DiagnoseOptions().max_screened;
  bool batches_while_structured = fesim::diagnosis::DiagnoseOptions().batches_while_structured;
  std::set<std::uint64_t> only;  // --only: the datasets kept, by seed (empty: all)
  double speed_time_scale =
      fesim::diagnosis::DiagnoseOptions::DefaultFitOptions().speed_time_scale_s;
  double tolerance = fesim::diagnosis::DiagnoseOptions::DefaultFitOptions().tolerance;
  double lm_tolerance = fesim::diagnosis::DiagnoseOptions::DefaultFitOptions().relative_tolerance;
  double fd_step = fesim::diagnosis::DiagnoseOptions::DefaultFitOptions().fd_step;
  std::vector<double> baseline_fd_steps = fesim::diagnosis::DiagnoseOptions{}.baseline_fd_steps;
  std::uint64_t first_seed = 1000;
  std::string out_path = "docs/diagnosis.md";
  std::string model = "full";  // or a reduced model (diagnose --model NAME)
  std::string protocol;        // "steps" / "grid" for every dataset; empty: alternate
  std::vector<std::string> mechanisms;
  std::vector<std::vector<std::string>> pair_list;  // --pair-list a+b,c+d (cycled)
  const char* usage =
      "usage: diagnosis_suite [--per N] [--clean N] [--pairs N] [--outside N] [--trials T]\n"
      "  [--duration S] [--mechanisms a,b,...] [--threads N] [--out FILE] [--seed S]\n"
      "  [--model full|NAME] [--protocol steps|grid] [--pair-list a+b,...] [--verbose N]\n"
      "  [--effects-only 0|1] [--speed-time-scale S] [--baseline-iterations N] [--tolerance TOL]\n"
      "  [--max-screened N] [--batches-while-structured 0|1] [--only SEED,SEED,...]\n"
      "  [--lm-tolerance R] [--fd-step H] [--baseline-fd-steps H,...]\n"
      "  [--oracle ITERATIONS] (single datasets: fits of the planted mechanism from the truth)\n"
      "  [--identifiable ITERATIONS] (single and clean datasets: the effect left after "
      "calibrating\n"
      "      the subject from the participant's true values; default 0 = off)\n"
      "  [--effect-floor R] (single datasets: effect RMS raised to >= R x noise; default 1)\n"
      "  (defaults: the full suite, hours of CPU)\n";
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h") {
      std::fputs(usage, stdout);
      return 0;
    }
  }
  if (argc % 2 == 0) {
    std::fprintf(stderr, "diagnosis_suite: option %s has no value\n%s", argv[argc - 1], usage);
    return 2;
  }
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--per")
      per = std::atoi(v.c_str());
    else if (k == "--clean")
      clean = std::atoi(v.c_str());
    else if (k == "--pairs")
      pairs = std::atoi(v.c_str());
    else if (k == "--outside")
      outside = std::atoi(v.c_str());
    else if (k == "--trials")
      trials = std::atoi(v.c_str());
    else if (k == "--threads")
      threads = std::atoi(v.c_str());
    else if (k == "--verbose")
      verbose = std::atoi(v.c_str());
    else if (k == "--effects-only")
      effects_only = std::atoi(v.c_str());
    else if (k == "--oracle")
      oracle = std::atoi(v.c_str());
    else if (k == "--identifiable")
      identifiable = std::atoi(v.c_str());
    else if (k == "--seed")
      first_seed = std::strtoull(v.c_str(), nullptr, 10);
    else if (k == "--duration")
      duration = std::atof(v.c_str());
    else if (k == "--effect-floor")
      effect_floor = std::atof(v.c_str());
    else if (k == "--speed-time-scale")
      speed_time_scale = std::atof(v.c_str());
    else if (k == "--tolerance")
      tolerance = std::atof(v.c_str());
    else if (k == "--lm-tolerance")
      lm_tolerance = std::atof(v.c_str());
    else if (k == "--fd-step")
      fd_step = std::atof(v.c_str());
    else if (k == "--baseline-fd-steps") {
      baseline_fd_steps.clear();
      for (const auto& part : Split(v)) baseline_fd_steps.push_back(std::atof(part.c_str()));
    } else if (k == "--baseline-iterations")
      baseline_iterations = std::atoi(v.c_str());
    else if (k == "--max-screened")
      max_screened = std::atoi(v.c_str());
    else if (k == "--batches-while-structured")
      batches_while_structured = std::atoi(v.c_str()) != 0;
    else if (k == "--only") {
      for (const auto& part : Split(v)) only.insert(std::strtoull(part.c_str(), nullptr, 10));
    } else if (k == "--mechanisms")
      mechanisms = Split(v);
    else if (k == "--out")
      out_path = v;
    else if (k == "--model")
      model = v;
    else if (k == "--protocol")
      protocol = v;
    else if (k == "--pair-list") {
      for (const auto& pair : Split(v)) {
        const auto plus = pair.find('+');
        if (plus == std::string::npos) {
          std::fprintf(stderr, "diagnosis_suite: --pair-list entry '%s' is not a+b\n",
                       pair.c_str());
          return 2;
        }
        pair_list.push_back({pair.substr(0, plus), pair.substr(plus + 1)});
      }
    } else {
      std::fprintf(stderr, "diagnosis_suite: unknown option %s\n", k.c_str());
      return 2;
    }
  }
  const fesim::Scenario rig =
      fesim::LoadScenario(std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/hand_rig.yaml");
  // arm_support needs an elbow / shoulder output: its datasets use the elbow rig (bic/tri steps
  // or grid up to 240 µs, elbow ≈ 35–130°; the hand rig has no free elbow).
  const fesim::Scenario elbow_rig =
      fesim::LoadScenario(std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/elbow_support_rig.yaml");
  if (mechanisms.empty()) {
    for (const auto& id : fesim::diagnosis::MechanismIds()) {
      mechanisms.push_back(id);
    }
  }
  std::vector<Case> cases;
  std::uint64_t seed = first_seed;
  const double scales[] = {1.0, 1.5, 2.0};
  for (const auto& id : mechanisms) {
    for (int k = 0; k < per; ++k) {
      Case c;
      c.kind = "single";
      c.spec.mechanisms = {id};
      c.spec.effect_scale = scales[k % 3];
      const auto protocols = fesim::diagnosis::PlantedProtocols(id);
      c.spec.protocol = protocols[k % protocols.size()];
      c.spec.seed = ++seed;
      if (id == "arm_support") {
        c.spec.channels = {"bic", "tri"};
        c.spec.max_us = 240.0;
      }
      cases.push_back(c);
    }
  }
  for (int k = 0; k < clean; ++k) {
    Case c;
    c.kind = "clean";
    c.spec.protocol = k % 2 ? "grid" : "steps";
    c.spec.seed = ++seed;
    cases.push_back(c);
  }
  if (pair_list.empty()) {
    pair_list = {{"fatigue", "tremor"},
                 {"delay", "sensor_drift"},
                 {"stiction", "tremor"},
                 {"potentiation", "delay"},
                 {"fatigue", "sensor_drift"}};
  }
  for (int k = 0; k < pairs; ++k) {
    Case c;
    c.kind = "pair";
    c.spec.mechanisms = pair_list[k % pair_list.size()];
    c.spec.effect_scale = 1.5;
    c.spec.protocol = k % 2 ? "grid" : "steps";
    c.spec.seed = ++seed;
    cases.push_back(c);
  }
  for (int k = 0; k < outside; ++k) {
    Case c;
    c.kind = "outside";
    c.spec.mechanisms = {"outside"};
    c.spec.effect_scale = 1.0 + 0.5 * (k % 3);
    c.spec.protocol = k % 2 ? "grid" : "steps";
    c.spec.seed = ++seed;
    cases.push_back(c);
  }
  fesim::diagnosis::DiagnoseOptions options;
  options.fit.threads = threads;
  options.fit.speed_time_scale_s = speed_time_scale;
  options.fit.tolerance = tolerance;
  options.fit.relative_tolerance = lm_tolerance;
  options.fit.fd_step = fd_step;
  options.baseline_fd_steps = baseline_fd_steps;
  options.baseline_iterations = baseline_iterations;
  options.max_screened = max_screened;
  options.batches_while_structured = batches_while_structured;
  options.model = model;
  if (model != "full") {
    for (const auto& m : fesim::diagnosis::ReducedModelMethods()) {
      if (m.name == model) options.reduced_fit = m.fit_simulator;
    }
    if (!options.reduced_fit) {
      std::fprintf(stderr, "diagnosis_suite: --model %s is not a reduced model\n", model.c_str());
      return 2;
    }
  }
  if (!protocol.empty()) {
    for (auto& c : cases) c.spec.protocol = protocol;
  }
  if (!only.empty()) {  // after the seeds, scales and protocols are assigned: the same datasets
    std::vector<Case> kept;
    for (auto& c : cases) {
      if (only.count(c.spec.seed)) kept.push_back(std::move(c));
    }
    cases = std::move(kept);
  }
  const auto t0 = std::chrono::steady_clock::now();
  double wall_sum = 0.0, wall_max = 0.0;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    Case& c = cases[i];
    c.spec.trials = trials;
    c.spec.duration_s = duration;
    const fesim::Scenario& case_rig = c.spec.channels[0] == "bic" ? elbow_rig : rig;
    c.data = c.kind == "single"
                 ? fesim::diagnosis::MakePlantedDatasetAtLeast(case_rig, &c.spec, effect_floor)
                 : fesim::diagnosis::MakePlantedDataset(case_rig, c.spec);
    std::string alone;
    if (c.kind == "pair") {
      std::vector<fesim::diagnosis::PlantedDataset> single;
      for (const auto& m : c.spec.mechanisms) {
        fesim::diagnosis::PlantedSpec one = c.spec;
        one.mechanisms = {m};
        single.push_back(fesim::diagnosis::MakePlantedDataset(case_rig, one));
        c.alone_effect.push_back(single.back().effect_rms_rad / single.back().noise_rms_rad);
      }
      for (std::size_t k = 0; k < 2; ++k) {
        c.marginal_effect.push_back(RmsDifference(c.data.trials, single[1 - k].trials) /
                                    c.data.noise_rms_rad);
        char b[160];
        std::snprintf(b, sizeof b, "%s%s %.2f alone, %.2f on top", k ? "; " : " (",
                      c.spec.mechanisms[k].c_str(), c.alone_effect[k], c.marginal_effect[k]);
        alone += b;
      }
      alone += ")";
    }
    std::string ident;
    if (identifiable > 0 && (c.kind == "single" || c.kind == "clean")) {
      c.identifiable = EffectFromTrueCalibration(case_rig, c, options, identifiable);
      char b[64];
      std::snprintf(b, sizeof b, ", from the true calibration %.2f", c.identifiable);
      ident = b;
    }
    if (effects_only) {
      std::string planted;
      for (const auto& m : c.spec.mechanisms) planted += (planted.empty() ? "" : "+") + m;
      std::fprintf(stderr, "%s scale %.1f %s seed %llu effect/noise %.2f%s%s\n",
                   planted.empty() ? "none" : planted.c_str(), c.spec.effect_scale,
                   c.spec.protocol.c_str(), static_cast<unsigned long long>(c.spec.seed),
                   c.data.effect_rms_rad / c.data.noise_rms_rad, alone.c_str(), ident.c_str());
      continue;
    }
    const auto tc = std::chrono::steady_clock::now();
    c.result = fesim::diagnosis::Diagnose(
        case_rig.model, c.data.trials, options, [&](double f, const std::string& stage) {
          if (verbose) {
            std::fprintf(
                stderr, "  %6.1f s %3.0f %% %s\n",
                std::chrono::duration<double>(std::chrono::steady_clock::now() - tc).count(),
                100 * f, stage.c_str());
          }
        });
    if (verbose >= 2) {
      std::fprintf(stderr, "    participant stiffness %.3f strength %.3f\n", c.data.stiffness_scale,
                   c.data.strength_scale);
      for (const auto& sp : c.result.subject_parameters) {
        std::fprintf(stderr, "    subject %s = %.4g\n", sp.name.c_str(), sp.value);
      }
      std::fprintf(stderr, "    baseline held-out NRMSE %.4f, extended %.4f, sims %d\n",
                   c.result.baseline_heldout_nrmse, c.result.extended_heldout_nrmse,
                   c.result.simulations);
      for (const auto& sg : c.result.signatures) {
        std::fprintf(stderr, "    %s structure base %.3f ext %.3f rms %.4f\n", sg.output.c_str(),
                     sg.structure_heldout_baseline, sg.structure_heldout_extended, sg.rms_rad);
      }
      for (const auto& cr : c.result.candidates) {
        std::fprintf(stderr, "    %s\n", fesim::diagnosis::CandidateLogLine(cr).c_str());
      }
    }
    if (verbose >= 1) {
      for (const auto& p : c.data.planted) {
        const double e = ParamError(c, p);
        std::fprintf(stderr, "    planted %s = %.5g, fitted rel. error %s\n", p.name.c_str(),
                     p.value, std::isfinite(e) ? std::to_string(e).c_str() : "-");
      }
      for (const auto& p : c.result.extension_parameters) {
        std::fprintf(stderr, "    extension %s = %.5g +- %.2g %s\n", p.name.c_str(), p.value,
                     p.ci95, p.unit.c_str());
      }
    }
    if (oracle > 0) OracleCheck(case_rig, c, options, oracle);
    wall_sum += c.result.wall_s;
    wall_max = std::max(wall_max, c.result.wall_s);
    std::string planted;
    for (const auto& m : c.spec.mechanisms) planted += (planted.empty() ? "" : "+") + m;
    std::string found;
    for (const auto& m : c.result.mechanisms) found += (found.empty() ? "" : "+") + m;
    std::fprintf(stderr,
                 "[%zu/%zu] %-8s planted %-32s scale %.1f %-5s seed %llu effect/noise %.2f%s -> "
                 "%s (%s) conf %.2f gain %.3f  %.1f s, after calibration %.2f%s\n",
                 i + 1, cases.size(), c.kind.c_str(), planted.empty() ? "none" : planted.c_str(),
                 c.spec.effect_scale, c.spec.protocol.c_str(),
                 static_cast<unsigned long long>(c.spec.seed),
                 c.data.effect_rms_rad / c.data.noise_rms_rad, alone.c_str(),
                 c.result.cause.c_str(), found.c_str(), c.result.confidence, c.result.gain,
                 c.result.wall_s, EffectAfterCalibration(c), ident.c_str());
  }
  const double total_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // Confusion matrix of single-mechanism and clean cases: planted → named cause.
  std::vector<std::string> rows = mechanisms;
  rows.emplace_back("none");
  std::vector<std::string> cols = rows;
  cols.emplace_back("unexplained");
  cols.emplace_back("other");
  std::map<std::string, std::map<std::string, int>> confusion;
  std::map<std::string, int> totals, correct, gain_ok;
  std::map<std::string, std::vector<double>> perr;
  for (const auto& c : cases) {
    if (c.kind != "single" && c.kind != "clean") continue;
    const std::string truth = c.kind == "clean" ? "none" : c.spec.mechanisms[0];
    std::string named = c.result.cause;
    bool known = false;
    for (const auto& col : cols) known |= col == named;
    confusion[truth][known ? named : "other"]++;
    totals[truth]++;
    if (named == truth) {
      correct[truth]++;
      if (truth == "none" || c.result.gain > 0.0) gain_ok[truth]++;
      for (const auto& p : c.data.planted) {
        const double e = ParamError(c, p);
        if (std::isfinite(e)) perr[truth].push_back(e);
      }
    }
  }
  int pair_both = 0, pair_n = 0, outside_ok = 0, outside_n = 0;
  std::string pair_lines, outside_lines;
  for (const auto& c : cases) {
    if (c.kind == "pair") {
      ++pair_n;
      std::set<std::string> named(c.result.mechanism_ids.begin(), c.result.mechanism_ids.end());
      const bool both = named.count(c.spec.mechanisms[0]) && named.count(c.spec.mechanisms[1]);
      pair_both += both ? 1 : 0;
      std::string found;
      for (const auto& m : c.result.mechanisms) found += (found.empty() ? "" : ", ") + m;
      char eff[128];
      std::snprintf(eff, sizeof eff, "%.2f | %.2f, %.2f | %.2f, %.2f",
                    c.data.effect_rms_rad / c.data.noise_rms_rad, c.alone_effect[0],
                    c.alone_effect[1], c.marginal_effect[0], c.marginal_effect[1]);
      pair_lines += "| " + c.spec.mechanisms[0] + " + " + c.spec.mechanisms[1] + " | " +
                    c.spec.protocol + " | " + std::to_string(c.spec.seed) + " | " + eff + " | " +
                    (found.empty() ? c.result.cause : found) + " | " + (both ? "yes" : "no") +
                    " |\n";
    } else if (c.kind == "outside") {
      ++outside_n;
      const bool ok =
          c.result.cause == "unexplained" || c.result.cause == "none" || c.result.confidence < 0.5;
      outside_ok += ok ? 1 : 0;
      char buf[256];
      std::snprintf(buf, sizeof buf, "| %.1f | %s | %s | %.2f | %s |\n", c.spec.effect_scale,
                    c.spec.protocol.c_str(), c.result.cause.c_str(), c.result.confidence,
                    ok ? "yes" : "no");
      outside_lines += buf;
    }
  }
  int below_floor = 0, singles = 0;
  for (const auto& c : cases) {
    if (c.kind != "single") continue;
    ++singles;
    below_floor += c.data.effect_rms_rad < effect_floor * c.data.noise_rms_rad ? 1 : 0;
  }
  std::string md;
  char buf[1024];
  md += "# Diagnosis: planted-effect suite (issue 7)\n\n";
  md += "Generated by `bench/diagnosis_suite.cc`; reproduce with\n\n```\n";
  std::string cmd = "build/bin/diagnosis_suite";
  for (int i = 1; i < argc; ++i) cmd += std::string(" ") + argv[i];
  md += cmd + "\n```\n\n";
  std::snprintf(buf, sizeof buf,
                "Rig: `scenarios/hand_rig.yaml` (wrist, MCP, PIP free; ext/flex array channels; "
                "60 Hz tracker, 1 deg noise); arm_support on `scenarios/elbow_support_rig.yaml` "
                "(elbow free, bic/tri, 100 Hz goniometer, 0.5 deg noise, u_max 240 us). %d trials "
                "of %.0f s per dataset (\"grid\": 56 s). "
                "Participants: stiffness and strength scales drawn in [0.8, 1.25]; protocols "
                "alternate pseudo-random steps / paper 000 step grid (2 s steps; spasticity steps "
                "only); effect scales 1, 1.5, 2 (diagnosis/planted.h), on single datasets raised "
                "until the effect RMS is >= %.2f x the noise RMS (below it after raising: %d of "
                "%d). %zu datasets, %.0f s in total, diagnosis wall "
                "time mean %.1f s, max %.1f s (%d threads).\n\n",
                trials, duration, effect_floor, below_floor, singles, cases.size(), total_s,
                wall_sum / std::max<std::size_t>(1, cases.size()), wall_max, threads);
  md += buf;
  md +=
      "## Rates\n\n| planted | datasets | right cause | rate | held-out gain > 0 when right | "
      "parameter rel. error (median, max) | effect RMS / noise RMS | after calibration "
      "| from the true calibration |\n|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : rows) {
    if (!totals[r]) continue;
    auto e = perr[r];
    std::sort(e.begin(), e.end());
    std::string es = e.empty() ? "-" : "";
    if (!e.empty()) {
      std::snprintf(buf, sizeof buf, "%.2f, %.2f", e[e.size() / 2], e.back());
      es = buf;
    }
    double eff_min = 1e9, eff_max = 0, cal_min = 1e9, cal_max = 0, id_min = 1e9, id_max = -1;
    for (const auto& c : cases) {
      const std::string truth =
          c.kind == "clean" ? "none" : (c.kind == "single" ? c.spec.mechanisms[0] : "");
      if (truth != r) continue;
      cal_min = std::min(cal_min, EffectAfterCalibration(c));
      cal_max = std::max(cal_max, EffectAfterCalibration(c));
      if (std::isfinite(c.identifiable)) {
        id_min = std::min(id_min, c.identifiable);
        id_max = std::max(id_max, c.identifiable);
      }
      if (r == "none") continue;
      eff_min = std::min(eff_min, c.data.effect_rms_rad / c.data.noise_rms_rad);
      eff_max = std::max(eff_max, c.data.effect_rms_rad / c.data.noise_rms_rad);
    }
    std::string eff = r == "none" ? "0" : "";
    if (r != "none") {
      std::snprintf(buf, sizeof buf, "%.2f–%.2f", eff_min, eff_max);
      eff = buf;
    }
    std::snprintf(buf, sizeof buf, "%.2f–%.2f", cal_min, cal_max);
    const std::string cal = buf;
    std::string ident = "-";
    if (id_max >= 0.0) {
      std::snprintf(buf, sizeof buf, "%.2f–%.2f", id_min, id_max);
      ident = buf;
    }
    std::snprintf(buf, sizeof buf, "| %s | %d | %d | %.0f %% | %d/%d | %s | %s | %s | %s |\n",
                  r.c_str(), totals[r], correct[r], 100.0 * correct[r] / totals[r], gain_ok[r],
                  correct[r], es.c_str(), eff.c_str(), cal.c_str(), ident.c_str());
    md += buf;
  }
  std::snprintf(buf, sizeof buf,
                "\nTwo mechanisms at once: both named in %d/%d (%.0f %%). Effect outside the "
                "library: `unexplained`/`none` or confidence < 0.5 in %d/%d.\n\n",
                pair_both, pair_n, pair_n ? 100.0 * pair_both / pair_n : 0.0, outside_ok,
                outside_n);
  md += buf;
  md += "## Confusion matrix (rows planted, columns named cause)\n\n| planted |";
  for (const auto& c : cols) md += " " + c + " |";
  md += "\n|---|";
  for (std::size_t k = 0; k < cols.size(); ++k) md += "---|";
  md += "\n";
  for (const auto& r : rows) {
    if (!totals[r]) continue;
    md += "| " + r + " |";
    for (const auto& c : cols) {
      const int v = confusion[r][c];
      md += v ? " " + std::to_string(v) + " |" : " |";
    }
    md += "\n";
  }
  if (pair_n)
    md +=
        "\n## Two mechanisms\n\n| planted | protocol | seed | effect / noise | each alone | each "
        "on "
        "top of the other | named | both |\n|---|---|---|---|---|---|---|---|\n" +
        pair_lines;
  if (outside_n) {
    md +=
        "\n## Outside the library (0.1 Hz baseline wander)\n\n| scale | protocol | cause | "
        "confidence | acceptable |\n|---|---|---|---|---|\n" +
        outside_lines;
  }
  fesim::WriteFileAtomic(out_path, md);
  std::fprintf(stderr, "wrote %s\n", out_path.c_str());
  return 0;
}
