#include "base/json.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

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
      case '"':
        out->append("\\\"");
        break;
      case '\\':
        out->append("\\\\");
        break;
      case '\n':
        out->append("\\n");
        break;
      case '\t':
        out->append("\\t");
        break;
      case '\r':
        out->append("\\r");
        break;
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
    case Kind::kNull:
      out->append("null");
      break;
    case Kind::kBool:
      out->append(boolean_ ? "true" : "false");
      break;
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
    case Kind::kString:
      Escape(out, string_);
      break;
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

double Json::AsNumber() const {
  if (kind_ == Kind::kNull) return std::nan("");
  if (kind_ != Kind::kNumber) throw std::runtime_error("json: expected a number");
  return number_;
}

const std::string& Json::AsString() const {
  if (kind_ != Kind::kString) throw std::runtime_error("json: expected a string");
  return string_;
}

bool Json::AsBool() const {
  if (kind_ != Kind::kBool) throw std::runtime_error("json: expected true or false");
  return boolean_;
}

const Json* Json::Find(const std::string& key) const {
  if (kind_ != Kind::kObject) return nullptr;
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    if (keys_[i] == key) return &items_[i];
  }
  return nullptr;
}

namespace {

/// Recursive-descent reader over the text; depth-limited so hostile input cannot overflow the
/// stack.
class JsonReader {
 public:
  JsonReader(const std::string& text, const std::string& what) : s_(text), what_(what) {}

  Json Document() {
    Json v = Value(0);
    SkipSpace();
    if (i_ != s_.size()) Fail("unexpected data after the value");
    return v;
  }

 private:
  static constexpr int kMaxDepth = 256;

  [[noreturn]] void Fail(const std::string& why) const {
    throw std::runtime_error(what_ + ": byte " + std::to_string(i_) + ": " + why);
  }
  void SkipSpace() {
    while (i_ < s_.size() &&
           (s_[i_] == ' ' || s_[i_] == '\t' || s_[i_] == '\n' || s_[i_] == '\r')) {
      ++i_;
    }
  }
  bool Literal(const char* word) {
    const std::size_t n = std::char_traits<char>::length(word);
    if (s_.compare(i_, n, word) != 0) return false;
    i_ += n;
    return true;
  }
  Json Value(int depth) {
    if (depth > kMaxDepth) Fail("nesting deeper than 256");
    SkipSpace();
    if (i_ >= s_.size()) Fail("unexpected end of text");
    const char c = s_[i_];
    if (c == '{') return Object(depth);
    if (c == '[') return Array(depth);
    if (c == '"') return Json(String());
    if (Literal("true")) return Json(true);
    if (Literal("false")) return Json(false);
    if (Literal("null")) return Json();
    return Json(Number());
  }
  Json Object(int depth) {
    Json obj = Json::Object();
    ++i_;
    SkipSpace();
    if (i_ < s_.size() && s_[i_] == '}') {
      ++i_;
      return obj;
    }
    for (;;) {
      SkipSpace();
      if (i_ >= s_.size() || s_[i_] != '"') Fail("expected a member name");
      std::string key = String();
      SkipSpace();
      if (i_ >= s_.size() || s_[i_] != ':') Fail("expected ':'");
      ++i_;
      obj.Set(key, Value(depth + 1));
      SkipSpace();
      if (i_ < s_.size() && s_[i_] == ',') {
        ++i_;
        continue;
      }
      if (i_ < s_.size() && s_[i_] == '}') {
        ++i_;
        return obj;
      }
      Fail("expected ',' or '}'");
    }
  }
  Json Array(int depth) {
    Json arr = Json::Array();
    ++i_;
    SkipSpace();
    if (i_ < s_.size() && s_[i_] == ']') {
      ++i_;
      return arr;
    }
    for (;;) {
      arr.Push(Value(depth + 1));
      SkipSpace();
      if (i_ < s_.size() && s_[i_] == ',') {
        ++i_;
        continue;
      }
      if (i_ < s_.size() && s_[i_] == ']') {
        ++i_;
        return arr;
      }
      Fail("expected ',' or ']'");
    }
  }
  static void AppendUtf8(unsigned code, std::string* out) {
    if (code < 0x80) {
      out->push_back(static_cast<char>(code));
    } else if (code < 0x800) {
      out->push_back(static_cast<char>(0xC0 | (code >> 6)));
      out->push_back(static_cast<char>(0x80 | (code & 0x3F)));
    } else {
      out->push_back(static_cast<char>(0xE0 | (code >> 12)));
      out->push_back(static_cast<char>(0x80 | ((code >> 6) & 0x3F)));
      out->push_back(static_cast<char>(0x80 | (code & 0x3F)));
    }
  }
  std::string String() {
    ++i_;  // opening quote
    std::string out;
    while (i_ < s_.size()) {
      const unsigned char c = static_cast<unsigned char>(s_[i_++]);
      if (c == '"') return out;
      if (c < 0x20) Fail("control character in a string");
      if (c != '\\') {
        out.push_back(static_cast<char>(c));
        continue;
      }
      if (i_ >= s_.size()) break;
      const char e = s_[i_++];
      switch (e) {
        case '"':
          out.push_back('"');
          break;
        case '\\':
          out.push_back('\\');
          break;
        case '/':
          out.push_back('/');
          break;
        case 'b':
          out.push_back('\b');
          break;
        case 'f':
          out.push_back('\f');
          break;
        case 'n':
          out.push_back('\n');
          break;
        case 'r':
          out.push_back('\r');
          break;
        case 't':
          out.push_back('\t');
          break;
        case 'u': {
          if (i_ + 4 > s_.size()) Fail("truncated \\u escape");
          unsigned code = 0;
          for (int k = 0; k < 4; ++k) {
            const char h = s_[i_++];
            code <<= 4;
            if (h >= '0' && h <= '9')
              code |= static_cast<unsigned>(h - '0');
            else if (h >= 'a' && h <= 'f')
              code |= static_cast<unsigned>(h - 'a' + 10);
            else if (h >= 'A' && h <= 'F')
              code |= static_cast<unsigned>(h - 'A' + 10);
            else
              Fail("bad hex digit in \\u escape");
          }
          AppendUtf8(code, &out);
          break;
        }
        default:
          Fail("bad escape in a string");
      }
    }
    Fail("unterminated string");
  }
  double Number() {
    const std::size_t start = i_;
    if (i_ < s_.size() && s_[i_] == '-') ++i_;
    const auto digits = [&] {
      const std::size_t d = i_;
      while (i_ < s_.size() && s_[i_] >= '0' && s_[i_] <= '9') ++i_;
      return i_ > d;
    };
    if (!digits()) Fail("expected a value");
    if (i_ < s_.size() && s_[i_] == '.') {
      ++i_;
      if (!digits()) Fail("expected digits after '.'");
    }
    if (i_ < s_.size() && (s_[i_] == 'e' || s_[i_] == 'E')) {
      ++i_;
      if (i_ < s_.size() && (s_[i_] == '+' || s_[i_] == '-')) ++i_;
      if (!digits()) Fail("expected exponent digits");
    }
    double v = 0.0;
    const auto r = std::from_chars(s_.data() + start, s_.data() + i_, v);
    if (r.ec != std::errc() || r.ptr != s_.data() + i_) {
      i_ = start;
      Fail("number out of range");
    }
    return v;
  }

  const std::string& s_;
  const std::string& what_;
  std::size_t i_ = 0;
};

}  // namespace

Json Json::Parse(const std::string& text, const std::string& what) {
  return JsonReader(text, what).Document();
}

}  // namespace fesim
