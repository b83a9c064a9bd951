// A minimal, deterministic JSON value for reports, manifests and metrics: built in memory and
// printed with stable key order; parsed back (RFC 8259) to reload cached results.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace fesim {

/// A JSON value built in memory and printed with stable key order (insertion order).
class Json {
 public:
  Json() : kind_(Kind::kNull) {}
  Json(double v);                                          // NOLINT(google-explicit-constructor)
  Json(int v) : Json(static_cast<double>(v)) {}            // NOLINT
  Json(long v) : Json(static_cast<double>(v)) {}           // NOLINT
  Json(unsigned long v) : Json(static_cast<double>(v)) {}  // NOLINT
  Json(bool v);                                            // NOLINT
  Json(const char* v);                                     // NOLINT
  Json(std::string v);                                     // NOLINT
  Json(const std::vector<double>& v);                      // NOLINT
  static Json Object();
  static Json Array();

  /// Sets a member of an object (keeps the first insertion position on overwrite).
  Json& Set(const std::string& key, Json value);
  /// Appends to an array.
  Json& Push(Json value);

  /// Serialises; `indent` > 0 pretty-prints. Non-finite numbers print as null.
  std::string Dump(int indent = 2) const;

  /// Parses RFC 8259 JSON text (UTF-8; \u escapes of the Basic Multilingual Plane). Throws
  /// std::runtime_error "<what>: byte <offset>: <reason>" on malformed text or trailing data.
  /// Dump(Parse(Dump(x))) == Dump(x) for every value without non-finite numbers.
  static Json Parse(const std::string& text, const std::string& what = "json");

  bool IsNull() const { return kind_ == Kind::kNull; }
  bool IsNumber() const { return kind_ == Kind::kNumber; }
  bool IsString() const { return kind_ == Kind::kString; }
  bool IsArray() const { return kind_ == Kind::kArray; }
  bool IsObject() const { return kind_ == Kind::kObject; }
  /// The number (NaN for null, which is how non-finite numbers are written); throws
  /// std::runtime_error for other kinds.
  double AsNumber() const;
  /// The string; throws std::runtime_error for other kinds.
  const std::string& AsString() const;
  bool AsBool() const;
  /// Member `key` of an object, or nullptr (also for non-objects).
  const Json* Find(const std::string& key) const;
  /// Elements of an array or member values of an object (in order).
  const std::vector<Json>& Items() const { return items_; }
  /// Member keys of an object (in order).
  const std::vector<std::string>& Keys() const { return keys_; }

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
