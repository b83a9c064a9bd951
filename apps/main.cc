// The `fesim` command-line tool: one binary, one subcommand per capability.
#include <unistd.h>

#include <cctype>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <memory>
#include <string>

#include "apps/commands.h"
#include "base/trial.h"
#include "cluster/cluster.h"
#include "fesim/version.h"

namespace {

/// SIGINT/SIGTERM: remove the registered temporary files (atomic writes in progress, the movie
/// being encoded), then die of the signal as before. Outputs are renamed into place only when
/// complete, so an interrupted run leaves complete files or none, and no *.tmp.* files
/// (docs/reliability.md).
void OnTerminate(int sig) {
  for (int k = 0; k < fesim::kMaxRegisteredTempFiles; ++k) {
    const char* registered = fesim::RegisteredTempFile(k);
    if (registered[0] != '\0') ::unlink(registered);
  }
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

/// Error messages are one line (PRODUCT.md "Interfaces"); some library exceptions (Simbody's)
/// span several, so line breaks and the indentation after them become single spaces.
std::string OneLine(const std::string& s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] != '\n' && s[i] != '\r') {
      out.push_back(s[i]);
      continue;
    }
    while (i + 1 < s.size() && std::isspace(static_cast<unsigned char>(s[i + 1]))) ++i;
    if (!out.empty() && i + 1 < s.size()) out.push_back(' ');
  }
  return out;
}

void PrintUsage() {
  std::printf(
      "fesim %s — upper-limb FES simulator and identification bench\n\n"
      "usage:\n"
      "  fesim simulate  SCENARIO.yaml [--out DIR] [--seed N]\n"
      "  fesim identify  --method NAME --train A.csv[,B.csv...] [--test C.csv] [--out DIR]\n"
      "  fesim benchmark [STUDY.yaml] [--out DIR] [--quick] [--threads N] [--seed N]\n"
      "  fesim diagnose  MEASURED.csv[,MORE.csv...] --scenario SCENARIO.yaml [--out DIR]\n"
      "  fesim render    TRIAL.csv --scenario SCENARIO.yaml --out MOVIE.mp4 | --frames DIR\n"
      "                  [--width W --height H --fps F --camera front|side|top|orbit]\n"
      "                  [--compare OTHER.csv]\n"
      "  fesim export    TRIAL.csv [--scenario SCENARIO.yaml] [--mat] [--out DIR]\n"
      "  fesim --version\n\n"
      "simulate (study files), benchmark and diagnose also run as an MPI job, spread over its\n"
      "ranks: mpirun -np N fesim benchmark ... (docs/cluster.md).\n"
      "Progress goes to stderr: a live bar on a terminal, a time-stamped line at most every 5 s\n"
      "into a pipe or file; --quiet (every subcommand) shows none.\n"
      "Run 'fesim SUBCOMMAND --help' for details.\n",
      FESIM_VERSION);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
    PrintUsage();
    return argc < 2 ? 2 : 0;
  }
  const std::string cmd = argv[1];
  std::signal(SIGINT, OnTerminate);
  std::signal(SIGTERM, OnTerminate);
  if (cmd == "--version") {
    std::printf("fesim %s\n", FESIM_VERSION);
    return 0;
  }
  // Under mpirun this process is one rank of a job (issue 9); otherwise a job of one.
  std::unique_ptr<fesim::cluster::Cluster> job;
  try {
    job = fesim::cluster::Cluster::Start(&argc, &argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fesim %s: error: %s\n", cmd.c_str(), OneLine(e.what()).c_str());
    return 2;
  }
  try {
    if (cmd == "simulate") return fesim::RunSimulate(argc, argv, *job);
    if (cmd == "benchmark") return fesim::RunBenchmark(argc, argv, *job);
    if (cmd == "diagnose") return fesim::RunDiagnose(argc, argv, *job);
    if (cmd != "render" && cmd != "identify" && cmd != "export") {
      if (job->is_root()) {
        std::fprintf(stderr, "fesim: unknown subcommand '%s' (see fesim --help)\n", cmd.c_str());
      }
      return 2;
    }
    if (job->size() > 1) {
      if (job->is_root()) {
        std::fprintf(stderr,
                     "fesim %s: error: runs on one process (its work is one item); start it "
                     "without mpirun or with -np 1\n",
                     cmd.c_str());
      }
      return 2;
    }
    if (cmd == "render") return fesim::RunRender(argc, argv);
    if (cmd == "export") return fesim::RunExport(argc, argv);
    return fesim::RunIdentify(argc, argv);
  } catch (const fesim::cluster::CollectiveError& e) {
    // Every rank threw it at the same point: rank 0 says it once, all end normally.
    if (job->is_root()) {
      std::fprintf(stderr, "\nfesim %s: error: %s\n", cmd.c_str(), OneLine(e.what()).c_str());
    }
    return 1;
  } catch (const std::exception& e) {
    if (job->size() == 1) {
      std::fprintf(stderr, "\nfesim %s: error: %s\n", cmd.c_str(), OneLine(e.what()).c_str());
      return 1;
    }
    // One rank's own failure (or every rank's, e.g. bad input): the others may be waiting for
    // it, so the job ends here.
    std::fprintf(stderr, "\nfesim %s: error (rank %d of %d): %s\n", cmd.c_str(), job->rank(),
                 job->size(), OneLine(e.what()).c_str());
    job->Abort(1);
  }
}
