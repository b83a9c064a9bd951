#include "scenarios/json.h"

#include <charconv>
#include <cmath>
#include <cstdio>

namespace fesim {

Json::Json(double v) : kind_(Kind::kNumber), number_(v) {}
Json::Json(bool v) : kind_(Kind::kBool), boolean_(v) {}
Json::Json(const char* v) : kind_(Kind::kString), string_(v) {}
Json::Json(std::string v) : kind_(Kind::kString), string_(std::move(v)) {}
Json::Json(const std::vector<double>& v) : kind_(Kind::kArray) {
  for (double x : v) items_.emplace_back(x);
}

Json Json::Object() {
  Json j;
  j.kind_ = Kind::kObject;
  return j;
}

Json Json::Array() {
  Json j;
  j.kind_ = Kind::kArray;
  return j;
}

Json& Json::Set(const std::string& key, Json value) {
  kind_ = Kind::kObject;
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    if (keys_[i] == key) {
      items_[i] = std::move(value);
      return *this;
    }
  }
  keys_.push_back(key);
  items_.push_back(std::move(value));
  return *this;
}

Json& Json::Push(Json value) {
  kind_ = Kind::kArray;
  items_.push_back(std::move(value));
  return *this;
}

std::string Json::Dump(int indent) const {
  std::string out;
  DumpTo(&out, indent, 0);
  out.push_back('\n');
  return out;
}

namespace {
void Escape(std::string* out, const std::string& s) {
  out->push_back('"');
  for (unsigned char c : s) {
    switch (c) {
      case '"': out->append("\\\""); break;
      case '\\': out->append("\\\\"); break;
      case '\n': out->append("\\n"); break;
      case '\t': out->append("\\t"); break;
      case '\r': out->append("\\r"); break;
      default:
        if (c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out->append(buf);
        } else {
          out->push_back(static_cast<char>(c));
        }
    }
  }
  out->push_back('"');
}
}  // namespace

void Json::DumpTo(std::string* out, int indent, int depth) const {
  const auto newline = [&](int d) {
    if (indent <= 0) return;
    out->push_back('\n');
    out->append(static_cast<std::size_t>(indent) * static_cast<std::size_t>(d), ' ');
  };
  switch (kind_) {
    case Kind::kNull: out->append("null"); break;
    case Kind::kBool: out->append(boolean_ ? "true" : "false"); break;
    case Kind::kNumber: {
      if (!std::isfinite(number_)) {
        out->append("null");
        break;
      }
      char buf[64];
      const auto r = std::to_chars(buf, buf + sizeof buf, number_);
      out->append(buf, r.ptr);
      break;
    }
    case Kind::kString: Escape(out, string_); break;
    case Kind::kArray:
    case Kind::kObject: {
      const bool obj = kind_ == Kind::kObject;
      out->push_back(obj ? '{' : '[');
      for (std::size_t i = 0; i < items_.size(); ++i) {
        if (i) out->push_back(',');
        newline(depth + 1);
        if (obj) {
          Escape(out, keys_[i]);
          out->append(indent > 0 ? ": " : ":");
        }
        items_[i].DumpTo(out, indent, depth + 1);
      }
      if (!items_.empty()) newline(depth);
      out->push_back(obj ? '}' : ']');
      break;
    }
  }
}

}  // namespace fesim
