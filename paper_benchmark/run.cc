#include "paper_benchmark/run.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <thread>

#include "fesim/version.h"
#include "identification/fullmodel/full_model_fit.h"
#include "identification/method.h"
#include "paper_benchmark/sections.h"
#include "scenarios/study.h"

namespace fesim::paper_benchmark {

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

double ModelYamlAt(const std::string& model_yaml, const std::vector<std::string>& path) {
  try {
    YAML::Node n = YAML::Load(model_yaml);
    for (const auto& key : path) {
      const YAML::Node& parent = n;  // const: a missing key is not inserted.
      if (!parent.IsMap()) return std::nan("");
      const YAML::Node child = parent[key];
      if (!child) return std::nan("");
      n.reset(child);  // rebinds n; `n = child` would assign into the parent's node.
    }
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
  StudyTrials data = GenerateStudy(path, ctx->seed, ctx->cache_dir + "/trials", *ctx->loop,
                                   ctx->progress, ctx->timing);
  ctx->trials_simulated += data.simulated;
  return data;
}

Json CachedJson(SectionContext* ctx, const std::vector<std::string>& key,
                const std::function<Json()>& compute) {
  Json value;
  if (ctx->fits->Load(key, &value)) return value;
  value = compute();
  ctx->fits->Store(key, value);
  // Read back through the cache's text, so a fresh and a cached run see the same numbers.
  return Json::Parse(value.Dump(0));
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

/// The ranks of a job exchange results through DIR/cache: every rank must see the same directory
/// (a shared file system). Rank 0 writes a token there; the others read it back.
void CheckSharedDirectory(cluster::Cluster& job, const std::string& dir) {
  const std::string token_path = dir + "/.ranks-token";
  std::string token;
  if (job.is_root()) {
    token = Fnv1a64Hex(dir +
                       std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
    WriteFileAtomic(token_path, token);
  }
  token = job.Broadcast(token);
  bool seen = false;
  try {
    seen = ReadFile(token_path) == token;
  } catch (const std::exception&) {
    seen = false;
  }
  const std::vector<std::string> all = job.Gather(seen ? "1" : "0");
  std::string missing;
  for (std::size_t r = 0; r < all.size(); ++r) {
    if (all[r] != "1") missing += (missing.empty() ? "" : ", ") + std::to_string(r);
  }
  missing = job.Broadcast(missing);
  if (!missing.empty()) {
    throw cluster::CollectiveError(dir + ": not shared with MPI rank(s) " + missing +
                                   " (the ranks exchange results through --out DIR: put it on a "
                                   "file system every node mounts)");
  }
}

Json FindingsSummary(const Json& sections, std::string* md) {
  *md +=
      "## Findings\n\n| section | paper's finding | on the virtual cohort | margin |\n"
      "|---|---|---|---|\n";
  Json all_findings = Json::Array();
  for (std::size_t k = 0; k < sections.Keys().size(); ++k) {
    const Json* f = sections.Items()[k].Find("findings");
    if (f == nullptr) continue;
    for (const auto& item : f->Items()) {
      *md += "| " + sections.Keys()[k] + " | " + item.Find("claim")->AsString() + " | " +
             (item.Find("holds")->AsBool() ? "holds" : "does not hold") + " | " +
             item.Find("margin")->AsString() + " |\n";
      Json g = item;
      g.Set("section", sections.Keys()[k]);
      all_findings.Push(g);
    }
  }
  return all_findings;
}

Json ScalingEstimate(const std::vector<WorkLoop::LoopCost>& costs, double wall_s, std::string* md) {
  double in_loops = 0.0;
  for (const auto& c : costs) in_loops += c.wall_s;
  const double serial = std::max(0.0, wall_s - in_loops);
  Json est = Json::Array();
  *md += "Work loops: " + std::to_string(costs.size()) +
         " loops of independent items; the rest of the run (" + Fixed(serial, 1) +
         " s) is serial. Estimated wall time on R single-threaded MPI ranks from these item costs "
         "(docs/cluster.md):\n\n| ranks | at least s | at most s |\n|---|---|---|\n";
  for (const int r : {1, 2, 4, 8, 16, 64}) {
    double lo = serial, hi = serial;
    for (const auto& c : costs) {
      lo += std::max(c.item_s_max, c.item_s_total / r) + c.replay_s;
      hi += c.item_s_total / r + c.item_s_max * (1.0 - 1.0 / r) + c.replay_s;
    }
    Json e = Json::Object();
    e.Set("ranks", r).Set("at_least_s", lo).Set("at_most_s", hi);
    est.Push(e);
    *md += "| " + std::to_string(r) + " | " + Fixed(lo, 1) + " | " + Fixed(hi, 1) + " |\n";
  }
  *md += "\n";
  return est;
}

Json WorkCounters::ToJson() const {
  Json j = Json::Object();
  j.Set("trials_simulated", trials_simulated)
      .Set("fits_run", fits_run)
      .Set("fits_cached", fits_cached);
  Json kinds = Json::Object();
  for (const auto& [what, sec] : by_kind) kinds.Set(what, sec);
  j.Set("by_kind", kinds);
  return j;
}

WorkCounters SumWorkCounters(const std::vector<std::string>& per_rank) {
  WorkCounters sum;
  for (const auto& text : per_rank) {
    const Json j = Json::Parse(text, "rank counters");
    sum.trials_simulated += static_cast<int>(j.Find("trials_simulated")->AsNumber());
    sum.fits_run += static_cast<int>(j.Find("fits_run")->AsNumber());
    sum.fits_cached += static_cast<int>(j.Find("fits_cached")->AsNumber());
    const Json* k = j.Find("by_kind");
    for (std::size_t q = 0; q < k->Keys().size(); ++q) {
      sum.by_kind[k->Keys()[q]] += k->Items()[q].AsNumber();
    }
  }
  return sum;
}

namespace {

/// Worker threads per process: as asked, else one per core (one per rank on an MPI job).
int ResolveThreads(const BenchmarkOptions& options, bool distributed) {
  return options.threads > 0 ? options.threads
         : distributed       ? 1
                             : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

/// Plans the progress bar's total (studies are loaded, not simulated) so the bar and the time
/// left cover every section. Every rank reads the same files and fails alike: on a job a bad
/// study is a CollectiveError, reported once (apps/main.cc).
void PlanProgress(const BenchmarkSpec& spec, const BenchmarkOptions& options, bool distributed,
                  Progress* progress) {
  const auto study_weight = [&](const std::optional<BenchmarkSection>& s, int* participants,
                                int* items) {
    Study st;
    try {
      st = LoadStudy(options.quick ? s->quick_study_path : s->study_path, options.seed);
    } catch (const std::runtime_error& e) {
      if (distributed) throw cluster::CollectiveError(e.what());
      throw;
    }
    double w = 0.0;
    for (const auto& item : st.items) w += kTrialWeightPerSecond * item.scenario.trial.duration_s;
    *participants = static_cast<int>(st.participants.size());
    *items = static_cast<int>(st.items.size());
    return w;
  };
  int np = 0, ni = 0;
  if (spec.hand_array) {
    progress->Plan(study_weight(spec.hand_array, &np, &ni));
    const auto& m = spec.hand_array->methods;
    const double per_fold =
        (std::count(m.begin(), m.end(), "hammerstein-mimo") ? kHammersteinFitWeight : 0.0) +
        (std::count(m.begin(), m.end(), "full-model")
             ? FullModelFitWeight(options.quick ? spec.quick_full_model : spec.full_model)
             : 0.0);
    progress->Plan(per_fold * ni / 2);  // one fold per step-grid repetition (half the items)
    // The independent cohort: the same folds for its persons (its trials cost little).
    const int ip = (options.quick ? spec.quick_independent : spec.independent).participants;
    if (np > 0) progress->Plan(per_fold * ni / 2 * ip / np);
  }
  if (spec.elbow_tests) {
    progress->Plan(study_weight(spec.elbow_tests, &np, &ni));
    // One fit per trial and one per test type and participant, per method.
    progress->Plan(kSplineFitWeight * spec.elbow_tests->methods.size() * (ni + ni / 2.0));
  }
  if (spec.tremor_wrist) {
    progress->Plan(study_weight(spec.tremor_wrist, &np, &ni));
    progress->Plan(kTremorParticipantWeight * np);
  }
  if (spec.shoulder) {
    progress->Plan(study_weight(spec.shoulder, &np, &ni));
    progress->Plan(kShoulderFitWeight * np * spec.shoulder->methods.size());
  }
  if (spec.reaching) progress->Plan(kReachingWeight);
}

/// results.json's header fields.
Json ResultsHeader(const BenchmarkSpec& spec, const BenchmarkOptions& options, int threads,
                   int ranks) {
  Json results = Json::Object();
  results.Set("benchmark", spec.name);
  results.Set("benchmark_file", spec.path);
  results.Set("benchmark_hash_fnv1a64", Fnv1a64Hex(spec.source_text));
  results.Set("fesim_version", FESIM_VERSION);
  results.Set("mode", options.quick ? "quick" : "default");
  results.Set("seed", static_cast<double>(options.seed));
  results.Set("threads", threads);
  results.Set("ranks", ranks);
  return results;
}

/// A section's wall time.
struct SectionTime {
  std::string key;
  double wall_s;
};

/// The sections in the spec's order: results.json "sections", the Markdown body and the times.
struct SectionsRun {
  Json sections = Json::Object();
  std::string body;
  std::vector<SectionTime> timing;
};

SectionsRun RunSections(const BenchmarkSpec& spec, SectionContext* ctx) {
  SectionsRun out;
  const auto run = [&](const std::string& key, const std::optional<BenchmarkSection>& s,
                       SectionResult (*fn)(const BenchmarkSection&, SectionContext*)) {
    if (!s) return;
    const auto ts = std::chrono::steady_clock::now();
    SectionResult r = fn(*s, ctx);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - ts).count();
    r.json.Set("wall_s", wall);
    out.timing.push_back({key, wall});
    out.sections.Set(key, r.json);
    out.body += r.markdown + "\n";
  };
  run("hand_array", spec.hand_array, RunHandArray);
  run("elbow_tests", spec.elbow_tests, RunElbowTests);
  run("tremor_wrist", spec.tremor_wrist, RunTremorWrist);
  run("shoulder", spec.shoulder, RunShoulder);
  run("reaching", spec.reaching, RunReaching);
  return out;
}

/// "Where the time went": per section, by kind of work, and the work counters; returns
/// results.json "wall_s" without its "total" and sets "thread_seconds_by_kind".
Json TimeTables(const std::vector<SectionTime>& timing, double wall, const WorkCounters& counters,
                int ranks, int threads, Json* results, std::string* md) {
  *md += "## Where the time went\n\n| section | wall s |\n|---|---|\n";
  Json jt = Json::Object();
  for (const auto& t : timing) {
    *md += "| " + t.key + " | " + Fixed(t.wall_s, 1) + " |\n";
    jt.Set(t.key, t.wall_s);
  }
  *md += "| **total** | **" + Fixed(wall, 1) + "** |\n\n";
  *md +=
      "By kind of work in this run (thread-seconds summed over the worker threads and ranks; "
      "cached work costs nothing):\n\n| work | s |\n|---|---|\n";
  Json jk = Json::Object();
  for (const auto& [what, s] : counters.by_kind) {
    *md += "| " + what + " | " + Fixed(s, 1) + " |\n";
    jk.Set(what, s);
  }
  *md += "\n";
  results->Set("thread_seconds_by_kind", jk);
  *md +=
      std::to_string(counters.trials_simulated) + " trials simulated, " +
      std::to_string(counters.fits_run) + " fits run, " + std::to_string(counters.fits_cached) +
      " fits reused from `cache/` (cached fits keep the wall times of the run that made them); " +
      (ranks > 1 ? std::to_string(ranks) + " MPI ranks × " : std::string()) +
      std::to_string(threads) + " threads; fesim " + FESIM_VERSION + ".\n";
  return jt;
}

/// The loops of independent items: what they cost item by item (the data behind the scaling
/// estimate, docs/cluster.md); the rest of the wall time is serial.
Json WorkLoopsJson(const std::vector<WorkLoop::LoopCost>& costs) {
  Json loops = Json::Array();
  for (const auto& c : costs) {
    Json j = Json::Object();
    j.Set("label", c.label)
        .Set("items", static_cast<double>(c.items))
        .Set("item_s_total", c.item_s_total)
        .Set("item_s_max", c.item_s_max)
        .Set("loop_wall_s", c.wall_s)
        .Set("replay_wall_s", c.replay_s);
    loops.Push(j);
  }
  return loops;
}

}  // namespace

BenchmarkOutcome RunBenchmark(const BenchmarkSpec& spec, const BenchmarkOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  cluster::Cluster* job = options.cluster;
  const bool distributed = job != nullptr && job->size() > 1;
  const bool root = job == nullptr || job->is_root();
  const int threads = ResolveThreads(options, distributed);
  std::vector<identification::MethodEntry> methods = identification::BuiltinMethods();
  Timing timing_by_kind;
  FitRunner fits(options.out_dir + "/cache/fits", methods, &timing_by_kind);
  Progress progress(root ? options.progress : nullptr);
  WorkLoop loop(threads, job);
  loop.InjectFault(options.fail_item);
  // On a job, each item is counted where it ran (progress: on rank 0 when the replay reads it).
  loop.OnPhase([&](WorkLoop::Phase phase) {
    progress.Mute(phase == WorkLoop::Phase::kDistribute);
    fits.SetCounting(phase != WorkLoop::Phase::kReplay);
  });
  SectionContext ctx;
  ctx.loop = &loop;
  ctx.write_outputs = root;
  ctx.spec = &spec;
  ctx.quick = options.quick;
  ctx.threads = threads;
  ctx.seed = options.seed;
  ctx.cache_dir = options.out_dir + "/cache";
  ctx.plots_dir = options.out_dir + "/plots";
  ctx.fits = &fits;
  ctx.progress = &progress;
  ctx.timing = &timing_by_kind;

  PlanProgress(spec, options, distributed, &progress);
  // Only now, with every study file read and checked: a bad or unreadable study leaves no
  // output directory behind (BenchmarkCli.BadInputIsOneLineAndNonZero).
  MakeDirs(options.out_dir + "/plots");
  MakeDirs(options.out_dir + "/cache");
  if (distributed) CheckSharedDirectory(*job, options.out_dir + "/cache");

  const int ranks = job == nullptr ? 1 : job->size();
  Json results = ResultsHeader(spec, options, threads, ranks);
  std::string md = "# fesim benchmark: " + spec.name + (options.quick ? " (quick)" : "") + "\n\n";
  md +=
      "Every identifier of papers 000–004 fitted to virtual trials of a cohort whose ground "
      "truth is known, with the papers' validation schemes and table layouts (paper values "
      "alongside, measured on real participants), then checked against the truth. Every "
      "figure below is in `results.json`.\n\n";
  const SectionsRun sections = RunSections(spec, &ctx);
  results.Set("sections", sections.sections);

  // Work counters of every rank, summed on rank 0.
  WorkCounters counters;
  counters.trials_simulated = ctx.trials_simulated;
  counters.fits_run = fits.fits_run();
  counters.fits_cached = fits.fits_cached();
  counters.by_kind = timing_by_kind.Totals();
  if (distributed) {
    const std::vector<std::string> all = job->Gather(counters.ToJson().Dump(0));
    if (root) counters = SumWorkCounters(all);
  }

  // Summary of the findings first, then the sections.
  results.Set("findings", FindingsSummary(sections.sections, &md));
  md += "\n" + sections.body;
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  Json jt =
      TimeTables(sections.timing, wall, counters, distributed ? ranks : 1, threads, &results, &md);
  jt.Set("total", wall);
  results.Set("wall_s", jt);
  const std::vector<WorkLoop::LoopCost> costs = loop.costs();
  results.Set("work_loops", WorkLoopsJson(costs));
  results.Set("scaling_estimate", ScalingEstimate(costs, wall, &md));
  results.Set("trials_simulated", counters.trials_simulated);
  results.Set("fits_run", counters.fits_run);
  results.Set("fits_cached", counters.fits_cached);
  if (root) {
    WriteFileAtomic(options.out_dir + "/results.json", results.Dump());
    WriteFileAtomic(options.out_dir + "/report.md", md);
  }
  BenchmarkOutcome out;
  out.results = std::move(results);
  out.report = std::move(md);
  out.wall_s = wall;
  return out;
}

}  // namespace fesim::paper_benchmark
