// `fesim simulate SCENARIO.yaml [--out DIR] [--seed N]`
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "apps/api.h"
#include "apps/cli.h"
#include "apps/commands.h"
#include "base/json.h"
#include "base/result_cache.h"
#include "base/source_fingerprint.h"
#include "base/trial.h"
#include "fesim/version.h"
#include "scenarios/scenario.h"
#include "scenarios/study.h"
#include "sim/opensim.h"
#include "sim/reaching.h"
#include "sim/trial_runner.h"
#include "sim/upper_limb_model.h"

namespace fesim {
namespace {

void PrintHelp() {
  std::printf(
      "usage: fesim simulate SCENARIO.yaml|STUDY.yaml [--out DIR] [--seed N] [--threads N]\n"
      "                      [--quiet]\n\n"
      "Simulates the scenario's trial on its virtual participant and writes, atomically:\n"
      "  DIR/<name>.csv        measured trial (sensors with noise; NaN where a sensor did not "
      "sample)\n"
      "  DIR/<name>.sto        the same as an OpenSim storage file\n"
      "  DIR/<name>_truth.csv  noiseless ground truth (all coordinates, activations, forces)\n"
      "  DIR/<name>.osim       the participant as an OpenSim 4 model (fesim export --help)\n"
      "  DIR/<name>.mot        the truth's angles in degrees, to play the .osim in OpenSim\n"
      "  DIR/manifest.json     scenario hash, seed, version, files, integrator statistics\n"
      "Same scenario and seed give the same bytes. Default DIR: out/<name>, seed 1.\n\n"
      "A study file (top-level key `study:`, see scenarios/study.h) runs every participant x\n"
      "protocol x repetition of its virtual cohort on --threads threads (default: all cores)\n"
      "and writes DIR/p<k>/<protocol>_r<r>.csv and _truth.csv plus DIR/manifest.json with\n"
      "every participant's drawn parameters. Results do not depend on the thread count.\n"
      "DIR/cache records the size and hash of each file written: a rerun into DIR simulates\n"
      "only the trials that are missing or whose files no longer match (named on stderr).\n"
      "Under mpirun (mpirun -np N fesim simulate STUDY.yaml) the trials are spread over the\n"
      "ranks and rank 0 writes the same files; the bytes do not depend on N either.\n");
}

/// FNV-1a, 64 bit: a stable content hash for the manifest.
/// `fesim simulate STUDY.yaml`: every participant × protocol × repetition, in parallel.
/// Whether study item `stem` finished in an earlier run: its record in `records` (key `key`)
/// exists and every file it lists under `out` still has the size and hash written
/// (CheckWrittenFile); then `integration` is its stored integration statistics. A damaged file
/// or record is named on stderr and the item counts as not finished (simulated again).
bool FinishedStudyItem(ResultCache& records, const std::vector<std::string>& key,
                       const std::string& out, const std::string& stem, std::string* integration) {
  try {
    Json record;
    if (!records.Load(key, &record)) return false;
    const Json* files = record.Find("files");
    const Json* stats = record.Find("integration");
    if (files == nullptr || !files->IsArray() || stats == nullptr || !stats->IsString()) {
      throw std::runtime_error(records.Path(key) + ".json: expected {files, integration}");
    }
    std::string damage;
    for (const Json& f : files->Items()) {
      const std::string why = CheckWrittenFile(out, f);
      if (!why.empty() && damage.empty()) damage = why;
    }
    if (damage.empty()) {
      *integration = stats->AsString();
      return true;
    }
    std::fprintf(stderr, "fesim simulate: %s; study item %s is simulated again\n", damage.c_str(),
                 stem.c_str());
  } catch (const std::exception& e) {
    // A damaged record (e.g. a file system that lost its end): the item is simulated again.
    std::fprintf(stderr, "fesim simulate: %s; study item %s is simulated again\n", e.what(),
                 stem.c_str());
  }
  return false;
}

/// manifest.json of a study run: version, study and its hash, seed, the participants and every
/// trial with its files and integration statistics (`stats`, one JSON line per item).
Json StudyManifest(const Study& st, const std::string& hash, long seed,
                   const std::vector<std::string>& stats) {
  Json manifest = Json::Object();
  manifest.Set("fesim_version", FESIM_VERSION)
      .Set("study", st.name)
      .Set("study_file", st.path)
      .Set("study_hash_fnv1a64", hash)
      .Set("seed", static_cast<double>(seed));
  Json people = Json::Array();
  for (const Participant& p : st.participants) {
    Json j = Json::Object();
    j.Set("id", "p" + std::to_string(p.index + 1))
        .Set("height_m", p.height_m)
        .Set("mass_kg", p.mass_kg)
        .Set("strength_scale", p.strength_scale)
        .Set("recruitment_threshold_scale", p.recruitment_threshold_scale)
        .Set("omega_scale", p.omega_scale)
        .Set("stiffness_scale", p.stiffness_scale)
        .Set("electrode_offset_along_m", p.electrode_offset_along_m)
        .Set("electrode_offset_around_m", p.electrode_offset_around_m);
    people.Push(j);
  }
  manifest.Set("participants", people);
  Json items = Json::Array();
  for (std::size_t i = 0; i < st.items.size(); ++i) {
    const StudyItem& item = st.items[i];
    Json j = Json::Object();
    j.Set("participant", "p" + std::to_string(item.participant + 1))
        .Set("protocol", item.protocol)
        .Set("repetition", item.repetition + 1)
        .Set("noise_seed", std::to_string(item.noise_seed))
        .Set("measured", item.file_stem + ".csv")
        .Set("truth", item.file_stem + "_truth.csv")
        .Set("duration_s", item.scenario.trial.duration_s)
        .Set("integration", Json::Parse(stats[i], item.file_stem + "_truth.csv: integration"));
    items.Push(j);
  }
  manifest.Set("trials", items);
  return manifest;
}

int RunStudy(const std::string& path, long seed, const cli::Args& args, cluster::Cluster& job) {
  const Study st = LoadStudy(path, static_cast<std::uint64_t>(seed));
  const std::string out = cli::OutPath(args, "out", "out/" + st.name);
  const std::string hash = Fnv1a64Hex(st.source_text);
  const int threads =
      cli::Threads(args, static_cast<int>(std::min<unsigned>(
                             std::max(1u, std::thread::hardware_concurrency()), cli::kMaxThreads)));
  const auto t0 = std::chrono::steady_clock::now();

  // Each item's files as bytes (measured CSV, truth CSV, integration statistics), made on
  // whichever rank (or thread) ran it and written by rank 0 as soon as it arrives, so that an
  // interrupted or partly failed run keeps the finished trials and a rerun does the others.
  // The truth file's metadata carries what a rerun needs to recognise a finished item (study
  // hash, seed, version) and the integration statistics for the manifest.
  const std::string seed_text = std::to_string(seed);
  const auto item_files = [&](std::size_t i) {
    const StudyItem& item = st.items[i];
    sim::TrialRequest req = item.scenario.trial;
    req.seed = item.noise_seed;
    req.name = item.file_stem;
    const sim::UpperLimbModel model(item.scenario.model);
    const sim::TrialResult r = sim::RunTrial(model, req);
    Trial measured = r.measured, truth = r.truth;
    for (Trial* t : {&measured, &truth}) {
      t->metadata["study"] = st.name;
      t->metadata["study_hash"] = hash;
      t->metadata["study_seed"] = seed_text;
      t->metadata["participant"] = "p" + std::to_string(item.participant + 1);
      t->metadata["protocol"] = item.protocol;
      t->metadata["repetition"] = std::to_string(item.repetition + 1);
      t->metadata["fesim_version"] = FESIM_VERSION;
    }
    std::string stats_line = IntegrationStatsJson(r).Dump(0);
    while (!stats_line.empty() && stats_line.back() == '\n') stats_line.pop_back();
    truth.metadata["integration"] = stats_line;  // one metadata line
    Json packed = Json::Object();
    packed.Set("measured", FormatTrialCsv(measured))
        .Set("truth", FormatTrialCsv(truth))
        .Set("integration", truth.metadata["integration"]);
    return packed.Dump(0);
  };
  const auto measured_path = [&](std::size_t i) {
    return out + "/" + st.items[i].file_stem + ".csv";
  };
  const auto truth_path = [&](std::size_t i) {
    return out + "/" + st.items[i].file_stem + "_truth.csv";
  };
  // A finished item has a record in DIR/cache (keyed by the build's identity, study text, seed and
  // item) of the size and hash of each file as written, stored after both files. Rank 0 counts an
  // item as finished only when every file still matches its record; a damaged file (truncated,
  // edited) is named and its item simulated again. The integration statistics of every item end
  // up in `stats` on rank 0.
  ResultCache records(out + "/cache", BuildIdentity(), "study-files-1");
  const auto record_key = [&](std::size_t i) {
    return std::vector<std::string>{"study " + hash, "seed " + seed_text, st.items[i].file_stem};
  };
  std::vector<std::string> stats(st.items.size());
  std::string pending_text;
  if (job.is_root()) {
    for (std::size_t i = 0; i < st.items.size(); ++i) {
      const bool finished =
          FinishedStudyItem(records, record_key(i), out, st.items[i].file_stem, &stats[i]);
      if (!finished) pending_text += std::to_string(i) + " ";
    }
  }
  pending_text = job.Broadcast(pending_text);
  std::vector<std::size_t> pending;
  {
    std::istringstream in(pending_text);
    for (std::size_t i; in >> i;) pending.push_back(i);
  }
  const std::size_t resumed = st.items.size() - pending.size();
  const cli::Progress progress(cli::ProgressFor(args));
  const auto outcomes = job.Map(
      pending.size(), [&](std::size_t k) { return item_files(pending[k]); }, threads,
      [&](std::size_t n, std::size_t k, const cluster::ItemOutcome& o) {
        // Rank 0, one item at a time: its files, then the progress line.
        const std::size_t i = pending[k];
        if (o.ok) {
          const Json j = Json::Parse(o.payload, "study item " + st.items[i].file_stem);
          MakeDirs(out + "/p" + std::to_string(st.items[i].participant + 1));
          const std::string& truth = j.Find("truth")->AsString();
          const std::string& measured = j.Find("measured")->AsString();
          WriteFileAtomic(truth_path(i), truth);
          WriteFileAtomic(measured_path(i), measured);
          stats[i] = j.Find("integration")->AsString();
          // Last: the item counts as finished once both files are in place.
          Json files = Json::Array();
          files.Push(WrittenFileRecord(st.items[i].file_stem + "_truth.csv", truth));
          files.Push(WrittenFileRecord(st.items[i].file_stem + ".csv", measured));
          Json record = Json::Object();
          record.Set("files", files).Set("integration", stats[i]);
          records.Store(record_key(i), record);
        }
        progress(static_cast<double>(n) / static_cast<double>(pending.size()),
                 st.name + " " + std::to_string(n) + "/" + std::to_string(pending.size()));
      });
  // Failed items, as rank 0 saw them, on every rank: one message; the finished ones are written.
  std::string failed;
  for (std::size_t k = 0; k < outcomes.size(); ++k) {
    if (!outcomes[k].ok) {
      failed += (failed.empty() ? "" : "; ") + std::string("study item ") +
                st.items[pending[k]].file_stem +
                (job.size() > 1 ? " (rank " + std::to_string(outcomes[k].rank) + ")" : "") + ": " +
                outcomes[k].payload;
    }
  }
  failed = job.Broadcast(failed);
  if (!failed.empty()) {
    throw cluster::CollectiveError(failed +
                                   " (the other trials are written; a rerun simulates "
                                   "only the missing ones)");
  }
  if (!job.is_root()) return 0;

  WriteFileAtomic(out + "/manifest.json", StudyManifest(st, hash, seed, stats).Dump());
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::string where = job.size() > 1 ? std::to_string(job.size()) + " MPI ranks"
                                           : std::to_string(threads) + " threads";
  std::fprintf(stderr,
               "fesim simulate: study %s, %zu trials (%zu simulated, %zu from an earlier run) on "
               "%s in %.1f s -> %s\n",
               st.name.c_str(), st.items.size(), pending.size(), resumed, where.c_str(), wall,
               out.c_str());
  return 0;
}

/// Robot-driven reaching ([Schearer 2014]): one trial per reach, written as <name>_<k>.csv.
int RunReaching(const Scenario& sc, const std::string& out, long seed) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<Trial> trials = sim::SimulateReaching(sc.model, *sc.reaching, {}, sc.trial.sensors,
                                                    static_cast<std::uint64_t>(seed));
  const std::string hash = Fnv1a64Hex(sc.source_text);
  MakeDirs(out);
  Json files = Json::Array();
  for (std::size_t k = 0; k < trials.size(); ++k) {
    trials[k].metadata["scenario"] = sc.name;
    trials[k].metadata["scenario_hash"] = hash;
    trials[k].metadata["fesim_version"] = FESIM_VERSION;
    char stem[64];
    std::snprintf(stem, sizeof stem, "%s_%03zu", sc.name.c_str(), k + 1);
    WriteFileAtomic(out + "/" + stem + ".csv", FormatTrialCsv(trials[k]));
    files.Push(std::string(stem) + ".csv");
  }
  Json manifest = Json::Object();
  manifest.Set("fesim_version", FESIM_VERSION)
      .Set("scenario", sc.name)
      .Set("scenario_file", sc.path)
      .Set("scenario_hash_fnv1a64", hash)
      .Set("seed", static_cast<double>(seed))
      .Set("protocol", "reaching")
      .Set("files", files);
  WriteFileAtomic(out + "/manifest.json", manifest.Dump());
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::fprintf(stderr, "fesim simulate: %s, %zu reaching trials in %.1f s -> %s\n", sc.name.c_str(),
               trials.size(), wall, out.c_str());
  return 0;
}

}  // namespace

