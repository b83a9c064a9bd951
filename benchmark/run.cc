#include "benchmark/run.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <thread>

#include "benchmark/sections.h"
#include "fesim/version.h"
#include "identification/fullmodel/full_model_fit.h"
#include "identification/method.h"
#include "scenarios/study.h"

namespace fesim::benchmark {

double MeanFinite(const std::vector<double>& v) {
  double s = 0.0;
  int n = 0;
  for (double x : v) {
    if (std::isfinite(x)) {
      s += x;
      ++n;
    }
  }
  return n > 0 ? s / n : std::nan("");
}

double StdFinite(const std::vector<double>& v) {
  const double m = MeanFinite(v);
  double s = 0.0;
  int n = 0;
  for (double x : v) {
    if (std::isfinite(x)) {
      s += (x - m) * (x - m);
      ++n;
    }
  }
  return n > 1 ? std::sqrt(s / (n - 1)) : 0.0;
}

std::string Fixed(double v, int digits) {
  if (!std::isfinite(v)) return "–";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

double ModelYamlValue(const std::string& model_yaml, const std::string& key) {
  try {
    const YAML::Node root = YAML::Load(model_yaml);
    const YAML::Node n = root[key];
    if (!n) return std::nan("");
    return n.IsMap() ? n["value"].as<double>() : n.as<double>();
  } catch (const YAML::Exception&) {
    return std::nan("");
  }
}

std::vector<double> ModelYamlList(const std::string& model_yaml, const std::string& key) {
  std::vector<double> out;
  try {
    const YAML::Node n = YAML::Load(model_yaml)[key];
    if (!n || !n.IsMap()) return out;
    for (const auto& kv : n) {
      out.push_back(kv.second.IsMap() ? kv.second["value"].as<double>() : kv.second.as<double>());
    }
  } catch (const YAML::Exception&) {
    out.clear();
  }
  return out;
}

StudyTrials SectionStudy(const BenchmarkSection& section, SectionContext* ctx) {
  const std::string& path = ctx->quick ? section.quick_study_path : section.study_path;
  StudyTrials data = GenerateStudy(path, ctx->seed, ctx->cache_dir + "/trials", ctx->threads,
                                   ctx->progress, ctx->timing);
  ctx->trials_simulated += data.simulated;
  return data;
}

StudyLayout LayoutOf(const Study& study) {
  StudyLayout l;
  for (const auto& item : study.items) {
    if (std::find(l.protocols.begin(), l.protocols.end(), item.protocol) == l.protocols.end()) {
      l.protocols.push_back(item.protocol);
    }
    l.reps = std::max(l.reps, item.repetition + 1);
  }
  l.participants = static_cast<int>(study.participants.size());
  return l;
}

Json Finding(const std::string& claim, bool holds, const std::string& margin) {
  Json j = Json::Object();
  j.Set("claim", claim).Set("holds", holds).Set("margin", margin);
  return j;
}

std::string FindingLine(const Json& f) {
  return "- " + f.Find("claim")->AsString() + ": **" +
         (f.Find("holds")->AsBool() ? std::string("holds") : std::string("does not hold")) +
         "** (" + f.Find("margin")->AsString() + ").\n";
}

BenchmarkOutcome RunBenchmark(const BenchmarkSpec& spec, const BenchmarkOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const int threads = options.threads > 0
                          ? options.threads
                          : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<identification::MethodEntry> methods = identification::BuiltinMethods();
  Timing timing_by_kind;
  FitRunner fits(options.out_dir + "/cache/fits", methods, &timing_by_kind);
  Progress progress(options.progress);
  SectionContext ctx;
  ctx.spec = &spec;
  ctx.quick = options.quick;
  ctx.threads = threads;
  ctx.seed = options.seed;
  ctx.cache_dir = options.out_dir + "/cache";
  ctx.plots_dir = options.out_dir + "/plots";
  ctx.fits = &fits;
  ctx.progress = &progress;
  ctx.timing = &timing_by_kind;

  // Plan the work (studies are loaded, not simulated) so the bar and the time left cover it all.
  const auto study_weight = [&](const std::optional<BenchmarkSection>& s, int* participants,
                                int* items) {
    const Study st = LoadStudy(options.quick ? s->quick_study_path : s->study_path, options.seed);
    double w = 0.0;
    for (const auto& item : st.items) w += kTrialWeightPerSecond * item.scenario.trial.duration_s;
    *participants = static_cast<int>(st.participants.size());
    *items = static_cast<int>(st.items.size());
    return w;
  };
  int np = 0, ni = 0;
  if (spec.hand_array) {
    progress.Plan(study_weight(spec.hand_array, &np, &ni));
    const auto& m = spec.hand_array->methods;
    const double per_fold =
        (std::count(m.begin(), m.end(), "hammerstein-mimo") ? kHammersteinFitWeight : 0.0) +
        (std::count(m.begin(), m.end(), "full-model")
             ? FullModelFitWeight(options.quick ? spec.quick_full_model : spec.full_model)
             : 0.0);
    progress.Plan(per_fold * ni / 2);  // one fold per step-grid repetition (half the items)
  }
  if (spec.elbow_tests) {
    progress.Plan(study_weight(spec.elbow_tests, &np, &ni));
    // One fit per trial and one per test type and participant, per method.
    progress.Plan(kSplineFitWeight * spec.elbow_tests->methods.size() * (ni + ni / 2.0));
  }
  if (spec.tremor_wrist) {
    progress.Plan(study_weight(spec.tremor_wrist, &np, &ni));
    progress.Plan(kTremorParticipantWeight * np);
  }
  if (spec.shoulder) {
    progress.Plan(study_weight(spec.shoulder, &np, &ni));
    progress.Plan(kShoulderFitWeight * np * spec.shoulder->methods.size());
  }
  if (spec.reaching) progress.Plan(kReachingWeight);
  // Only now, with every study file read and checked: a bad or unreadable study leaves no
  // output directory behind (issue 10).
  MakeDirs(options.out_dir + "/plots");
  MakeDirs(options.out_dir + "/cache");

  Json results = Json::Object();
  results.Set("benchmark", spec.name);
  results.Set("benchmark_file", spec.path);
  results.Set("benchmark_hash_fnv1a64", Fnv1a64Hex(spec.source_text));
  results.Set("fesim_version", FESIM_VERSION);
  results.Set("mode", options.quick ? "quick" : "default");
  results.Set("seed", static_cast<double>(options.seed));
  results.Set("threads", threads);
  std::string md = "# fesim benchmark: " + spec.name + (options.quick ? " (quick)" : "") + "\n\n";
  md +=
      "Every identifier of papers 000–004 fitted to virtual trials of a cohort whose ground "
      "truth is known, with the papers' validation schemes and table layouts (paper values "
      "alongside, measured on real participants), then checked against the truth. Every "
      "figure below is in `results.json`.\n\n";

  struct Timed {
    std::string key;
    double wall_s;
  };
  std::vector<Timed> timing;
  Json sections = Json::Object();
  std::string body;
  const auto run = [&](const std::string& key, const std::optional<BenchmarkSection>& s,
                       SectionResult (*fn)(const BenchmarkSection&, SectionContext*)) {
    if (!s) return;
    const auto ts = std::chrono::steady_clock::now();
    SectionResult r = fn(*s, &ctx);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - ts).count();
    r.json.Set("wall_s", wall);
    timing.push_back({key, wall});
    sections.Set(key, r.json);
    body += r.markdown + "\n";
  };
  run("hand_array", spec.hand_array, RunHandArray);
  run("elbow_tests", spec.elbow_tests, RunElbowTests);
  run("tremor_wrist", spec.tremor_wrist, RunTremorWrist);
  run("shoulder", spec.shoulder, RunShoulder);
  run("reaching", spec.reaching, RunReaching);
  results.Set("sections", sections);

  // Summary of the findings first, then the sections.
  md +=
      "## Findings\n\n| section | paper's finding | on the virtual cohort | margin |\n"
      "|---|---|---|---|\n";
  Json all_findings = Json::Array();
  for (std::size_t k = 0; k < sections.Keys().size(); ++k) {
    const Json* f = sections.Items()[k].Find("findings");
    if (f == nullptr) continue;
    for (const auto& item : f->Items()) {
      md += "| " + sections.Keys()[k] + " | " + item.Find("claim")->AsString() + " | " +
            (item.Find("holds")->AsBool() ? "holds" : "does not hold") + " | " +
            item.Find("margin")->AsString() + " |\n";
      Json g = item;
      g.Set("section", sections.Keys()[k]);
      all_findings.Push(g);
    }
  }
  results.Set("findings", all_findings);
  md += "\n" + body;
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  md += "## Where the time went\n\n| section | wall s |\n|---|---|\n";
  Json jt = Json::Object();
  for (const auto& t : timing) {
    md += "| " + t.key + " | " + Fixed(t.wall_s, 1) + " |\n";
    jt.Set(t.key, t.wall_s);
  }
  md += "| **total** | **" + Fixed(wall, 1) + "** |\n\n";
  md +=
      "By kind of work in this run (thread-seconds summed over the worker threads; cached work "
      "costs nothing):\n\n| work | s |\n|---|---|\n";
  Json jk = Json::Object();
  for (const auto& [what, s] : timing_by_kind.Totals()) {
    md += "| " + what + " | " + Fixed(s, 1) + " |\n";
    jk.Set(what, s);
  }
  md += "\n";
  results.Set("thread_seconds_by_kind", jk);
  md += std::to_string(ctx.trials_simulated) + " trials simulated, " +
        std::to_string(fits.fits_run()) + " fits run, " + std::to_string(fits.fits_cached()) +
        " fits reused from `cache/` (cached fits keep the wall times of the run that made them); " +
        std::to_string(threads) + " threads; fesim " + FESIM_VERSION + ".\n";
  jt.Set("total", wall);
  results.Set("wall_s", jt);
  results.Set("trials_simulated", ctx.trials_simulated);
  results.Set("fits_run", fits.fits_run());
  results.Set("fits_cached", fits.fits_cached());
  WriteFileAtomic(options.out_dir + "/results.json", results.Dump());
  WriteFileAtomic(options.out_dir + "/report.md", md);
  BenchmarkOutcome out;
  out.results = std::move(results);
  out.report = std::move(md);
  out.wall_s = wall;
  return out;
}

}  // namespace fesim::benchmark
