// The validation suites of `fesim diagnose` (docs/diagnosis.md "Validation"): planted-effect data
// sets diagnosed blind, counted against their truth.
//
//   --suite foreign  data from the independent simulator (foreign/dataset.h): drawn persons,
//                    three trials (steps, grid, steps; the last held out), effects raised to
//                    --floor × the noise RMS (default 1); library mechanisms (every id the
//                    hand rig can show), clean persons, out-of-library effects (wander, slip,
//                    voluntary) and pairs
//   --suite family   data from fesim's own model (diagnosis/planted.h) with wide persons, effects
//                    raised to --floor × the noise RMS (default 0.5); hand rig, arm_support on the
//                    elbow rig
//
//   diagnosis_suite --suite foreign|family [--per N] [--clean N] [--outside N] [--pairs N]
//                   [--mechanisms a,b,…] [--floor R] [--seed S] [--only SEED,…] [--threads N]
//                   [--rhs simbody|chain] [--out FILE.md] [--json FILE.json] [--verbose 0|1|2]
//                   [--reuse OLD.json [--rerun SEED,…]] [--data DIR] [--diagnose 0|1]
//                   [--twin 0|1] [--protocols steps,grid,...] [--heldout N]
//
// --data: each data set's trials are also written as DIR/<seed>/trial<k>.csv (the last the
// held-out one), so that `fesim diagnose DIR/<seed>/trial1.csv,… --scenario <rig>` diagnoses the
// same data with its report, plots and cache (the rig is in the data set's line of --json);
// --diagnose 0 writes them without diagnosing.
//
// --reuse: the data sets found in an earlier run's --json output (same seed, kind and planted
// effects) are taken from it instead of being diagnosed again, except those --rerun lists; the
// Markdown says how many were read. For a change whose effect is confined to data sets one can
// name (e.g. those that fitted a given candidate): the others' diagnoses are the same by
// determinism (fixed seeds, results independent of the thread count).
//
// --twin 1: every data set with planted effects is diagnosed a second time without them — its
// clean twin: the same person, stimulation, noise and dropouts, the effects off
// (foreign::MakeDataset or diagnosis::MakePlantedDataset with no effects, the same seeds). Beside
// each such data set the Markdown gives the twin's verdict and, on the held-out trial, the planted
// effect's RMS (noiseless reads with − without) and what the calibrated model leaves of it: the RMS
// of that difference minus the difference of the two calibrated models' held-out predictions, both
// over the noise σ. An effect the calibration reproduces leaves ≈ 0 for any mechanism to explain;
// --json holds the twin's whole diagnosis. Not with --reuse (the twin needs the planted run's
// predictions).
//
// --protocols (foreign suite): the trials of each data set, in order (steps, grid, multisine;
// default steps,grid,steps), the last --heldout of them held out; the first trials are the same
// whatever follows them. Measures what more trials per person give (docs/diagnosis.md, Known
// limits "Six trials per person instead of three").
//
// --heldout N (foreign suite, not with --twin): the last N trials of each data set are held out
// (DiagnoseSettings::heldout_trials; 1 ≤ N < the number of trials).
//
// --rhs: the fits' right-hand side (diagnosis::FitOptions::simbody_right_hand_side; chain, the
// articulated-body one and the default, or simbody), to see which verdicts turn on round-off.
//
// Every data set has its own seed (--seed + 1, + 2, … in the order single per mechanism, clean,
// outside, pairs), so `--only` reruns any of them alone. The Markdown (default: stdout) holds the
// rates beside the targets of docs/diagnosis.md, the confusion table, the calibrated model beside
// the black box, wall times, and one line per data set; --json the same per data set.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "base/json.h"
#include "base/trial.h"
#include "diagnosis/diagnose.h"
#include "diagnosis/mechanisms/mechanism.h"
#include "diagnosis/planted.h"
#include "diagnosis/report.h"
#include "foreign/dataset.h"
#include "scenarios/scenario.h"

namespace {

namespace dg = fesim::diagnosis;

std::vector<std::string> Split(const std::string& s, char sep = ',') {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, sep)) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

std::string F(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

struct Options {
  std::string suite = "foreign";
  int per = 10, clean = 20, outside = 5, pairs = 10, threads = 2, verbose = 0;
  double floor = NAN;  // suite default
  std::uint64_t seed = 1000;
  std::set<std::uint64_t> only;
  std::vector<std::string> mechanisms;
  std::string out, json;
  bool simbody_rhs = false;                                         // --rhs
  std::string reuse;                                                // --reuse
  std::set<std::uint64_t> rerun;                                    // --rerun
  std::string data;                                                 // --data
  bool diagnose = true;                                             // --diagnose
  bool twin = false;                                                // --twin
  std::vector<std::string> protocols = {"steps", "grid", "steps"};  // --protocols (foreign)
  int heldout = 1;                                                  // --heldout
};

/// The clean twin of a planted data set (--twin) and what the calibration left of the effect.
struct Twin {
  bool run = false;
  dg::Diagnosis result;
  double wall_s = 0.0;
  double heldout_effect = NAN;  // RMS of the planted effect on the held-out trial / noise σ
  double heldout_left = NAN;    // RMS of what the calibrated model leaves of it / noise σ
  double heldout_misfit = NAN;  // RMS of the twin's calibrated held-out residual / noise σ
};

/// The names joined by "+" ("" for none).
std::string Joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : "+") + n;
  return out;
}

