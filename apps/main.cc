// The `fesim` command-line tool: one binary, one subcommand per capability.
#include <unistd.h>

#include <cctype>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include "apps/commands.h"
#include "fesim/version.h"
#include "scenarios/trial.h"

namespace {

/// SIGINT/SIGTERM: remove the temporary file of an atomic write in progress (if any) and the
/// registered ones (the movie being encoded), then die of
/// the signal as before. Outputs are renamed into place only when complete, so an interrupted run
/// leaves complete files or none, and no *.tmp.* files (docs/reliability.md).
void OnTerminate(int sig) {
  const char* tmp = fesim::PendingAtomicWriteTempFile();
  if (tmp[0] != '\0') ::unlink(tmp);
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
      "  fesim --version\n\n"
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
  try {
    if (cmd == "simulate") return fesim::RunSimulate(argc, argv);
    if (cmd == "render") return fesim::RunRender(argc, argv);
    if (cmd == "identify") return fesim::RunIdentify(argc, argv);
    if (cmd == "benchmark") return fesim::RunBenchmark(argc, argv);
    if (cmd == "diagnose") return fesim::RunDiagnose(argc, argv);
    std::fprintf(stderr, "fesim: unknown subcommand '%s' (see fesim --help)\n", cmd.c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "\nfesim %s: error: %s\n", cmd.c_str(), OneLine(e.what()).c_str());
    return 1;
  }
}
