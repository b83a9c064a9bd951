// Small helpers shared by the `fesim` subcommands: argument parsing and progress display.
#pragma once

#include <map>
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

/// Prints a one-line progress bar on stderr (overwritten in place; newline at fraction 1).
void ShowProgress(double fraction, const std::string& stage);

}  // namespace fesim::cli