/// One data set of a suite and what the diagnosis said.
struct Case {
  std::string kind;                  // single, clean, outside, pair
  std::vector<std::string> planted;  // effect ids (empty: clean)
  std::uint64_t seed = 0;
  std::string protocol;       // family suite: steps / grid
  double effect_ratio = 0.0;  // effect RMS / noise RMS
  std::vector<fesim::Trial> trials;
  std::vector<fesim::Trial> truth;  // noiseless reads (--twin)
  double noise_rad = NAN;           // noise σ, rad
  std::string rig;                  // scenario file of the rig
  /// What was planted: the family suite's mechanism parameters; the foreign suite's effect
  /// scales s as raised to the floor (`<id>.scale`; foreign/effects.cc gives each effect's
  /// parameters per unit of s).
  std::vector<dg::NamedValue> planted_values;
  std::string planted_joint;  // single: the joint a joint-local effect acts at, else empty
  dg::Diagnosis result;
  double wall_s = 0.0;
  /// --reuse: the earlier run's "diagnosis" object (null: diagnosed in this run); `result` then
  /// holds only what the Markdown reads (ReusedResult).
  fesim::Json reused;
  Twin twin;
};

bool Named(const Case& c, const std::string& id) {
  return std::find(c.result.mechanism_ids.begin(), c.result.mechanism_ids.end(), id) !=
         c.result.mechanism_ids.end();
}

/// The accepted label ("id" or "id@joint") of the verdict's cause, or the cause itself.
std::string CauseLabel(const Case& c) {
  for (std::size_t k = 0; k < c.result.mechanism_ids.size(); ++k) {
    if (c.result.mechanism_ids[k] == c.result.cause) return c.result.mechanisms[k];
  }
  return c.result.cause;
}

/// Right: single — the cause is the planted id, at the planted joint when the effect is local
/// to one joint and the cause is named at a joint; clean — none; outside — no library mechanism
/// at confidence ≥ 0.5; pair — both ids accepted.
bool Right(const Case& c) {
  if (c.kind == "single") {
    if (c.result.cause != c.planted[0]) return false;
    const std::string label = CauseLabel(c);
    const auto at = label.find('@');
    return c.planted_joint.empty() || at == std::string::npos ||
           label.substr(at + 1) == c.planted_joint;
  }
  if (c.kind == "clean") return c.result.cause == "none";
  if (c.kind == "outside") {
    return c.result.cause == "none" || c.result.cause == "unexplained" || c.result.confidence < 0.5;
  }
  return Named(c, c.planted[0]) && Named(c, c.planted[1]);
}

/// The library mechanisms a suite plants: every id applicable on its rig(s).
std::vector<std::string> SuiteMechanisms(const Options& o) {
  if (!o.mechanisms.empty()) return o.mechanisms;
  std::vector<std::string> out;
  for (const auto& id : dg::MechanismIds()) {
    if (o.suite == "foreign" && id == "arm_support") continue;  // the foreign hand has no arm
    out.push_back(id);
  }
  return out;
}

std::vector<Case> PlanCases(const Options& o) {
  std::vector<Case> cases;
  std::uint64_t seed = o.seed;
  for (const auto& id : SuiteMechanisms(o)) {
    for (int k = 0; k < o.per; ++k) {
      Case c;
      c.kind = "single";
      c.planted = {id};
      c.seed = ++seed;
      const auto protocols = dg::PlantedProtocols(id);
      c.protocol = protocols[static_cast<std::size_t>(k) % protocols.size()];
      cases.push_back(c);
    }
  }
  const std::vector<std::string> outside =
      o.suite == "foreign" ? std::vector<std::string>{"wander", "slip", "voluntary"}
                           : std::vector<std::string>{"outside"};
  for (int k = 0; k < o.clean; ++k) {
    Case c;
    c.kind = "clean";
    c.seed = ++seed;
    c.protocol = k % 2 ? "grid" : "steps";
    cases.push_back(c);
  }
  for (int k = 0; k < o.outside; ++k) {
    Case c;
    c.kind = "outside";
    c.planted = {outside[static_cast<std::size_t>(k) % outside.size()]};
    c.seed = ++seed;
    c.protocol = k % 2 ? "grid" : "steps";
    cases.push_back(c);
  }
  const std::vector<std::vector<std::string>> pair_list = {{"fatigue", "tremor"},
                                                           {"delay", "sensor_drift"},
                                                           {"stiction", "tremor"},
                                                           {"potentiation", "delay"},
                                                           {"fatigue", "sensor_drift"}};
  for (int k = 0; k < o.pairs; ++k) {
    Case c;
    c.kind = "pair";
    c.planted = pair_list[static_cast<std::size_t>(k) % pair_list.size()];
    c.seed = ++seed;
    c.protocol = k % 2 ? "grid" : "steps";
    cases.push_back(c);
  }
  if (!o.only.empty()) {
    std::vector<Case> kept;
    for (auto& c : cases) {
      if (o.only.count(c.seed)) kept.push_back(std::move(c));
    }
    cases = std::move(kept);
  }
  return cases;
}

