// `fesim benchmark [STUDY.yaml] [--out DIR] [--quick] [--threads N] [--seed N]`
#include <cstdio>
#include <stdexcept>
#include <string>

#include "apps/cli.h"
#include "apps/commands.h"
#include "benchmark/run.h"
#include "scenarios/benchmark_spec.h"

namespace fesim {

namespace {

void PrintHelp() {
  std::printf(
      "usage: fesim benchmark [STUDY.yaml] [--out DIR] [--quick] [--threads N] [--seed N]\n\n"
      "Generates the virtual studies named in STUDY.yaml (default scenarios/default_study.yaml),\n"
      "fits every identification method with the papers' validation schemes (papers 000-004),\n"
      "compares with the papers' tables and with the ground truth, and writes\n"
      "  DIR/report.md     tables, findings, plots (Markdown)\n"
      "  DIR/results.json  every figure of the report\n"
      "  DIR/plots/*.png\n"
      "  DIR/cache/        trials and fits by input hash: a killed run resumes where it stopped\n"
      "Default DIR: out/benchmark (out/benchmark-quick with --quick). --quick runs the sections'\n"
      "quick studies (two participants, shortened protocols). --threads: default all cores.\n");
}

}  // namespace

int RunBenchmark(int argc, char** argv) {
  const auto args = cli::Parse(argc, argv, 2, {"help", "quick"}, {"out", "threads", "seed"});
  if (args.Has("help")) {
    PrintHelp();
    return 0;
  }
  if (args.positional.size() > 1) {
    throw std::runtime_error("unexpected argument '" + args.positional[1] + "'");
  }
  const std::string path =
      args.positional.empty() ? std::string("scenarios/default_study.yaml") : args.positional[0];
  benchmark::BenchmarkOptions o;
  o.quick = args.Has("quick");
  o.out_dir = args.Get("out", o.quick ? "out/benchmark-quick" : "out/benchmark");
  const long threads = args.GetInt("threads", 0);
  if (threads < 0 || threads > 256) throw std::runtime_error("--threads: must be in [0, 256]");
  o.threads = static_cast<int>(threads);
  const long seed = args.GetInt("seed", 1);
  if (seed < 0) throw std::runtime_error("--seed: must be >= 0");
  o.seed = static_cast<std::uint64_t>(seed);
  o.progress = cli::ShowProgress;
  const BenchmarkSpec spec = LoadBenchmarkSpec(path);  // after the options: cheap errors first
  const auto outcome = benchmark::RunBenchmark(spec, o);
  cli::ShowProgress(1.0, "done");
  std::fprintf(stderr, "fesim benchmark: %s in %.1f s -> %s/report.md\n", spec.name.c_str(),
               outcome.wall_s, o.out_dir.c_str());
  return 0;
}

}  // namespace fesim
