#include "base/trial.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>

namespace fesim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;

std::string Trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

/// Splits a line at commas into `out` (reused between lines to spare allocations), cells trimmed.
void SplitComma(const std::string& line, std::vector<std::string>* out) {
  std::size_t n = 0, begin = 0;
  while (true) {
    const std::size_t comma = std::min(line.find(',', begin), line.size());
    std::size_t b = begin, e = comma;
    while (b < e && (line[b] == ' ' || line[b] == '\t' || line[b] == '\r')) ++b;
    while (e > b && (line[e - 1] == ' ' || line[e - 1] == '\t' || line[e - 1] == '\r')) --e;
    if (n == out->size()) out->emplace_back();
    (*out)[n++].assign(line, b, e - b);
    if (comma == line.size()) break;
    begin = comma + 1;
  }
  out->resize(n);
}

/// A cell or name as shown in an error message (one short line whatever the file holds).
std::string Shown(const std::string& s) { return ShownInMessage(s); }

[[noreturn]] void Fail(const std::string& source, std::size_t line, const std::string& what) {
  throw std::runtime_error(source + ":" + std::to_string(line) + ": " + what);
}

/// Parses one cell; empty or "nan" gives NaN. Returns false when the cell is not a number.
bool ParseCell(const std::string& cell, double* value) {
  if (cell.empty() || cell == "nan" || cell == "NaN" || cell == "NAN") {
    *value = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  const char* begin = cell.data();
  const char* end = cell.data() + cell.size();
  if (*begin == '+') ++begin;
  const auto r = std::from_chars(begin, end, *value);
  return r.ec == std::errc() && r.ptr == end;
}

void AppendNumber(std::string* out, double v) {
  if (std::isnan(v)) {
    out->append("nan");
    return;
  }
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out->append(buf, r.ptr);
}

}  // namespace

bool Trial::Has(const std::string& name) const {
  return std::find(names.begin(), names.end(), name) != names.end();
}

const std::vector<double>& Trial::Column(const std::string& name) const {
  const auto it = std::find(names.begin(), names.end(), name);
  if (it == names.end()) throw std::out_of_range("trial has no column '" + name + "'");
  return columns[it - names.begin()];
}

std::vector<double>& Trial::MutableColumn(const std::string& name) {
  return const_cast<std::vector<double>&>(static_cast<const Trial*>(this)->Column(name));
}

void Trial::AddColumn(const std::string& name, std::vector<double> values) {
  if (name == "time" || Has(name)) throw std::invalid_argument("duplicate column '" + name + "'");
  if (values.size() != time.size()) {
    throw std::invalid_argument("column '" + name + "' has " + std::to_string(values.size()) +
                                " values, time has " + std::to_string(time.size()));
  }
  names.push_back(name);
  columns.push_back(std::move(values));
}

std::vector<std::string> Trial::NamesWithPrefix(const std::string& prefix) const {
  std::vector<std::string> out;
  for (const auto& n : names) {
    if (n.compare(0, prefix.size(), prefix) == 0) out.push_back(n);
  }
  return out;
}