std::string SourcePath(const std::string& rel) {
  return std::string(FESIM_SOURCE_DIR_PATH) + "/" + rel;
}

/// Simulates a case's data (its trials, effect ratio, planted values).
/// Writes a data set's trials as `dir`/<seed>/trial<k>.csv, k = 1, 2, … (throws on failure).
void WriteTrials(const std::string& dir, const Case& c) {
  const std::filesystem::path at = std::filesystem::path(dir) / std::to_string(c.seed);
  std::filesystem::create_directories(at);
  for (std::size_t k = 0; k < c.trials.size(); ++k) {
    fesim::WriteFileAtomic((at / ("trial" + std::to_string(k + 1) + ".csv")).string(),
                           fesim::FormatTrialCsv(c.trials[k]));
  }
}

/// A foreign data set of `seed` with `planted` at the floor (none: the clean person).
fesim::foreign::Dataset ForeignData(const Options& o, std::uint64_t seed,
                                    const std::vector<std::string>& planted, double floor) {
  fesim::foreign::DatasetSpec spec;
  spec.protocols = o.protocols;
  spec.person_seed = seed;
  spec.seed = seed;
  spec.floor = floor;
  for (const auto& id : planted) spec.effects.push_back({id, 1.0});
  return fesim::foreign::MakeDataset(spec);
}

/// A family case's rig (scenario file) and data set spec: a wide person of the case's seed on the
/// hand rig, or on the elbow rig for arm_support; the case's effects at scale 1.
struct FamilyRig {
  std::string file;
  dg::PlantedSpec spec;
};

FamilyRig FamilySpec(const Case& c) {
  const bool elbow = !c.planted.empty() && c.planted[0] == "arm_support";
  FamilyRig r;
  r.file = elbow ? "scenarios/elbow_support_rig.yaml" : "scenarios/hand_rig.yaml";
  r.spec.mechanisms = c.planted;
  r.spec.person = dg::PersonSpread::kWide;
  r.spec.protocol = c.protocol;
  r.spec.seed = c.seed;
  if (elbow) {
    r.spec.channels = {"bic", "tri"};
    r.spec.max_us = 240.0;
  }
  return r;
}

void MakeData(const Options& o, double floor, Case* c) {
  if (o.suite == "foreign") {
    const fesim::foreign::Dataset d = ForeignData(o, c->seed, c->planted, floor);
    c->trials = d.trials;
    c->truth = d.truth;
    c->noise_rad = d.noise_rms_rad;
    c->effect_ratio = d.effect_rms_rad / d.noise_rms_rad;
    c->planted_values.clear();
    for (const auto& e : d.effects) c->planted_values.push_back({e.id + ".scale", "1", e.scale});
    c->rig = "scenarios/hand_rig.yaml";
    if (c->kind == "single") {
      const int j = fesim::foreign::MakeEffect({c->planted[0], 1.0}, {})->JointIndex();
      if (j >= 0) c->planted_joint = fesim::foreign::kJointNames[static_cast<std::size_t>(j)];
    }
    return;
  }
  FamilyRig r = FamilySpec(*c);
  c->rig = r.file;
  const fesim::Scenario rig = fesim::LoadScenario(SourcePath(r.file));
  const dg::PlantedDataset d = c->kind == "clean"
                                   ? dg::MakePlantedDataset(rig, r.spec)
                                   : dg::MakePlantedDatasetAtLeast(rig, &r.spec, floor);
  c->trials = d.trials;
  c->truth = d.truth;
  c->noise_rad = d.noise_rms_rad;
  c->effect_ratio = d.effect_rms_rad / d.noise_rms_rad;
  c->planted_values = d.planted;
  if (c->kind == "single" && !d.planted.empty()) {  // label "id@joint:parameter"
    const std::string& label = d.planted[0].name;
    const auto at = label.find('@'), colon = label.find(':');
    if (at != std::string::npos && colon != std::string::npos && at < colon) {
      c->planted_joint = label.substr(at + 1, colon - at - 1);
    }
  }
}

/// Diagnoses `trials` on the case's rig with the suite's settings; its wall time into *wall_s.
dg::Diagnosis DiagnoseTrials(const Options& o, const Case& c,
                             const std::vector<fesim::Trial>& trials, double* wall_s) {
  const fesim::Scenario rig = fesim::LoadScenario(SourcePath(c.rig));
  dg::DiagnoseSettings settings;
  settings.fit.simbody_right_hand_side = o.simbody_rhs;
  settings.heldout_trials = o.heldout;
  dg::DiagnoseExecution exec;
  exec.threads = o.threads;
  const auto tc = std::chrono::steady_clock::now();
  if (o.verbose >= 1) {
    exec.progress = [&](double f, const std::string& stage) {
      std::fprintf(stderr, "  %6.1f s %3.0f %% %s\n",
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - tc).count(),
                   100 * f, stage.c_str());
    };
  }
  dg::Diagnosis d = dg::Diagnose(rig.model, trials, settings, exec);
  *wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - tc).count();
  return d;
}

