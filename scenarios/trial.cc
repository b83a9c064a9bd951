#include "scenarios/trial.h"

#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace fesim {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

std::string Trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

std::vector<std::string> SplitComma(const std::string& line) {
  std::vector<std::string> out;
  std::string cell;
  for (char c : line) {
    if (c == ',') {
      out.push_back(Trim(cell));
      cell.clear();
    } else {
      cell.push_back(c);
    }
  }
  out.push_back(Trim(cell));
  return out;
}

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
  std::istringstream in(text);
  std::string line;
  std::size_t line_no = 0;
  bool have_header = false;
  std::vector<bool> in_degrees;
  while (std::getline(in, line)) {
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
    const auto cells = SplitComma(line);
    if (!have_header) {
      if (cells.empty() || cells[0] != "time") {
        Fail(source, line_no, "header must start with column 'time', found '" +
                                  (cells.empty() ? std::string() : cells[0]) + "'");
      }
      for (std::size_t k = 1; k < cells.size(); ++k) {
        std::string name = cells[k];
        if (name.empty()) Fail(source, line_no, "column " + std::to_string(k + 1) + " has no name");
        bool deg = false;
        if (name.size() > 4 && name.compare(name.size() - 4, 4, "_deg") == 0) {
          name = name.substr(0, name.size() - 4);
          deg = true;
        }
        if (name == "time" || trial.Has(name)) {
          Fail(source, line_no, "column " + cells[k] + ": duplicate column name");
        }
        trial.names.push_back(name);
        in_degrees.push_back(deg);
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
      Fail(source, line_no, "column time: '" + cells[0] + "' is not a finite number");
    }
    if (!trial.time.empty() && !(t > trial.time.back())) {
      Fail(source, line_no, "column time: " + cells[0] + " is not greater than the previous time");
    }
    trial.time.push_back(t);
    for (std::size_t k = 0; k < trial.names.size(); ++k) {
      double v = 0.0;
      if (!ParseCell(cells[k + 1], &v) || std::isinf(v)) {
        Fail(source, line_no,
             "column " + trial.names[k] + ": '" + cells[k + 1] + "' is not a number");
      }
      trial.columns[k].push_back(in_degrees[k] ? v * kDegToRad : v);
    }
  }
  if (!have_header) Fail(source, line_no, "no header row (expected 'time,...')");
  if (trial.time.empty()) Fail(source, line_no, "no data rows");
  return trial;
}

Trial ReadTrialCsv(const std::string& path) { return ParseTrialCsv(ReadFile(path), path); }

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

void WriteFileAtomic(const std::string& path, const std::string& contents) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (f == nullptr) throw std::runtime_error(path + ": cannot open for writing");
  const bool ok = std::fwrite(contents.data(), 1, contents.size(), f) == contents.size() &&
                  std::fflush(f) == 0 && ::fsync(::fileno(f)) == 0;
  const bool closed = std::fclose(f) == 0;
  if (!ok || !closed) {
    std::remove(tmp.c_str());
    throw std::runtime_error(path + ": write failed (disk full?)");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error(path + ": cannot rename temporary file into place");
  }
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open for reading");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw std::runtime_error(path + ": read error");
  return ss.str();
}

}  // namespace fesim
