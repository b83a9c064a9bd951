// Measures the trial CSV reader on one file (docs/reliability.md, "huge files"):
//   c++ -std=c++17 -O2 -I. fuzz/load_trial_csv.cc base/trial.cc -o /tmp/load_trial_csv
//   /usr/bin/time -v /tmp/load_trial_csv big.csv
// Prints rows and columns, or the reader's one-line error; exit code 0 or 1.
#include <chrono>
#include <cstdio>
#include <exception>

#include "base/trial.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: load_trial_csv FILE.csv\n");
    return 2;
  }
  const auto t0 = std::chrono::steady_clock::now();
  try {
    const fesim::Trial t = fesim::ReadTrialCsv(argv[1]);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("%zu rows, %zu columns, %.2f s\n", t.size(), t.names.size() + 1, s);
    return 0;
  } catch (const std::exception& e) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::fprintf(stderr, "error after %.2f s: %s\n", s, e.what());
    return 1;
  }
}