/// Column `q` of `t` at `times` (a subset of t.time, matched within 1 ns), NaN where t has no
/// such sample or no such column.
std::vector<double> ColumnAt(const fesim::Trial& t, const std::string& q,
                             const std::vector<double>& times) {
  std::vector<double> out(times.size(), NAN);
  if (!t.Has(q)) return out;
  const std::vector<double>& v = t.Column(q);
  for (std::size_t i = 0, k = 0; i < times.size(); ++i) {
    while (k < t.size() && t.time[k] < times[i] - 1e-9) ++k;
    if (k < t.size() && t.time[k] <= times[i] + 1e-9) out[i] = v[k];
  }
  return out;
}

/// The held-out trial's figures of Twin: at the samples of the calibrated model's held-out
/// prediction where both measured records have the output, the RMS of (noiseless with − without)
/// and of that minus (calibrated prediction with − without), and of the twin's calibrated
/// residual, each over the noise σ (the measured records may join several sensors' grids; the
/// predictions are on the outputs' sensor's). Throws std::runtime_error when the two predictions'
/// grids differ.
void HeldoutEffect(const Case& c, const std::vector<fesim::Trial>& twin_trials,
                   const std::vector<fesim::Trial>& twin_truth, Twin* twin) {
  const fesim::Trial& p1 = c.result.heldout_baseline.back();
  const fesim::Trial& p0 = twin->result.heldout_baseline.back();
  if (p0.time != p1.time) {
    throw std::runtime_error("--twin: held-out predictions of " + std::to_string(c.seed) +
                             " on different time grids");
  }
  double effect = 0.0, left = 0.0, misfit = 0.0;
  long n = 0;
  for (const std::string& q : p1.NamesWithPrefix("q.")) {
    if (!p0.Has(q)) continue;
    const std::vector<double> ya = ColumnAt(c.trials.back(), q, p1.time),
                              yb = ColumnAt(twin_trials.back(), q, p1.time),
                              ta = ColumnAt(c.truth.back(), q, p1.time),
                              tb = ColumnAt(twin_truth.back(), q, p1.time);
    const std::vector<double>&pa = p1.Column(q), &pb = p0.Column(q);
    for (std::size_t i = 0; i < pa.size(); ++i) {
      if (!std::isfinite(ya[i]) || !std::isfinite(yb[i]) || !std::isfinite(ta[i]) ||
          !std::isfinite(tb[i])) {
        continue;
      }
      const double de = ta[i] - tb[i], dp = pa[i] - pb[i], r0 = yb[i] - pb[i];
      effect += de * de;
      left += (de - dp) * (de - dp);
      misfit += r0 * r0;
      ++n;
    }
  }
  const double m = static_cast<double>(std::max<long>(1, n));
  twin->heldout_effect = std::sqrt(effect / m) / c.noise_rad;
  twin->heldout_left = std::sqrt(left / m) / c.noise_rad;
  twin->heldout_misfit = std::sqrt(misfit / m) / c.noise_rad;
}

/// --twin: diagnoses the case's clean twin and measures what the calibration left of the effect.
void DiagnoseTwin(const Options& o, Case* c) {
  std::vector<fesim::Trial> trials, truth;
  if (o.suite == "foreign") {
    fesim::foreign::Dataset d = ForeignData(o, c->seed, {}, 0.0);
    trials = std::move(d.trials);
    truth = std::move(d.truth);
  } else {
    FamilyRig r = FamilySpec(*c);
    r.spec.mechanisms.clear();  // the same person, stimulation and noise seeds
    dg::PlantedDataset d = dg::MakePlantedDataset(fesim::LoadScenario(SourcePath(r.file)), r.spec);
    trials = std::move(d.trials);
    truth = std::move(d.truth);
  }
  c->twin.result = DiagnoseTrials(o, *c, trials, &c->twin.wall_s);
  c->twin.run = true;
  HeldoutEffect(*c, trials, truth, &c->twin);
  std::fprintf(stderr,
               "  twin: %s (%.2f), held-out effect %.2f σ, left %.2f σ, twin residual %.2f σ\n",
               c->twin.result.cause.c_str(), c->twin.result.confidence, c->twin.heldout_effect,
               c->twin.heldout_left, c->twin.heldout_misfit);
}

/// --twin: one row per data set with a twin.
std::string TwinTable(const std::vector<Case>& cases) {
  std::string md =
      "| seed | planted | named | right | held-out effect / σ | left by the calibration / σ | "
      "twin's residual / σ | twin's cause | twin's confidence | calibrated, with / twin | wall s "
      "|\n"
      "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& c : cases) {
    if (!c.twin.run) continue;
    const std::string planted = Joined(c.planted);
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "| %llu | %s | %s | %s | %.2f | %.2f | %.2f | %s | %.2f | %.3f / %.3f | %.1f |\n",
                  static_cast<unsigned long long>(c.seed), planted.c_str(), c.result.cause.c_str(),
                  Right(c) ? "yes" : "no", c.twin.heldout_effect, c.twin.heldout_left,
                  c.twin.heldout_misfit, c.twin.result.cause.c_str(), c.twin.result.confidence,
                  c.result.baseline_heldout_nrmse, c.twin.result.baseline_heldout_nrmse,
                  c.twin.wall_s);
    md += buf;
  }
  return md;
}

