// `fesim simulate SCENARIO.yaml [--out DIR] [--seed N]`
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "apps/cli.h"
#include "apps/commands.h"
#include "fesim/version.h"
#include "scenarios/json.h"
#include "scenarios/scenario.h"
#include "scenarios/trial.h"
#include "sim/trial_runner.h"
#include "sim/upper_limb_model.h"

namespace fesim {
namespace {

void PrintHelp() {
  std::printf(
      "usage: fesim simulate SCENARIO.yaml [--out DIR] [--seed N]\n\n"
      "Simulates the scenario's trial on its virtual participant and writes, atomically:\n"
      "  DIR/<name>.csv        measured trial (sensors with noise; NaN where a sensor did not "
      "sample)\n"
      "  DIR/<name>.sto        the same as an OpenSim storage file\n"
      "  DIR/<name>_truth.csv  noiseless ground truth (all coordinates, activations, forces)\n"
      "  DIR/manifest.json     scenario hash, seed, version, files, integrator statistics\n"
      "Same scenario and seed give the same bytes. Default DIR: out/<name>, seed 1.\n");
}

/// FNV-1a, 64 bit: a stable content hash for the manifest.
std::string Fnv1a64(const std::string& s) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

}  // namespace

int RunSimulate(int argc, char** argv) {
  const auto args = cli::Parse(argc, argv, 2, {"help"}, {"out", "seed"});
  if (args.Has("help")) {
    PrintHelp();
    return 0;
  }
  if (args.positional.size() != 1) {
    throw std::runtime_error("expected one SCENARIO.yaml argument (see --help)");
  }
  const long seed = args.GetInt("seed", 1);
  if (seed < 0)
    throw std::runtime_error("option --seed: " + std::to_string(seed) + " is outside [0, 2^63)");
  Scenario sc = LoadScenario(args.positional[0]);
  sc.trial.seed = static_cast<std::uint64_t>(seed);
  const std::string out = args.Get("out", "out/" + sc.name);

  const auto t0 = std::chrono::steady_clock::now();
  const sim::UpperLimbModel model(sc.model);
  const sim::TrialResult r = sim::RunTrial(
      model, sc.trial, [&](double f) { cli::ShowProgress(f, "simulating " + sc.name); });
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  Trial measured = r.measured, truth = r.truth;
  const std::string hash = Fnv1a64(sc.source_text);
  for (Trial* t : {&measured, &truth}) {
    t->metadata["scenario"] = sc.name;
    t->metadata["scenario_hash"] = hash;
    t->metadata["fesim_version"] = FESIM_VERSION;
  }
  Json files = Json::Array();
  Json manifest = Json::Object();
  manifest.Set("fesim_version", FESIM_VERSION)
      .Set("scenario", sc.name)
      .Set("scenario_file", sc.path)
      .Set("scenario_hash_fnv1a64", hash)
      .Set("seed", static_cast<double>(seed))
      .Set("duration_s", sc.trial.duration_s);
  Json stats = Json::Object();
  stats.Set("steps", static_cast<double>(r.stats.steps))
      .Set("rhs_evaluations", static_cast<double>(r.stats.rhs_evaluations))
      .Set("jacobian_evaluations", static_cast<double>(r.stats.jacobian_evaluations))
      .Set("breakpoints", static_cast<double>(r.stats.breakpoints))
      .Set("fibre_length_clamped", r.fibre_clamped);
  manifest.Set("integration", stats);

  cli::MakeDirs(out);
  const std::string base = out + "/" + sc.name;
  WriteFileAtomic(base + ".csv", FormatTrialCsv(measured));
  WriteFileAtomic(base + ".sto", FormatTrialSto(measured, sc.name));
  WriteFileAtomic(base + "_truth.csv", FormatTrialCsv(truth));
  for (const char* suffix : {".csv", ".sto", "_truth.csv"}) files.Push(sc.name + suffix);
  manifest.Set("files", files);
  WriteFileAtomic(out + "/manifest.json", manifest.Dump());
  std::fprintf(stderr, "fesim simulate: %s, %.1f s simulated in %.2f s (%.0fx real time) -> %s\n",
               sc.name.c_str(), sc.trial.duration_s, wall, sc.trial.duration_s / wall, out.c_str());
  return 0;
}

}  // namespace fesim
