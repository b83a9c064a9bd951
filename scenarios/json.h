// A minimal, deterministic JSON writer for reports, manifests and metrics (no parsing).
#pragma once

#include <map>
#include <string>
#include <vector>

namespace fesim {

/// A JSON value built in memory and printed with stable key order (insertion order).
class Json {
 public:
  Json() : kind_(Kind::kNull) {}
  Json(double v);  // NOLINT(google-explicit-constructor)
  Json(int v) : Json(static_cast<double>(v)) {}  // NOLINT
  Json(long v) : Json(static_cast<double>(v)) {}  // NOLINT
  Json(unsigned long v) : Json(static_cast<double>(v)) {}  // NOLINT
  Json(bool v);  // NOLINT
  Json(const char* v);  // NOLINT
  Json(std::string v);  // NOLINT
  Json(const std::vector<double>& v);  // NOLINT
  static Json Object();
  static Json Array();

  /// Sets a member of an object (keeps the first insertion position on overwrite).
  Json& Set(const std::string& key, Json value);
  /// Appends to an array.
  Json& Push(Json value);

  /// Serialises; `indent` > 0 pretty-prints. Non-finite numbers print as null.
  std::string Dump(int indent = 2) const;

 private:
  enum class Kind { kNull, kNumber, kBool, kString, kArray, kObject };
  void DumpTo(std::string* out, int indent, int depth) const;
  Kind kind_;
  double number_ = 0.0;
  bool boolean_ = false;
  std::string string_;
  std::vector<Json> items_;
  std::vector<std::string> keys_;
};

}  // namespace fesim