std::string CaseLine(const Case& c) {
  std::string planted = Joined(c.planted);
  if (planted.empty()) planted = "clean";
  if (!c.planted_joint.empty()) planted += "@" + c.planted_joint;
  const std::string named = Joined(c.result.mechanisms);
  const double ref = c.result.reference.heldout_nrmse;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "| %llu | %s | %s | %.2f | %s | %s | %.2f | %.3f | %.3f | %.3f | %.1f | %s |",
                static_cast<unsigned long long>(c.seed), c.kind.c_str(), planted.c_str(),
                c.effect_ratio, c.result.cause.c_str(), named.empty() ? "-" : named.c_str(),
                c.result.confidence, c.result.baseline_heldout_nrmse, ref,
                c.result.extended_heldout_nrmse, c.wall_s, Right(c) ? "yes" : "**no**");
  return buf;
}

fesim::Json CaseJson(const Case& c) {
  fesim::Json j = fesim::Json::Object();
  j.Set("seed", static_cast<double>(c.seed)).Set("kind", c.kind);
  fesim::Json planted = fesim::Json::Array();
  for (const auto& p : c.planted) planted.Push(p);
  j.Set("planted", planted).Set("protocol", c.protocol).Set("effect_ratio", c.effect_ratio);
  if (!c.planted_joint.empty()) j.Set("planted_joint", c.planted_joint);
  fesim::Json values = fesim::Json::Array();
  for (const auto& v : c.planted_values) {
    fesim::Json e = fesim::Json::Object();
    e.Set("name", v.name).Set("unit", v.unit).Set("value", v.value);
    values.Push(e);
  }
  j.Set("planted_values", values);
  j.Set("right", Right(c)).Set("wall_s", c.wall_s);
  j.Set("diagnosis", c.reused.IsNull() ? dg::DiagnosisJson(c.result) : c.reused);
  if (c.twin.run) {
    fesim::Json t = fesim::Json::Object();
    t.Set("heldout_effect_noise", c.twin.heldout_effect)
        .Set("heldout_left_noise", c.twin.heldout_left)
        .Set("heldout_twin_residual_noise", c.twin.heldout_misfit)
        .Set("wall_s", c.twin.wall_s)
        .Set("diagnosis", dg::DiagnosisJson(c.twin.result));
    j.Set("twin", t);
  }
  return j;
}

double NumberOr(const fesim::Json* j, double fallback) {
  return j != nullptr && j->IsNumber() ? j->AsNumber() : fallback;
}

/// Member `key` of `j`; std::runtime_error naming the file and the key when it is missing.
const fesim::Json& Need(const fesim::Json& j, const std::string& key, const std::string& file) {
  const fesim::Json* v = j.IsObject() ? j.Find(key) : nullptr;
  if (v == nullptr) {
    throw std::runtime_error(file + ": a data set lacks \"" + key +
                             "\" (--reuse reads a diagnosis_suite --json output)");
  }
  return *v;
}

/// What the Markdown reads of a diagnosis, from its diagnosis.json form (report.h).
dg::Diagnosis ReusedResult(const fesim::Json& d, const std::string& file) {
  dg::Diagnosis r;
  r.cause = Need(d, "cause", file).AsString();
  r.confidence = NumberOr(d.Find("confidence"), NAN);
  r.reason = Need(d, "reason", file).AsString();
  r.gain = NumberOr(d.Find("gain"), NAN);
  const auto nrmse = [&](const char* part) {
    const fesim::Json* o = d.Find(part);
    return o != nullptr && o->IsObject() ? NumberOr(o->Find("heldout_nrmse"), NAN) : NAN;
  };
  r.baseline_heldout_nrmse = nrmse("baseline");
  r.extended_heldout_nrmse = nrmse("extended");
  r.reference.heldout_nrmse = nrmse("reference");
  // Accepted ids in order (extended.mechanisms); each one's label ("id@joint") from the
  // prefixes of its parameters' names ("label:parameter").
  const fesim::Json* ext = d.Find("extended");
  if (ext == nullptr || !ext->IsObject() || ext->Find("mechanisms") == nullptr) return r;
  const fesim::Json* params = ext->Find("parameters");
  for (const auto& m : ext->Find("mechanisms")->Items()) {
    const std::string& id = m.AsString();
    std::string label = id;
    if (params != nullptr) {
      for (const auto& key : params->Keys()) {
        const std::string prefix = key.substr(0, key.find(':'));
        if (prefix.substr(0, prefix.find('@')) == id) {
          label = prefix;
          break;
        }
      }
    }
    r.mechanism_ids.push_back(id);
    r.mechanisms.push_back(label);
  }
  return r;
}