Trial ParseTrialCsv(const std::string& text, const std::string& source) {
  Trial trial;
  std::string line;
  std::size_t line_no = 0;
  bool have_header = false;
  std::vector<bool> in_degrees;
  std::vector<std::string> cells;
  std::vector<char> unit;  // 'u': pulse width in [0, 300] µs; 'q': angle in rad; 0: unchecked
  // Lines are cut from `text` directly (no stream copy): a large file costs its text once.
  // A leading UTF-8 byte order mark is skipped (it would make the header 'time' look unequal
  // to 'time').
  const std::size_t start = text.rfind("\xEF\xBB\xBF", 0) == 0 ? 3 : 0;
  for (std::size_t pos = start; pos < text.size();) {
    std::size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) eol = text.size();
    line.assign(text, pos, eol - pos);
    pos = eol + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (Trim(line).empty()) continue;
    if (line[0] == '#') {
      if (have_header) Fail(source, line_no, "comment line after the header");
      const std::string body = Trim(line.substr(1));
      const auto colon = body.find(':');
      if (colon == std::string::npos) continue;  // free comment
      trial.metadata[Trim(body.substr(0, colon))] = Trim(body.substr(colon + 1));
      continue;
    }
    SplitComma(line, &cells);
    if (!have_header) {
      if (cells.empty() || cells[0] != "time") {
        Fail(source, line_no,
             "header must start with column 'time', found '" +
                 Shown(cells.empty() ? std::string() : cells[0]) + "'");
      }
      for (std::size_t k = 1; k < cells.size(); ++k) {
        std::string name = cells[k];
        if (name.empty()) Fail(source, line_no, "column " + std::to_string(k + 1) + " has no name");
        bool deg = false;
        if (name.size() > 4 && name.compare(name.size() - 4, 4, "_deg") == 0) {
          name = Trim(name.substr(0, name.size() - 4));
          deg = true;
          if (name.empty())
            Fail(source, line_no, "column " + Shown(cells[k]) + ": no name before _deg");
          if (name.size() > 4 && name.compare(name.size() - 4, 4, "_deg") == 0) {
            Fail(source, line_no, "column " + Shown(cells[k]) + ": suffix _deg given twice");
          }
        }
        for (const char c : name) {
          if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
            Fail(source, line_no,
                 "column " + std::to_string(k + 1) + ": name contains a control character");
          }
        }
        if (name == "time" || trial.Has(name)) {
          Fail(source, line_no, "column " + Shown(cells[k]) + ": duplicate column name");
        }
        trial.names.push_back(name);
        in_degrees.push_back(deg);
        unit.push_back(name.rfind("u.", 0) == 0 ? 'u' : name.rfind("q.", 0) == 0 ? 'q' : 0);
      }
      trial.columns.resize(trial.names.size());
      have_header = true;
      continue;
    }
    if (cells.size() != trial.names.size() + 1) {
      Fail(source, line_no,
           "expected " + std::to_string(trial.names.size() + 1) + " cells, found " +
               std::to_string(cells.size()));
    }
    double t = 0.0;
    if (!ParseCell(cells[0], &t) || !std::isfinite(t)) {
      Fail(source, line_no, "column time: '" + Shown(cells[0]) + "' is not a finite number");
    }
    if (!trial.time.empty() && !(t > trial.time.back())) {
      Fail(source, line_no,
           "column time: " + Shown(cells[0]) + " is not greater than the previous time");
    }
    trial.time.push_back(t);
    for (std::size_t k = 0; k < trial.names.size(); ++k) {
      double v = 0.0;
      if (!ParseCell(cells[k + 1], &v) || std::isinf(v)) {
        Fail(source, line_no,
             "column " + Shown(trial.names[k]) + ": '" + Shown(cells[k + 1]) + "' is not a number");
      }
      if (in_degrees[k]) v *= kDegToRad;
      // Wrong units: a pulse width outside 0–300 µs (ms or ns?) or an angle beyond a full turn
      // (degrees without the _deg suffix?).
      if (unit[k] == 'u' && !(std::isnan(v) || (v >= 0.0 && v <= 300.0))) {
        Fail(source, line_no,
             "column " + Shown(trial.names[k]) + ": " + Shown(cells[k + 1]) +
                 " is outside [0, 300] (pulse width in µs)");
      }
      if (unit[k] == 'q' && std::abs(v) > 2.0 * kPi) {
        Fail(source, line_no,
             "column " + Shown(trial.names[k]) + ": " + Shown(cells[k + 1]) +
                 (in_degrees[k] ? " is beyond a full turn"
                                : " is beyond a full turn (angles are in rad; degrees need the "
                                  "suffix _deg)"));
      }
      trial.columns[k].push_back(v);
    }
  }
  if (!have_header) Fail(source, line_no, "no header row (expected 'time,...')");
  if (trial.time.empty()) Fail(source, line_no, "no data rows");
  return trial;
}

Trial ReadTrialCsv(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode) &&
      static_cast<std::uint64_t>(st.st_size) > kMaxTrialFileBytes) {
    char size[32];
    std::snprintf(size, sizeof size, "%.1f GiB", st.st_size / 1073741824.0);
    throw std::runtime_error(path + ": " + size +
                             " is larger than the 4 GiB limit for a trial file (loading takes "
                             "about 1.5 times its size in memory); split the trial");
  }
  return ParseTrialCsv(ReadFile(path), path);
}

std::string FormatTrialCsv(const Trial& trial) {
  std::string out;
  for (const auto& [k, v] : trial.metadata) out += "# " + k + ": " + v + "\n";
  out += "time";
  for (const auto& n : trial.names) out += "," + n;
  out += "\n";
  for (std::size_t i = 0; i < trial.size(); ++i) {
    AppendNumber(&out, trial.time[i]);
    for (const auto& c : trial.columns) {
      out.push_back(',');
      AppendNumber(&out, c[i]);
    }
    out.push_back('\n');
  }
  return out;
}

std::string FormatTrialSto(const Trial& trial, const std::string& name) {
  std::string out = name + "\nversion=1\nnRows=" + std::to_string(trial.size()) +
                    "\nnColumns=" + std::to_string(trial.names.size() + 1) + "\ninDegrees=no\n";
  for (const auto& [k, v] : trial.metadata) out += "# " + k + ": " + v + "\n";
  out += "endheader\ntime";
  for (const auto& n : trial.names) out += "\t" + n;
  out += "\n";
  for (std::size_t i = 0; i < trial.size(); ++i) {
    AppendNumber(&out, trial.time[i]);
    for (const auto& c : trial.columns) {
      out.push_back('\t');
      AppendNumber(&out, c[i]);
    }
    out.push_back('\n');
  }
  return out;
}

