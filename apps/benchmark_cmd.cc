// `fesim benchmark [STUDY.yaml] [--out DIR] [--quick] [--threads N] [--seed N]`
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "apps/cli.h"
#include "apps/commands.h"
#include "paper_benchmark/run.h"
#include "scenarios/benchmark_spec.h"

namespace fesim {

namespace {

void PrintHelp() {
  std::printf(
      "usage: fesim benchmark [STUDY.yaml] [--out DIR] [--quick] [--threads N] [--seed N]\n"
      "                       [--quiet]\n\n"
      "Generates the virtual studies named in STUDY.yaml (default scenarios/default_study.yaml),\n"
      "fits every identification method with the papers' validation schemes (papers 000-004),\n"
      "compares with the papers' tables and with the ground truth, and writes\n"
      "  DIR/report.md     tables, findings, plots (Markdown)\n"
      "  DIR/results.json  every figure of the report\n"
      "  DIR/plots/*.png\n"
      "  DIR/cache/        trials and fits by input hash: a killed run resumes where it stopped\n"
      "Default DIR: out/benchmark (out/benchmark-quick with --quick). --quick runs the sections'\n"
      "quick studies (two participants, shortened protocols). --threads: default all cores.\n\n"
      "As an MPI job (mpirun -np N fesim benchmark ...), the trials and fits are spread over\n"
      "the ranks (dynamically balanced; --threads per rank, default 1); DIR must be on a file\n"
      "system every rank sees. Results do not depend on N. If work items fail, the others\n"
      "finish, the run exits 1 naming each failed item, and a rerun redoes only those.\n");
}

}  // namespace

int RunBenchmark(int argc, char** argv, cluster::Cluster& job) {
  const auto args =
      cli::Parse(argc, argv, 2, {"help", "quick", "quiet"}, {"out", "threads", "seed"});
  if (args.Has("help")) {
    PrintHelp();
    return 0;
  }
  if (args.positional.size() > 1) {
    throw std::runtime_error("unexpected argument '" + args.positional[1] + "'");
  }
  const std::string path =
      args.positional.empty() ? std::string("scenarios/default_study.yaml") : args.positional[0];
  paper_benchmark::BenchmarkOptions o;
  o.quick = args.Has("quick");
  o.out_dir = cli::OutPath(args, "out", o.quick ? "out/benchmark-quick" : "out/benchmark");
  o.threads = cli::Threads(args, 0);  // 0 (not given): all cores, 1 per rank under mpirun
  const long seed = args.GetInt("seed", 1);
  if (seed < 0) throw std::runtime_error("--seed: must be >= 0");
  o.seed = static_cast<std::uint64_t>(seed);
  const cli::Progress progress(cli::ProgressFor(args));
  if (job.is_root()) o.progress = progress;
  o.cluster = &job;
  // Fault injection for the failure-handling tests (docs/cluster.md): the named work item fails.
  if (const char* fail = std::getenv("FESIM_FAIL_ITEM")) o.fail_item = fail;
  BenchmarkSpec spec;
  try {
    spec = LoadBenchmarkSpec(path);  // after the options: cheap errors first
  } catch (const std::runtime_error& e) {
    // Every rank reads the same file and fails alike: one message, not one per rank.
    throw cluster::CollectiveError(e.what());
  }
  const auto outcome = paper_benchmark::RunBenchmark(spec, o);
  if (job.is_root()) {
    progress(1.0, "done");
    std::fprintf(stderr, "fesim benchmark: %s in %.1f s%s -> %s/report.md\n", spec.name.c_str(),
                 outcome.wall_s,
                 job.size() > 1 ? (" on " + std::to_string(job.size()) + " MPI ranks").c_str() : "",
                 o.out_dir.c_str());
  }
  return 0;
}

}  // namespace fesim