/// --reuse: fills the cases found in `path` (not in o.rerun) from it; returns how many, or
/// throws std::runtime_error naming the file and the data set that does not match.
std::size_t ReuseEarlierRun(const Options& o, std::vector<Case>* cases) {
  const fesim::Json all = fesim::Json::Parse(fesim::ReadFile(o.reuse), o.reuse);
  if (!all.IsArray()) throw std::runtime_error(o.reuse + ": not a diagnosis_suite --json array");
  std::map<std::uint64_t, const fesim::Json*> by_seed;
  for (const auto& j : all.Items()) {
    by_seed[static_cast<std::uint64_t>(Need(j, "seed", o.reuse).AsNumber())] = &j;
  }
  std::size_t n = 0;
  for (Case& c : *cases) {
    const auto it = by_seed.find(c.seed);
    if (it == by_seed.end() || o.rerun.count(c.seed)) continue;
    const fesim::Json& j = *it->second;
    std::vector<std::string> planted;
    for (const auto& p : Need(j, "planted", o.reuse).Items()) planted.push_back(p.AsString());
    if (Need(j, "kind", o.reuse).AsString() != c.kind || planted != c.planted) {
      const auto what = [](const std::string& kind, const std::vector<std::string>& effects) {
        std::string w = kind;
        for (const auto& e : effects) w += " " + e;
        return w;
      };
      throw std::runtime_error(o.reuse + ": data set " + std::to_string(c.seed) + " is " +
                               what(Need(j, "kind", o.reuse).AsString(), planted) + " there, " +
                               what(c.kind, c.planted) +
                               " here (--reuse needs the same suite options)");
    }
    c.reused = Need(j, "diagnosis", o.reuse);
    c.result = ReusedResult(c.reused, o.reuse);
    c.effect_ratio = NumberOr(j.Find("effect_ratio"), NAN);
    c.wall_s = NumberOr(j.Find("wall_s"), NAN);
    const fesim::Json* joint = j.Find("planted_joint");
    if (joint != nullptr) c.planted_joint = joint->AsString();
    const fesim::Json* values = j.Find("planted_values");  // absent in older outputs
    c.planted_values.clear();
    if (values != nullptr) {
      for (const fesim::Json& v : values->Items()) {
        c.planted_values.push_back({Need(v, "name", o.reuse).AsString(),
                                    Need(v, "unit", o.reuse).AsString(),
                                    Need(v, "value", o.reuse).AsNumber()});
      }
    }
    ++n;
  }
  return n;
}

/// Rates of the suite beside the targets of docs/diagnosis.md.
std::string RatesTable(const Options& o, const std::vector<Case>& cases) {
  std::map<std::string, std::pair<int, int>> by;  // key → (right, total)
  std::map<std::string, std::pair<int, int>> confident;
  std::vector<double> clean_ratio;
  for (const auto& c : cases) {
    const std::string key = c.kind == "single" ? c.planted[0] : c.kind;
    by[key].second++;
    by[key].first += Right(c) ? 1 : 0;
    confident[key].second++;
    confident[key].first +=
        (Right(c) && (c.kind != "single" || c.result.confidence >= 0.5)) ? 1 : 0;
    if (c.kind == "clean" && c.result.reference.heldout_nrmse > 0) {
      clean_ratio.push_back(c.result.baseline_heldout_nrmse / c.result.reference.heldout_nrmse);
    }
  }
  const bool foreign = o.suite == "foreign";
  std::string md =
      "| data sets | right | rate | named at confidence ≥ 0.5 | target |\n|---|---|---|---|---|\n";
  for (const auto& [key, rt] : by) {
    const std::string target = key == "clean"     ? (foreign ? "none ≥ 90 %" : "none ≥ 95 %")
                               : key == "outside" ? "never a mechanism at confidence ≥ 0.5"
                               : key == "pair"    ? "both named ≥ 80 %"
                                                  : (foreign ? "≥ 80 %" : "≥ 95 %");
    md += "| " + key + " | " + std::to_string(rt.first) + "/" + std::to_string(rt.second) + " | " +
          F("%.0f %%", 100.0 * rt.first / std::max(1, rt.second)) + " | " +
          std::to_string(confident[key].first) + "/" + std::to_string(confident[key].second) +
          " | " + target + " |\n";
  }
  if (!clean_ratio.empty()) {
    std::sort(clean_ratio.begin(), clean_ratio.end());
    int within = 0;
    for (double r : clean_ratio) within += r <= 1.5 ? 1 : 0;
    md += "\nClean data sets: calibrated model / black box held-out NRMSE " +
          F("%.2f", clean_ratio.front()) + "–" + F("%.2f", clean_ratio.back()) + " (median " +
          F("%.2f", clean_ratio[clean_ratio.size() / 2]) + "), within 1.5× on " +
          std::to_string(within) + "/" + std::to_string(clean_ratio.size()) + ".\n";
  }
  return md;
}

/// Planted (rows) × named cause (columns).
std::string ConfusionTable(const std::vector<Case>& cases) {
  std::set<std::string> causes;
  std::map<std::string, std::map<std::string, int>> m;
  for (const auto& c : cases) {
    std::string planted = Joined(c.planted);
    if (planted.empty()) planted = "clean";
    causes.insert(c.result.cause);
    m[planted][c.result.cause]++;
  }
  std::string md = "| planted \\ named |";
  for (const auto& c : causes) md += " " + c + " |";
  md += "\n|---|";
  for (std::size_t k = 0; k < causes.size(); ++k) md += "---|";
  md += "\n";
  for (const auto& [planted, row] : m) {
    md += "| " + planted + " |";
    for (const auto& c : causes) {
      const auto it = row.find(c);
      md += " " + (it == row.end() ? std::string("") : std::to_string(it->second)) + " |";
    }
    md += "\n";
  }
  return md;
}

