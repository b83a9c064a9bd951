// The `fesim` command-line tool: one binary, one subcommand per capability.
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include "apps/commands.h"
#include "fesim/version.h"

namespace {

void PrintUsage() {
  std::printf(
      "fesim %s — upper-limb FES simulator and identification bench\n\n"
      "usage:\n"
      "  fesim simulate  SCENARIO.yaml [--out DIR] [--seed N]\n"
      "  fesim identify  --method NAME --train A.csv[,B.csv...] [--test C.csv] [--out DIR]\n"
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
  if (cmd == "--version") {
    std::printf("fesim %s\n", FESIM_VERSION);
    return 0;
  }
  try {
    if (cmd == "simulate") return fesim::RunSimulate(argc, argv);
    if (cmd == "render") return fesim::RunRender(argc, argv);
    if (cmd == "identify") return fesim::RunIdentify(argc, argv);
    std::fprintf(stderr, "fesim: unknown subcommand '%s' (see fesim --help)\n", cmd.c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "\nfesim %s: error: %s\n", cmd.c_str(), e.what());
    return 1;
  }
}
