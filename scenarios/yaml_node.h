// Validating access to a YAML mapping for the scenario and study loaders: every read names the
// file and the key path, checks the type and the allowed range, and unknown keys are errors.
// Internal to scenarios/.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "base/trial.h"

namespace fesim::internal {

inline std::string Fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

/// Returns parse(), turning a yaml-cpp exception that escapes a loader's checks into a one-line
/// error naming the file and line: e.g. a mapping used as a key (`{{ext: 1}}`), which makes
/// yaml-cpp throw "bad conversion" from a key check (found by fuzzing, docs/reliability.md).
template <typename Parse>
auto WithYamlErrorsNamed(const std::string& path, Parse&& parse) -> decltype(parse()) {
  try {
    return parse();
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path +
                             (e.mark.is_null() ? "" : ":" + std::to_string(e.mark.line + 1)) +
                             ": unexpected YAML structure (" + e.msg + ")");
  }
}

/// A YAML mapping with its key path, which checks types, ranges and unknown keys.
class YamlNode {
 public:
  // YAML::Node has no move constructor (a copy shares the underlying node), hence const&.
  YamlNode(const YAML::Node& node, std::string path, const std::string* file)
      : node_(node), path_(std::move(path)), file_(file) {}

  [[noreturn]] void Fail(const std::string& what) const {
    throw std::runtime_error(*file_ + ": " + (path_.empty() ? "" : path_ + ": ") + what);
  }
  [[noreturn]] void FailKey(const std::string& key, const std::string& what) const {
    throw std::runtime_error(*file_ + ": " + Join(key) + ": " + what);
  }
  std::string Join(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

  /// Requires a mapping whose keys are all in `allowed`, each given once.
  void Keys(const std::set<std::string>& allowed) const {
    if (!node_.IsMap()) Fail("expected a mapping");
    RequireUniqueKeys();
    for (const auto& kv : node_) {
      const auto k = kv.first.as<std::string>();
      if (!allowed.count(k)) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        FailKey(k, "unknown key (allowed: " + list + ")");
      }
    }
  }
  bool Has(const std::string& key) const { return node_.IsMap() && node_[key]; }
  YamlNode Child(const std::string& key) const {
    if (!Has(key)) FailKey(key, "missing required key");
    return {node_[key], Join(key), file_};
  }
  YamlNode Item(std::size_t i) const {
    return {node_[i], path_ + "[" + std::to_string(i) + "]", file_};
  }
  std::size_t Size() const {
    if (!node_.IsSequence()) Fail("expected a list");
    return node_.size();
  }
  bool IsMap() const { return node_.IsMap(); }

