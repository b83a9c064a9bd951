#include "paper_benchmark/work.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <exception>
#include <memory>
#include <stdexcept>
#include <thread>

#include "base/parallel.h"
#include "base/result_cache.h"
#include "base/source_fingerprint.h"
#include "paper_benchmark/sections.h"
#include "sim/trial_runner.h"
#include "sim/upper_limb_model.h"

namespace fesim::paper_benchmark {
namespace {

/// The truth record reduced to what the benchmark compares against: inputs, joint angles and
/// velocities, sensor torques, and the activations a.* of the muscles that were activated (the
/// shoulder section's σ, [Spagnol 2013] §III; the full record with forces is `fesim simulate`'s).
Trial TrimTruth(const Trial& truth) {
  Trial t;
  t.metadata = truth.metadata;
  t.time = truth.time;
  for (std::size_t k = 0; k < truth.names.size(); ++k) {
    const std::string& n = truth.names[k];
    const auto& c = truth.columns[k];
    const bool active =
        n.rfind("a.", 0) == 0 && std::any_of(c.begin(), c.end(), [](double v) { return v != 0.0; });
    if (n.rfind("u.", 0) == 0 || n.rfind("q.", 0) == 0 || n.rfind("qd.", 0) == 0 ||
        n.rfind("tau.", 0) == 0 || active) {
      t.AddColumn(n, c);
    }
  }
  return t;
}

/// The record an identifier sees: the rows of the output sensor (q.* if the rig measures angles,
/// else tau.*), the channels the protocol drives (u.* not identically zero), the output columns,
/// and every other sensor column that has a value at each of those rows (e.g. qd.* at the same
/// rate). Rigs with sensors at several rates write NaN where a sensor did not sample.
Trial SensorView(const Trial& t) {
  const std::string primary = t.NamesWithPrefix("q.").empty() ? "tau." : "q.";
  const std::vector<std::string> outputs = t.NamesWithPrefix(primary);
  std::vector<std::size_t> rows;
  for (std::size_t i = 0; i < t.size(); ++i) {
    bool any = false;
    for (const auto& n : outputs) any = any || std::isfinite(t.Column(n)[i]);
    if (any) rows.push_back(i);
  }
  Trial v;
  v.metadata = t.metadata;
  for (std::size_t i : rows) v.time.push_back(t.time[i]);
  const auto pick = [&](const std::string& n) {
    const std::vector<double>& source = t.Column(n);
    std::vector<double> c;
    c.reserve(rows.size());
    for (std::size_t i : rows) c.push_back(source[i]);
    return c;
  };
  std::vector<std::string> driven;
  for (const auto& n : t.NamesWithPrefix("u.")) {
    const auto& c = t.Column(n);
    if (std::any_of(c.begin(), c.end(), [](double x) { return x != 0.0; })) driven.push_back(n);
  }
  if (driven.empty()) driven = t.NamesWithPrefix("u.");
  for (const auto& n : driven) v.AddColumn(n, pick(n));
  for (const auto& n : t.names) {
    if (n.rfind("u.", 0) == 0) continue;
    std::vector<double> c = pick(n);
    const bool is_output = n.rfind(primary, 0) == 0;
    if (is_output || std::all_of(c.begin(), c.end(), [](double x) { return std::isfinite(x); })) {
      v.AddColumn(n, std::move(c));
    }
  }
  return v;
}

/// Sets metadata `trial_hash` to the hash of the trial's CSV without it; returns the CSV with it.
std::string HashAndFormat(Trial* t) {
  t->metadata.erase("trial_hash");
  t->metadata["trial_hash"] = Fnv1a64Hex(FormatTrialCsv(*t));
  return FormatTrialCsv(*t);
}

/// Reads a cached trial back and checks it is the one written: its `trial_hash` metadata is the
/// hash of its contents without it (FormatTrialCsv of what ReadTrialCsv returns is the bytes
/// written), so a file truncated at a row boundary or edited since is caught. "" when intact,
/// else why not.
std::string ReadIntactTrial(const std::string& path, Trial* out) {
  try {
    *out = ReadTrialCsv(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  Trial t = *out;
  const auto it = t.metadata.find("trial_hash");
  if (it == t.metadata.end()) return path + ": no trial_hash";
  const std::string recorded = it->second;
  t.metadata.erase("trial_hash");
  if (Fnv1a64Hex(FormatTrialCsv(t)) != recorded) {
    return path + ": contents differ from what was written (trial_hash " + recorded + ")";
  }
  return "";
}

}  // namespace

namespace {

std::string FailureMessage(const std::vector<FailedItem>& items) {
  std::string m;
  if (items.size() > 1) m = std::to_string(items.size()) + " work items failed: ";
  for (std::size_t k = 0; k < items.size(); ++k) {
    if (k > 0) m += "; ";
    m += items[k].label + " " + std::to_string(items[k].index);
    if (items[k].rank > 0) m += " (rank " + std::to_string(items[k].rank) + ")";
    m += ": " + items[k].what;
  }
  return m;
}

// Failed items travel from rank 0 to the others as lines "index\trank\twhat" (what is one line).
std::string EncodeFailures(const std::vector<FailedItem>& items) {
  std::string s;
  for (const auto& f : items) {
    std::string what = f.what;
    std::replace(what.begin(), what.end(), '\n', ' ');
    s += std::to_string(f.index) + "\t" + std::to_string(f.rank) + "\t" + what + "\n";
  }
  return s;
}

std::vector<FailedItem> DecodeFailures(const std::string& label, const std::string& s) {
  std::vector<FailedItem> out;
  std::size_t pos = 0;
  while (pos < s.size()) {
    const std::size_t end = s.find('\n', pos);
    const std::string line = s.substr(pos, end - pos);
    pos = end == std::string::npos ? s.size() : end + 1;
    const std::size_t t1 = line.find('\t'), t2 = line.find('\t', t1 + 1);
    FailedItem f;
    f.label = label;
    f.index = std::stoul(line.substr(0, t1));
    f.rank = std::stoi(line.substr(t1 + 1, t2 - t1 - 1));
    f.what = line.substr(t2 + 1);
    out.push_back(std::move(f));
  }
  return out;
}

}  // namespace

WorkItemsFailed::WorkItemsFailed(std::vector<FailedItem> items)
    : cluster::CollectiveError(FailureMessage(items)), items_(std::move(items)) {}

WorkLoop::WorkLoop(int threads, cluster::Cluster* cluster)
    : threads_(std::max(threads, 1)), cluster_(cluster) {}

void WorkLoop::Run(const std::string& label, std::size_t n,
                   const std::function<void(std::size_t)>& fn, int threads) const {
  const auto item = [&](std::size_t i) -> std::string {
    if (!fault_.empty() && fault_ == label + " " + std::to_string(i)) {
      throw std::runtime_error("injected fault");
    }
    fn(i);
    return {};
  };
  const int local = threads > 0 ? threads : threads_;
  const auto t0 = std::chrono::steady_clock::now();
  const auto since = [](std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  };
  const auto record = [&](const std::vector<cluster::ItemOutcome>& outcomes, double replay_s) {
    if (outcomes.empty() && n > 0) return;  // not rank 0
    LoopCost c;
    c.label = label;
    c.items = n;
    for (const auto& o : outcomes) {
      c.item_s_total += o.seconds;
      c.item_s_max = std::max(c.item_s_max, o.seconds);
    }
    c.wall_s = since(t0);
    c.replay_s = replay_s;
    std::lock_guard<std::mutex> lock(costs_mutex_);
    costs_.push_back(c);
  };
  std::vector<FailedItem> failed;
  if (!distributed()) {
    const std::unique_ptr<cluster::Cluster> single = cluster::Cluster::Single();
    const auto outcomes = single->Map(n, item, local);
    for (std::size_t i = 0; i < outcomes.size(); ++i) {
      if (!outcomes[i].ok) failed.push_back({label, i, 0, outcomes[i].payload});
    }
    if (!failed.empty()) throw WorkItemsFailed(std::move(failed));
    record(outcomes, 0.0);
    return;
  }
  // MPI: the items once over the ranks (each caches its result) …
  const auto phase = [&](Phase p) {
    if (phase_hook_) phase_hook_(p);
  };
  cluster::Cluster& c = *cluster_;
  phase(Phase::kDistribute);
  std::vector<cluster::ItemOutcome> outcomes;
  try {
    outcomes = c.Map(n, item);
  } catch (...) {
    phase(Phase::kDone);
    throw;
  }
  for (std::size_t i = 0; i < outcomes.size(); ++i) {
    if (!outcomes[i].ok) failed.push_back({label, i, outcomes[i].rank, outcomes[i].payload});
  }
  failed = DecodeFailures(label, c.Broadcast(EncodeFailures(failed)));
  if (!failed.empty()) {
    phase(Phase::kDone);
    throw WorkItemsFailed(std::move(failed));
  }
  // … then every rank reads them all back, so every rank holds the same state.
  phase(Phase::kReplay);
  const auto replay_start = std::chrono::steady_clock::now();
  try {
    fesim::ParallelFor(n, threads_, fn);
  } catch (...) {
    phase(Phase::kDone);
    throw;
  }
  phase(Phase::kDone);
  record(outcomes, since(replay_start));
}

std::vector<WorkLoop::LoopCost> WorkLoop::costs() const {
  std::lock_guard<std::mutex> lock(costs_mutex_);
  return costs_;
}

void ParallelFor(std::size_t n, int threads, const std::string& label,
                 const std::function<void(std::size_t)>& fn) {
  WorkLoop(threads, nullptr).Run(label, n, fn);
}

Progress::Progress(std::function<void(double, const std::string&)> report)
    : report_(std::move(report)), start_(std::chrono::steady_clock::now()) {}

void Progress::Plan(double weight) {
  std::lock_guard<std::mutex> lock(mutex_);
  planned_ += weight;
}

void Progress::Mute(bool muted) {
  std::lock_guard<std::mutex> lock(mutex_);
  muted_ = muted;
}

void Progress::Done(double weight, const std::string& stage) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (muted_) return;
  done_ += weight;
  if (!report_) return;
  // Below 1 until the caller reports completion (the plan is an estimate).
  const double f = planned_ > 0.0 ? std::min(0.99, done_ / planned_) : 0.0;
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  std::string label = stage;
  if (f > 0.02) {
    const double left = elapsed / f * (1.0 - f);
    char buf[64];
    std::snprintf(buf, sizeof buf, ", ~%.0f s left", left);
    label += buf;
  }
  report_(f, label);
}

void Timing::Add(const std::string& what, double seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  totals_[what] += seconds;
}

std::map<std::string, double> Timing::Totals() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return totals_;
}

StudyTrials GenerateStudy(const std::string& study_path, std::uint64_t seed,
                          const std::string& cache_dir, int threads, Progress* progress,
                          Timing* timing) {
  return GenerateStudy(study_path, seed, cache_dir, WorkLoop(threads, nullptr), progress, timing);
}

StudyTrials GenerateStudy(const std::string& study_path, std::uint64_t seed,
                          const std::string& cache_dir, const WorkLoop& loop, Progress* progress,
                          Timing* timing) {
  StudyTrials out;
  out.study = LoadStudy(study_path, seed);
  const Study& st = out.study;
  // The trial-generation tolerances a scenario that states none is simulated at are part of the
  // key: a change of the defaults (sim::TaskTolerances) must not reuse trials of the old ones.
  const std::string key = Fnv1a64Hex(
      st.source_text + "\n--\n" + ReadFile(st.scenario_path) + "\n--\n" + std::to_string(seed) +
      "\n" + BuildIdentity() + "\nsensor-view-1\ntruth-activations\ndefault-tolerances " +
      std::to_string(sim::TaskTolerances::kTrialGeneration) + " " +
      std::to_string(sim::TaskTolerances::kTrialGenerationTremor) + " " +
      std::to_string(sim::TaskTolerances::kTrialGenerationFriction));
  const std::string dir = cache_dir + "/" + st.name + "_" + key;
  const std::size_t n = st.items.size();
  out.measured.resize(n);
  out.truth.resize(n);
  std::vector<double> weight(n);
  for (std::size_t i = 0; i < n; ++i) {
    weight[i] = kTrialWeightPerSecond * st.items[i].scenario.trial.duration_s;
  }
  std::mutex write_mutex;
  std::atomic<int> simulated{0};
  loop.Run(st.name + " trial", n, [&](std::size_t i) {
    const StudyItem& item = st.items[i];
    const std::string stem = dir + "/" + item.file_stem;
    bool cached = RegularFileExists(stem + ".csv") && RegularFileExists(stem + "_truth.csv");
    if (cached) {
      // A damaged file (truncated, edited) is named and its trial simulated again.
      std::string why = ReadIntactTrial(stem + ".csv", &out.measured[i]);
      if (why.empty()) why = ReadIntactTrial(stem + "_truth.csv", &out.truth[i]);
      if (!why.empty()) {
        std::fprintf(stderr, "\nfesim benchmark: %s; trial simulated again\n", why.c_str());
        cached = false;
      }
    }
    if (!cached) {
      sim::TrialRequest req = item.scenario.trial;
      req.seed = item.noise_seed;
      req.name = item.file_stem;
      const auto t0 = std::chrono::steady_clock::now();
      const sim::UpperLimbModel model(item.scenario.model);
      sim::TrialResult r = sim::RunTrial(model, req);
      if (timing) {
        timing->Add("simulation",
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      }
      Trial measured = SensorView(r.measured);
      Trial truth = TrimTruth(r.truth);
      for (Trial* t : {&measured, &truth}) {
        t->metadata["study"] = st.name;
        t->metadata["participant"] = "p" + std::to_string(item.participant + 1);
        t->metadata["protocol"] = item.protocol;
        t->metadata["repetition"] = std::to_string(item.repetition + 1);
      }
      const std::string measured_csv = HashAndFormat(&measured);
      const std::string truth_csv = HashAndFormat(&truth);
      {
        std::lock_guard<std::mutex> lock(write_mutex);
        MakeDirs(stem.substr(0, stem.find_last_of('/')));
        WriteFileAtomic(stem + "_truth.csv", truth_csv);
        WriteFileAtomic(stem + ".csv", measured_csv);
      }
      out.measured[i] = std::move(measured);
      out.truth[i] = std::move(truth);
      ++simulated;
    }
    if (progress) progress->Done(weight[i], st.name + " trials");
  });
  out.simulated = simulated;
  return out;
}

FitRunner::FitRunner(std::string cache_dir, std::vector<identification::MethodEntry> methods,
                     Timing* timing)
    // The cache layout is part of the key: a build with another layout misses instead of failing.
    : cache_(std::move(cache_dir), BuildIdentity(), "fit-cache-2"),
      methods_(std::move(methods)),
      timing_(timing) {}

bool FitRunner::Load(const std::vector<std::string>& parts, Json* out) const {
  return cache_.Load(parts, out);
}

void FitRunner::Store(const std::vector<std::string>& parts, const Json& value) {
  cache_.Store(parts, value);
}

FitOutput FitRunner::Run(const std::string& method, const std::vector<Trial>& train,
                         const std::vector<Trial>& test,
                         const std::map<std::string, std::string>& options) {
  const identification::MethodEntry* entry = nullptr;
  for (const auto& m : methods_) {
    if (m.name == method) entry = &m;
  }
  if (entry == nullptr) throw std::logic_error("benchmark: method " + method + " not registered");
  std::vector<std::string> parts = {"fit", method};
  for (const auto& [k, v] : options) parts.push_back(k + "=" + v);
  parts.emplace_back("train");
  for (const auto& t : train) parts.push_back(TrialHash(t));
  parts.emplace_back("test");
  for (const auto& t : test) parts.push_back(TrialHash(t));
  const std::string dir = cache_.Path(parts);
  FitOutput out;
  if (RegularFileExists(dir + "/metrics.json")) {
    out.metrics = Json::Parse(ReadFile(dir + "/metrics.json"), dir + "/metrics.json");
    out.model_yaml = ReadFile(dir + "/model.yaml");
    out.predictions =
        TrialsFromJson(Json::Parse(ReadFile(dir + "/predictions.json"), dir + "/predictions.json"),
                       dir + "/predictions.json");
    out.cached = true;
    std::lock_guard<std::mutex> lock(mutex_);
    if (counting_) ++fits_cached_;
    return out;
  }
  std::vector<Trial> tr = train;
  for (const auto& [k, v] : options) tr[0].metadata[k] = v;
  const auto t0 = std::chrono::steady_clock::now();
  identification::MethodResult r = entry->run(tr, test, {});
  if (timing_) {
    timing_->Add(method,
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  out.model_yaml = std::move(r.model_yaml);
  // Round-trip through the cache's text so a fresh and a cached run read the same values
  // (non-finite numbers become NaN either way).
  const std::string predictions = TrialsToJson(r.predictions).Dump(0);
  out.predictions = TrialsFromJson(Json::Parse(predictions));
  out.metrics = Json::Parse(r.metrics.Dump(0));
  std::lock_guard<std::mutex> lock(mutex_);
  MakeDirs(dir);
  WriteFileAtomic(dir + "/model.yaml", out.model_yaml);
  WriteFileAtomic(dir + "/predictions.json", predictions);
  WriteFileAtomic(dir + "/metrics.json", out.metrics.Dump(0));  // last: marks the fit complete
  if (counting_) ++fits_run_;
  return out;
}

const std::string& TrialHash(const Trial& trial) {
  const auto it = trial.metadata.find("trial_hash");
  if (it == trial.metadata.end()) throw std::logic_error("benchmark: trial without trial_hash");
  return it->second;
}

std::vector<double> Resample(const Trial& source, const std::string& column,
                             const std::vector<double>& times) {
  const std::vector<double>& t = source.time;
  const std::vector<double>& y = source.Column(column);
  std::vector<double> out(times.size(), std::nan(""));
  if (t.size() < 2) return out;
  std::size_t j = 0;
  for (std::size_t i = 0; i < times.size(); ++i) {
    const double x = times[i];
    if (x < t.front() - 1e-12 || x > t.back() + 1e-12) continue;
    while (j + 2 < t.size() && t[j + 1] < x) ++j;
    while (j > 0 && t[j] > x) --j;
    const double w = std::clamp((x - t[j]) / (t[j + 1] - t[j]), 0.0, 1.0);
    out[i] = (1.0 - w) * y[j] + w * y[j + 1];
  }
  return out;
}

}  // namespace fesim::paper_benchmark
