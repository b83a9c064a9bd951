// Trial records: the plain data every part of fesim exchanges (PRODUCT.md "Interfaces").
//
// A trial is a table sampled at the times in `time` (s, strictly increasing). Column names carry
// the quantity and its unit by prefix:
//   u.<channel>  stimulation pulse width, µs (0–300)
//   q.<joint>    joint angle, rad                 qd.<joint>  joint velocity, rad/s
//   tau.<joint>  joint torque, N·m               f.<muscle>  muscle force, N
//   a.<muscle>   muscle activation, 0–1
// Other prefixes are allowed and kept. Metadata are `key: value` pairs written as `#` comment
// lines before the CSV header.
//
// This header depends on the C++ standard library only, so that identification/ (Eigen only) can
// read trials without seeing Simbody.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace fesim {

/// One trial: time plus named columns of equal length.
struct Trial {
  std::map<std::string, std::string> metadata;  ///< `key: value` pairs, written sorted by key.
  std::vector<double> time;                     ///< sample times, s, strictly increasing.
  std::vector<std::string> names;               ///< column names, without `time`.
  std::vector<std::vector<double>> columns;     ///< columns[k][i] is names[k] at time[i].

  /// Number of samples.
  std::size_t size() const { return time.size(); }
  /// True when a column with this exact name exists.
  bool Has(const std::string& name) const;
  /// The column with this name; throws std::out_of_range naming it when absent.
  const std::vector<double>& Column(const std::string& name) const;
  std::vector<double>& MutableColumn(const std::string& name);
  /// Appends a column; throws std::invalid_argument on a duplicate name or wrong length.
  void AddColumn(const std::string& name, std::vector<double> values);
  /// Names of the columns starting with `prefix` (e.g. "q."), in file order, prefix kept.
  std::vector<std::string> NamesWithPrefix(const std::string& prefix) const;
};

/// Reads a trial CSV (C locale, `#` metadata lines, header row whose first column is `time`).
/// Columns whose name ends in `_deg` are angles in degrees: they are converted to rad and renamed
/// without the suffix. Empty cells and `nan` become NaN (tracker dropouts); anything else that is
/// not a number, a wrong cell count, a duplicate column or non-increasing time is an error, and so
/// are units that cannot be right: a `u.` value outside [0, 300] µs, a `q.` angle beyond ±2π rad.
/// Throws std::runtime_error with a one-line message "FILE:LINE: column NAME: what is wrong".
/// Files larger than kMaxTrialFileBytes are refused with that message before reading.
Trial ReadTrialCsv(const std::string& path);
/// Largest trial CSV ReadTrialCsv loads, bytes (4 GiB; the parse peaks at ≈ 1.5× the size).
inline constexpr std::uint64_t kMaxTrialFileBytes = 4ull << 30;

/// Parses trial CSV text; `source` names the origin in error messages.
Trial ParseTrialCsv(const std::string& text, const std::string& source);

/// Formats a trial as CSV text (17 significant digits, C locale, deterministic).
std::string FormatTrialCsv(const Trial& trial);

/// Formats a trial as an OpenSim storage (.sto) file: header with nRows/nColumns/inDegrees=no,
/// `endheader`, then a tab-separated table with `time` first.
std::string FormatTrialSto(const Trial& trial, const std::string& name);

/// Writes `contents` to `path` atomically: a temporary file in the same directory, flushed and
/// renamed over `path`. Throws std::runtime_error naming the path on failure; never leaves a
/// partial file at `path`.
void WriteFileAtomic(const std::string& path, const std::string& contents);

/// Temporary files that a SIGINT/SIGTERM handler must remove so that an interrupted run leaves
/// none behind (apps/main.cc): every WriteFileAtomic's while it is written (one per writing
/// thread) and those written elsewhere (the movie ffmpeg is encoding). At most
/// kMaxRegisteredTempFiles at once, paths shorter than 4096 bytes. RegisterTempFile returns a
/// slot (−1 when full: the file is then not cleaned up on a signal, which is the only
/// consequence); UnregisterTempFile(slot) frees it.
inline constexpr int kMaxRegisteredTempFiles = 64;
int RegisterTempFile(const std::string& path);
void UnregisterTempFile(int slot);
/// For signal handlers (async-signal-safe): the path in `slot`, or "".
const char* RegisteredTempFile(int slot);

/// `bytes` as shown in a one-line error message: control bytes and bytes that are not valid
/// UTF-8 (binary garbage) as \xNN, at most 40 bytes of input followed by "..." when longer.
std::string ShownInMessage(const std::string& bytes);

/// FNV-1a 64-bit hash of `bytes` as 16 lower-case hex digits (cache keys, manifest hashes).
std::string Fnv1a64Hex(const std::string& bytes);

/// The host part of WriteFileAtomic's temporary names, `PATH.tmp.PID.HOST` (the host name with
/// characters other than letters, digits, '-' and '.' replaced by '_').
std::string TempSuffixHost();

/// Reads a whole file; throws std::runtime_error naming the path when it cannot be read.
std::string ReadFile(const std::string& path);

}  // namespace fesim