int RunSimulate(int argc, char** argv, cluster::Cluster& job) {
  const auto args = cli::Parse(argc, argv, 2, {"help", "quiet"}, {"out", "seed", "threads"});
  if (args.Has("help")) {
    PrintHelp();
    return 0;
  }
  if (args.positional.size() != 1) {
    throw std::runtime_error("expected one SCENARIO.yaml argument (see --help)");
  }
  cli::Threads(args, 1);  // checked before any work, also for a single scenario (one thread)
  const long seed = args.GetInt("seed", 1);
  if (seed < 0)
    throw std::runtime_error("option --seed: " + std::to_string(seed) + " is outside [0, 2^63)");
  if (IsStudy(ReadFile(args.positional[0]))) return RunStudy(args.positional[0], seed, args, job);
  if (job.size() > 1) {
    throw cluster::CollectiveError(
        "a scenario is one trial: run it without mpirun (a study file spreads over the ranks)");
  }
  Scenario sc = LoadScenario(args.positional[0]);
  sc.trial.seed = static_cast<std::uint64_t>(seed);
  const std::string out = cli::OutPath(args, "out", "out/" + sc.name);
  if (sc.reaching) return RunReaching(sc, out, seed);

  const auto t0 = std::chrono::steady_clock::now();
  const cli::Progress progress(cli::ProgressFor(args));
  const SimulatedTrial r =
      SimulateScenario(sc, [&](double f) { progress(f, "simulating " + sc.name); });
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const Trial& measured = r.measured;
  const Trial& truth = r.truth;
  const std::string hash = Fnv1a64Hex(sc.source_text);
  Json files = Json::Array();
  Json manifest = Json::Object();
  manifest.Set("fesim_version", FESIM_VERSION)
      .Set("scenario", sc.name)
      .Set("scenario_file", sc.path)
      .Set("scenario_hash_fnv1a64", hash)
      .Set("seed", static_cast<double>(seed))
      .Set("duration_s", sc.trial.duration_s);
  manifest.Set("integration", r.stats);

  MakeDirs(out);
  const std::string base = out + "/" + sc.name;
  WriteFileAtomic(base + ".csv", FormatTrialCsv(measured));
  WriteFileAtomic(base + ".sto", FormatTrialSto(measured, sc.name));
  WriteFileAtomic(base + "_truth.csv", FormatTrialCsv(truth));
  // OpenSim playback (sim/opensim.h): the participant and the noiseless angles.
  WriteFileAtomic(base + ".osim", sim::FormatOsimModel(sc.model, sc.name));
  WriteFileAtomic(base + ".mot", sim::FormatOsimMotion(truth, sc.model, sc.name));
  for (const char* suffix : {".csv", ".sto", "_truth.csv", ".osim", ".mot"}) {
    files.Push(sc.name + suffix);
  }
  manifest.Set("files", files);
  WriteFileAtomic(out + "/manifest.json", manifest.Dump());
  std::fprintf(stderr, "fesim simulate: %s, %.1f s simulated in %.2f s (%.0fx real time) -> %s\n",
               sc.name.c_str(), sc.trial.duration_s, wall, sc.trial.duration_s / wall, out.c_str());
  return 0;
}

}  // namespace fesim