int Usage(const char* why) {
  std::fprintf(
      stderr,
      "diagnosis_suite: %s\nusage: diagnosis_suite --suite foreign|family [--per N] "
      "[--clean N] [--outside N] [--pairs N] [--mechanisms a,b,...] [--floor R] "
      "[--seed S] [--only SEED,...] [--threads N] [--rhs simbody|chain] [--out FILE.md] "
      "[--json FILE.json] [--verbose 0|1|2] [--reuse OLD.json [--rerun SEED,...]] "
      "[--data DIR] [--diagnose 0|1] [--twin 0|1] [--protocols steps,grid,...] [--heldout N]\n",
      why);
  return 2;
}

}  // namespace

/// Reads the command line into *o; -1 to go on, else the exit code (help 0, a bad option 2).
int ParseArguments(int argc, char** argv, Options* out) {
  Options& o = *out;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (k == "--help" || k == "-h") {
      Usage("help");
      return 0;
    }
    if (i + 1 >= argc) return Usage(("option " + k + " has no value").c_str());
    const std::string v = argv[++i];
    if (k == "--suite")
      o.suite = v;
    else if (k == "--per")
      o.per = std::atoi(v.c_str());
    else if (k == "--clean")
      o.clean = std::atoi(v.c_str());
    else if (k == "--outside")
      o.outside = std::atoi(v.c_str());
    else if (k == "--pairs")
      o.pairs = std::atoi(v.c_str());
    else if (k == "--threads")
      o.threads = std::atoi(v.c_str());
    else if (k == "--verbose")
      o.verbose = std::atoi(v.c_str());
    else if (k == "--floor")
      o.floor = std::atof(v.c_str());
    else if (k == "--seed")
      o.seed = std::strtoull(v.c_str(), nullptr, 10);
    else if (k == "--mechanisms")
      o.mechanisms = Split(v);
    else if (k == "--protocols")
      o.protocols = Split(v);
    else if (k == "--heldout")
      o.heldout = std::atoi(v.c_str());
    else if (k == "--rhs" && (v == "simbody" || v == "chain"))
      o.simbody_rhs = v == "simbody";
    else if (k == "--rhs")
      return Usage(("--rhs " + v + ": allowed simbody, chain").c_str());
    else if (k == "--out")
      o.out = v;
    else if (k == "--json")
      o.json = v;
    else if (k == "--reuse")
      o.reuse = v;
    else if (k == "--data")
      o.data = v;
    else if (k == "--diagnose" && (v == "0" || v == "1"))
      o.diagnose = v == "1";
    else if (k == "--diagnose")
      return Usage(("--diagnose " + v + ": allowed 0, 1").c_str());
    else if (k == "--twin" && (v == "0" || v == "1"))
      o.twin = v == "1";
    else if (k == "--twin")
      return Usage(("--twin " + v + ": allowed 0, 1").c_str());
    else if (k == "--rerun") {
      for (const auto& s : Split(v)) o.rerun.insert(std::strtoull(s.c_str(), nullptr, 10));
    } else if (k == "--only") {
      for (const auto& s : Split(v)) o.only.insert(std::strtoull(s.c_str(), nullptr, 10));
    } else {
      return Usage(("unknown option " + k).c_str());
    }
  }
  return -1;
}

/// Checks the options' combinations; -1 when they hold, else Usage's exit code.
int CheckOptions(const Options& o) {
  if (o.suite != "foreign" && o.suite != "family") {
    return Usage("--suite must be foreign or family");
  }
  if (o.threads < 1 || o.per < 0 || o.clean < 0 || o.outside < 0 || o.pairs < 0) {
    return Usage("counts must be >= 0 and --threads >= 1");
  }
  if (!o.rerun.empty() && o.reuse.empty()) return Usage("--rerun needs --reuse");
  for (const std::string& p : o.protocols) {
    if (p != "steps" && p != "grid" && p != "multisine") {
      return Usage(("--protocols " + p + ": allowed steps, grid, multisine").c_str());
    }
  }
  if (o.heldout < 1 || (o.heldout > 1 && (o.suite != "foreign" || o.twin)) ||
      o.heldout >= static_cast<int>(o.protocols.size())) {
    return Usage(
        "--heldout must be >= 1 and below the number of --protocols; above 1 only with --suite "
        "foreign and without --twin (the twin measures the last trial alone)");
  }
  if (o.protocols.size() < 2 || (o.suite != "foreign" && o.protocols != Options().protocols)) {
    return Usage("--protocols needs --suite foreign and at least two trials (the last held out)");
  }
  if (!o.diagnose && o.data.empty()) return Usage("--diagnose 0 needs --data DIR");
  if (o.twin && (!o.reuse.empty() || !o.diagnose)) {
    return Usage("--twin 1 needs --diagnose 1 and no --reuse");
  }
  return -1;
}

