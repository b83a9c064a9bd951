// A directory of results keyed by a hash of their inputs, so that a killed `fesim benchmark` or
// `fesim diagnose` resumes where it stopped (issue 10): every entry is one JSON file written
// atomically (base/trial.h WriteFileAtomic), so an interrupted run leaves complete entries
// or none. The key hashes the fesim version, a layout tag (a build with another layout misses
// instead of misreading) and the caller's parts (input contents, options).
#pragma once

#include <mutex>
#include <string>
#include <vector>

#include "base/json.h"
#include "base/trial.h"

namespace fesim {

/// Creates a directory and its parents; throws std::runtime_error naming the path and the
/// system's reason on failure. Returns the directories it created, outermost first (empty when
/// `path` existed), so a caller whose first write then fails can remove them again.
std::vector<std::string> MakeDirs(const std::string& path);

/// True when `path` is a regular file.
bool RegularFileExists(const std::string& path);

/// What a run wrote to one output file, so that a resumed run can tell a complete file from one
/// damaged since (truncated, edited): {"path": path relative to the output directory, "bytes":
/// size, "fnv1a64": Fnv1a64Hex(contents)}.
Json WrittenFileRecord(const std::string& relative_path, const std::string& contents);

/// "" when `dir`/record.path holds exactly the recorded bytes, else why not, naming the file
/// (e.g. "out/p1/a_r1.csv: 5000 bytes, 61234 were written"). Never throws on a missing or
/// unreadable file; throws std::runtime_error on a malformed record.
std::string CheckWrittenFile(const std::string& dir, const Json& record);

class ResultCache {
 public:
  /// Entries live in `dir` (created on the first Store); `version` and `layout` enter every key.
  ResultCache(std::string dir, std::string version, std::string layout);

  /// 16 hex digits: FNV-1a of version, layout and parts, newline-separated.
  std::string Key(const std::vector<std::string>& parts) const;
  /// `dir`/<Key(parts)>: a sub-directory name for callers that store several files per entry.
  std::string Path(const std::vector<std::string>& parts) const;

  /// Reads the entry of `parts` into *out; false when there is none. A present but malformed
  /// entry throws std::runtime_error naming the file.
  bool Load(const std::vector<std::string>& parts, Json* out) const;
  /// Writes the entry of `parts` (atomically, creating `dir`). Thread-safe.
  void Store(const std::vector<std::string>& parts, const Json& value);

  const std::string& dir() const { return dir_; }

 private:
  std::string dir_, version_, layout_;
  std::mutex mutex_;
};

/// Trials as JSON (metadata, time, columns) for cached predictions: unlike the trial CSV reader,
/// which rejects angles beyond a full turn as unit errors, JSON keeps what a diverging model
/// predicted. Non-finite numbers come back as NaN.
Json TrialsToJson(const std::vector<Trial>& trials);
/// The inverse; throws std::runtime_error (prefixed with `what`) on a malformed value.
std::vector<Trial> TrialsFromJson(const Json& all, const std::string& what = "json");

/// A double as its shortest round-trip decimal text (for cache keys of numeric inputs).
std::string ExactNumberText(double v);

}  // namespace fesim
