// Small helpers shared by the `fesim` subcommands: argument parsing and progress display.
#pragma once

#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace fesim::cli {

/// Parsed command line: positional arguments and `--key value` / `--flag` options.
struct Args {
  std::vector<std::string> positional;
  std::map<std::string, std::string> options;  ///< flags map to "".
  bool Has(const std::string& key) const { return options.count(key) > 0; }
  std::string Get(const std::string& key, const std::string& fallback = "") const;
  /// Integer option; throws std::runtime_error naming the option when not an integer.
  long GetInt(const std::string& key, long fallback) const;
};

/// Parses argv[first..]. `flags` lists the options that take no value; `valued` those that take
/// one. Anything else starting with `--` is an error naming it.
Args Parse(int argc, char** argv, int first, const std::vector<std::string>& flags,
           const std::vector<std::string>& valued);

/// The output path option `key` ("out", "frames"), or `fallback` when it is absent. An empty
/// value is refused (an empty --out would put DIR/<file> in the file system root).
std::string OutPath(const Args& args, const std::string& key, const std::string& fallback);

/// Thread counts every command accepts for --threads.
inline constexpr long kMaxThreads = 256;
/// --threads: `fallback` when absent, else an integer in [1, kMaxThreads] (std::runtime_error
/// naming the option and the range otherwise).
int Threads(const Args& args, int fallback);

/// Splits "a,b,c" into its parts (empty parts dropped).
std::vector<std::string> SplitList(const std::string& s);

/// How progress is shown: a live bar on a terminal, plain time-stamped lines into a pipe or a
/// file, nothing with --quiet.
struct ProgressOptions {
  enum class Mode { kBar, kLines, kQuiet };
  Mode mode = Mode::kLines;
  double line_interval_s = 5.0;  ///< kLines: at most one line per interval (and the last), s.
  int columns = 80;              ///< kBar: terminal width, characters.
  std::FILE* out = stderr;
  std::function<double()> clock;  ///< monotonic seconds; null: std::chrono::steady_clock.
  std::function<std::string()> time_of_day;  ///< kLines stamp; null: local "HH:MM:SS".
};

/// The options every command takes from its arguments: --quiet → kQuiet; stderr a terminal →
/// kBar at its width (80 when unknown); else kLines.
ProgressOptions ProgressFor(const Args& args);

/// The progress callback the library functions take (fraction in [0, 1], stage label); copies
/// share one state. The ETA comes from the measured pace: the time since the first report with
/// a fraction above 0 over the fraction done since then (the start-up before it is not an
/// item's cost); shown once 2 % and 1 s have passed since that report, never cut off (a long
/// label is shortened instead).
class Progress {
 public:
  explicit Progress(ProgressOptions options);
  void operator()(double fraction, const std::string& stage) const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

/// A duration for people: "42 s", "3 min 05 s", "1 h 02 min".
std::string FormatDuration(double seconds);

}  // namespace fesim::cli