namespace {
// Registered temporary files (see RegisterTempFile); a slot is free when its first byte is 0.
// The mutex orders registrations between threads; handlers only read.
char g_registered_tmp[kMaxRegisteredTempFiles][4096] = {};
std::mutex g_registered_mutex;
}  // namespace

int RegisterTempFile(const std::string& path) {
  if (path.empty() || path.size() >= sizeof g_registered_tmp[0]) return -1;
  std::lock_guard<std::mutex> lock(g_registered_mutex);
  for (int k = 0; k < kMaxRegisteredTempFiles; ++k) {
    char* slot = g_registered_tmp[k];
    if (slot[0] != '\0') continue;
    // The terminating NUL first, the first byte last: a signal handler interrupting the update
    // sees either "" or a complete name.
    std::memcpy(slot + 1, path.c_str() + 1, path.size());
    std::atomic_signal_fence(std::memory_order_seq_cst);
    slot[0] = path[0];
    return k;
  }
  return -1;
}

void UnregisterTempFile(int slot) {
  if (slot < 0 || slot >= kMaxRegisteredTempFiles) return;
  std::lock_guard<std::mutex> lock(g_registered_mutex);
  g_registered_tmp[slot][0] = '\0';
}

const char* RegisteredTempFile(int slot) {
  if (slot < 0 || slot >= kMaxRegisteredTempFiles) return "";
  return g_registered_tmp[slot];
}

std::string TempSuffixHost() {
  // MPI ranks on several hosts may write the same file (identical contents) on a shared file
  // system, with equal pids: the host name keeps their temporary files apart.
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) != 0) return "host";
  std::string h(host);
  for (char& c : h) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '.') c = '_';
  }
  return h.empty() ? "host" : h;
}

void WriteFileAtomic(const std::string& path, const std::string& contents) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid()) + "." + TempSuffixHost();
  // Registered for the SIGINT/SIGTERM handler while it exists (several threads may write).
  struct Registration {
    int slot;
    ~Registration() { UnregisterTempFile(slot); }
  } registration{RegisterTempFile(tmp)};
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (f == nullptr) {
    const int err = errno;
    throw std::runtime_error(path + ": cannot open for writing: " + std::strerror(err));
  }
  const bool ok = std::fwrite(contents.data(), 1, contents.size(), f) == contents.size() &&
                  std::fflush(f) == 0 && ::fsync(::fileno(f)) == 0;
  const int write_err = errno;
  const bool closed = std::fclose(f) == 0;
  if (!ok || !closed) {
    const int err = ok ? errno : write_err;
    std::remove(tmp.c_str());
    throw std::runtime_error(path + ": write failed: " + std::strerror(err));
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    std::remove(tmp.c_str());
    throw std::runtime_error(path +
                             ": cannot rename temporary file into place: " + std::strerror(err));
  }
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open for reading: " + std::strerror(errno));
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
    throw std::runtime_error(path + ": cannot open for reading: is a directory");
  }
  // Read in blocks straight into the result (a stream copy would double the peak memory of a
  // large file, docs/reliability.md).
  std::string text;
  if (S_ISREG(st.st_mode) && st.st_size > 0) text.reserve(static_cast<std::size_t>(st.st_size));
  char buf[1 << 16];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) text.append(buf, in.gcount());
  if (in.bad()) throw std::runtime_error(path + ": read error: " + std::strerror(errno));
  return text;
}

std::string ShownInMessage(const std::string& bytes) {
  constexpr std::size_t kMaxShown = 40;
  const std::size_t end = std::min(bytes.size(), kMaxShown);
  std::string out;
  for (std::size_t i = 0; i < end;) {
    const auto b = static_cast<unsigned char>(bytes[i]);
    // Length of the UTF-8 sequence this byte starts (0: not a lead byte; C0, C1 and F5-FF
    // never start a valid sequence).
    const std::size_t len = b < 0x80                ? 1
                            : b >= 0xc2 && b < 0xe0 ? 2
                            : b >= 0xe0 && b < 0xf0 ? 3
                            : b >= 0xf0 && b < 0xf5 ? 4
                                                    : 0;
    bool ok = len > 0 && i + len <= end && !(len == 1 && (b < 0x20 || b == 0x7f));
    for (std::size_t k = 1; ok && k < len; ++k) {
      ok = (static_cast<unsigned char>(bytes[i + k]) & 0xc0) == 0x80;
    }
    if (ok) {
      out.append(bytes, i, len);
      i += len;
      continue;
    }
    char buf[8];
    std::snprintf(buf, sizeof buf, "\\x%02x", b);
    out += buf;
    ++i;
  }
  if (bytes.size() > kMaxShown) out += "...";
  return out;
}

std::string Fnv1a64Hex(const std::string& bytes) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 1099511628211ull;
  }
  static const char kHex[] = "0123456789abcdef";
  std::string out(16, '0');
  for (int k = 15; k >= 0; --k, h >>= 4) out[static_cast<std::size_t>(k)] = kHex[h & 15];
  return out;
}

}  // namespace fesim