/// The Markdown record of the data sets `finished` (the first of the `planned` ones, in order).
std::string SuiteMarkdown(const Options& o, const std::vector<Case>& finished, std::size_t planned,
                          std::size_t reused, double floor, double wall, const std::string& lines,
                          int argc, char** argv) {
  const std::size_t done = finished.size();
  std::string md = "# Diagnosis suite: " + o.suite + "\n\nGenerated by `build/bin/diagnosis_suite";
  for (int i = 1; i < argc; ++i) md += std::string(" ") + argv[i];
  md += "` (" + std::to_string(done) + " of " + std::to_string(planned) + " data sets";
  if (!o.reuse.empty()) {
    md += ", " + std::to_string(reused) + " of them read from " + o.reuse +
          " and the others diagnosed in this run";
  }
  md += ", " + F("%.0f", wall) + " s wall, effect floor " + F("%.2f", floor) +
        " × noise RMS).\n\n## Rates\n\n" + RatesTable(o, finished) + "\n## Planted × named\n\n" +
        ConfusionTable(finished) +
        "\n## Data sets\n\nright: single — cause = planted, at the planted joint (@) when the "
        "effect acts "
        "at one joint; clean — none; outside — no mechanism "
        "at confidence ≥ 0.5; pair — both named. NRMSE on the held-out trial: calibrated model, "
        "black box, extended model.\n\n| seed | kind | planted | effect/noise | cause | named | "
        "confidence | calibrated | black box | extended | wall s | right |\n|---|---|---|---|---|"
        "---|---|---|---|---|---|---|\n" +
        lines;
  if (o.twin) {
    md +=
        "\n## Clean twins\n\nEach data set with planted effects diagnosed again without them "
        "(--twin). Held-out trial: the effect's RMS and what the calibrated model leaves of "
        "it, and the twin's calibrated residual (its misfit and the noise), over the noise σ; "
        "the calibrated model's held-out NRMSE with the effect and of the "
        "twin.\n\n" +
        TwinTable(finished);
  }
  return md;
}

int main(int argc, char** argv) {
  Options o;
  if (const int status = ParseArguments(argc, argv, &o); status >= 0) return status;
  if (const int status = CheckOptions(o); status >= 0) return status;
  const double floor = std::isfinite(o.floor) ? o.floor : (o.suite == "foreign" ? 1.0 : 0.5);
  std::vector<Case> cases = PlanCases(o);
  std::size_t reused = 0;
  if (!o.reuse.empty()) {
    try {
      reused = ReuseEarlierRun(o, &cases);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "diagnosis_suite: %s\n", e.what());
      return 2;
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  std::string lines;
  fesim::Json all = fesim::Json::Array();
  std::size_t done = 0;
  // The results so far, rewritten after every data set (a long suite stopped early keeps them).
  const auto write = [&] {
    const std::vector<Case> finished(cases.begin(),
                                     cases.begin() + static_cast<std::ptrdiff_t>(done));
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::string md =
        SuiteMarkdown(o, finished, cases.size(), reused, floor, wall, lines, argc, argv);
    if (o.out.empty()) {
      if (done == cases.size()) std::fputs(md.c_str(), stdout);
    } else {
      fesim::WriteFileAtomic(o.out, md);
    }
    if (!o.json.empty()) fesim::WriteFileAtomic(o.json, all.Dump(1) + "\n");
  };
  for (auto& c : cases) {
    if (!c.reused.IsNull()) {
      lines += CaseLine(c) + "\n";
      all.Push(CaseJson(c));
      ++done;
      write();
      continue;
    }
    MakeData(o, floor, &c);
    if (!o.data.empty()) {
      try {
        WriteTrials(o.data, c);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "diagnosis_suite: --data %s: %s\n", o.data.c_str(), e.what());
        return 2;
      }
    }
    if (!o.diagnose) {
      std::string planted;
      for (const auto& v : c.planted_values) planted += " " + v.name + "=" + F("%.4g", v.value);
      std::fprintf(stderr, "%llu: %s/%llu (%s) effect/noise %.2f%s\n",
                   static_cast<unsigned long long>(c.seed), o.data.c_str(),
                   static_cast<unsigned long long>(c.seed), c.rig.c_str(), c.effect_ratio,
                   planted.c_str());
      continue;
    }
    c.result = DiagnoseTrials(o, c, c.trials, &c.wall_s);
    const std::string line = CaseLine(c);
    std::fprintf(stderr, "%s\n", line.c_str());
    if (o.verbose >= 2) {
      std::fprintf(stderr, "    reason: %s\n", c.result.reason.c_str());
      for (const auto& cr : c.result.candidates) {
        if (cr.applicable && cr.dof > 0) {
          std::fprintf(stderr, "    %s | %s\n", dg::CandidateLogLine(cr).c_str(),
                       cr.decision.c_str());
        }
      }
    }
    if (o.twin && !c.planted.empty()) {
      try {
        DiagnoseTwin(o, &c);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "diagnosis_suite: %s\n", e.what());
        return 2;
      }
    }
    lines += line + "\n";
    all.Push(CaseJson(c));
    ++done;
    write();
  }
  return 0;
}