  double Number(const std::string& key, double lo, double hi) const {
    const YamlNode c = Child(key);
    double v = 0.0;
    try {
      if (!c.node_.IsScalar()) throw YAML::Exception(YAML::Mark(), "");
      v = c.node_.as<double>();
    } catch (const YAML::Exception&) {
      FailKey(key, "expected a number in [" + Fmt(lo) + ", " + Fmt(hi) + "]");
    }
    if (!std::isfinite(v) || v < lo || v > hi) {
      FailKey(key, Fmt(v) + " is outside [" + Fmt(lo) + ", " + Fmt(hi) + "]");
    }
    return v;
  }
  /// Optional number: keeps `*out` when the key is absent.
  void Number(const std::string& key, double lo, double hi, double* out, double scale = 1.0) const {
    if (Has(key)) *out = Number(key, lo, hi) * scale;
  }
  int Integer(const std::string& key, int lo, int hi) const {
    const double v = Number(key, lo, hi);
    if (v != std::floor(v))
      FailKey(key, Fmt(v) + " is not an integer in [" + Fmt(lo) + ", " + Fmt(hi) + "]");
    return static_cast<int>(v);
  }
  std::string Text(const std::string& key) const {
    const YamlNode c = Child(key);
    if (!c.node_.IsScalar()) FailKey(key, "expected text");
    return c.node_.as<std::string>();
  }
  /// Text that becomes part of an output file name (`fesim simulate` writes DIR/<name>.csv):
  /// non-empty, letters, digits, '.', '_' and '-' only, not starting with '.', so that it can
  /// neither leave DIR ('..', '/') nor make a hidden file.
  std::string FileStem(const std::string& key) const {
    const std::string v = Text(key);
    bool ok = !v.empty() && v.size() <= 200 && v[0] != '.';
    for (const char c : v) {
      ok = ok && ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                  c == '.' || c == '_' || c == '-');
    }
    if (!ok) {
      FailKey(key, "'" + ShownInMessage(v) +
                       "' cannot name output files (allowed: 1-200 of A-Z a-z 0-9 . _ -, not "
                       "starting with '.')");
    }
    return v;
  }
  std::string Choice(const std::string& key, const std::set<std::string>& allowed) const {
    std::string v = Text(key);
    if (!allowed.count(v)) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : "|") + a;
      FailKey(key, "'" + v + "' is not one of " + list);
    }
    return v;
  }
  std::vector<double> Vector(const std::string& key, std::size_t n, double lo, double hi) const {
    const YamlNode c = Child(key);
    if (!c.node_.IsSequence() || c.node_.size() != n) {
      FailKey(key, "expected a list of " + std::to_string(n) + " numbers");
    }
    std::vector<double> v;
    for (std::size_t i = 0; i < n; ++i) {
      double x = 0.0;
      try {
        x = c.node_[i].as<double>();
      } catch (const YAML::Exception&) {
        FailKey(key, "element " + std::to_string(i) + " is not a number");
      }
      if (!std::isfinite(x) || x < lo || x > hi) {
        FailKey(key, "element " + std::to_string(i) + " = " + Fmt(x) + " is outside [" + Fmt(lo) +
                         ", " + Fmt(hi) + "]");
      }
      v.push_back(x);
    }
    return v;
  }
  /// This node as a list of three finite numbers in [−10, 10] (a point in m).
  std::vector<double> Vector3() const {
    if (!node_.IsSequence() || node_.size() != 3) Fail("expected a list of 3 numbers");
    std::vector<double> v;
    for (std::size_t i = 0; i < 3; ++i) {
      double x = 0.0;
      try {
        x = node_[i].as<double>();
      } catch (const YAML::Exception&) {
        Fail("element " + std::to_string(i) + " is not a number");
      }
      if (!std::isfinite(x) || x < -10 || x > 10) {
        Fail("element " + std::to_string(i) + " = " + Fmt(x) + " is outside [-10, 10]");
      }
      v.push_back(x);
    }
    return v;
  }
  std::vector<int> IntList(const std::string& key, int lo, int hi) const {
    const YamlNode c = Child(key);
    std::vector<int> out;
    for (std::size_t i = 0; i < c.Size(); ++i) {
      double x = 0.0;
      try {
        x = c.node_[i].as<double>();
      } catch (const YAML::Exception&) {
        FailKey(key, "element " + std::to_string(i) + " is not an integer");
      }
      if (x != std::floor(x) || x < lo || x > hi) {
        FailKey(key, "element " + std::to_string(i) + " = " + Fmt(x) + " is not an integer in [" +
                         Fmt(lo) + ", " + Fmt(hi) + "]");
      }
      out.push_back(static_cast<int>(x));
    }
    return out;
  }
  std::vector<std::string> TextList() const {
    std::vector<std::string> out;
    for (std::size_t i = 0; i < Size(); ++i) {
      if (!node_[i].IsScalar()) Fail("element " + std::to_string(i) + " is not text");
      out.push_back(node_[i].as<std::string>());
    }
    return out;
  }
  /// Keys of a mapping, in file order, each given once.
  std::vector<std::string> MapKeys() const {
    if (!node_.IsMap()) Fail("expected a mapping");
    RequireUniqueKeys();
    std::vector<std::string> k;
    for (const auto& kv : node_) k.push_back(kv.first.as<std::string>());
    return k;
  }

 private:
  /// yaml-cpp keeps both entries of a key given twice and finds the first: a silently ignored
  /// setting. Refused, naming both lines.
  void RequireUniqueKeys() const {
    std::vector<std::pair<std::string, int>> seen;
    for (const auto& kv : node_) {
      const auto k = kv.first.as<std::string>();
      const int line = kv.first.Mark().line + 1;
      for (const auto& [name, first_line] : seen) {
        if (name == k) {
          throw std::runtime_error(*file_ + ":" + std::to_string(line) + ": " +
                                   ShownInMessage(Join(k)) + ": key given twice (lines " +
                                   std::to_string(first_line) + " and " + std::to_string(line) +
                                   ")");
        }
      }
      seen.emplace_back(k, line);
    }
  }

  YAML::Node node_;
  std::string path_;
  const std::string* file_;
};

}  // namespace fesim::internal
