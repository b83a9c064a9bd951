#include "apps/cli.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace fesim::cli {

std::string Args::Get(const std::string& key, const std::string& fallback) const {
  const auto it = options.find(key);
  return it == options.end() ? fallback : it->second;
}

long Args::GetInt(const std::string& key, long fallback) const {
  const auto it = options.find(key);
  if (it == options.end()) return fallback;
  try {
    std::size_t pos = 0;
    const long v = std::stol(it->second, &pos);
    if (pos != it->second.size()) throw std::invalid_argument("");
    return v;
  } catch (const std::exception&) {
    throw std::runtime_error("option --" + key + ": '" + it->second + "' is not an integer");
  }
}

Args Parse(int argc, char** argv, int first, const std::vector<std::string>& flags,
           const std::vector<std::string>& valued) {
  Args a;
  for (int i = first; i < argc; ++i) {
    std::string s = argv[i];
    if (s.rfind("--", 0) != 0 || s == "--") {
      a.positional.push_back(s);
      continue;
    }
    std::string key = s.substr(2);
    std::string value;
    const auto eq = key.find('=');
    const bool inline_value = eq != std::string::npos;
    if (inline_value) {
      value = key.substr(eq + 1);
      key = key.substr(0, eq);
    }
    if (std::find(flags.begin(), flags.end(), key) != flags.end()) {
      a.options[key] = "";
    } else if (std::find(valued.begin(), valued.end(), key) != valued.end()) {
      if (!inline_value) {
        if (i + 1 >= argc) throw std::runtime_error("option --" + key + " needs a value");
        value = argv[++i];
      }
      a.options[key] = value;
    } else {
      throw std::runtime_error("unknown option --" + key + " (see --help)");
    }
  }
  return a;
}

std::string OutPath(const Args& args, const std::string& key, const std::string& fallback) {
  if (!args.Has(key)) return fallback;
  const std::string v = args.Get(key);
  if (v.empty())
    throw std::runtime_error("option --" + key + ": empty path (outputs need a place to go)");
  return v;
}

int Threads(const Args& args, int fallback) {
  if (!args.Has("threads")) return fallback;
  const long n = args.GetInt("threads", fallback);
  if (n < 1 || n > kMaxThreads) {
    throw std::runtime_error("option --threads: " + std::to_string(n) + " is outside [1, " +
                             std::to_string(kMaxThreads) + "]");
  }
  return static_cast<int>(n);
}

std::vector<std::string> SplitList(const std::string& s) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : s) {
    if (c == ',') {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else {
      cur.push_back(c);
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

void ShowProgress(double fraction, const std::string& stage) {
  // NaN would make the integer conversions below undefined: show it as 0.
  fraction = std::isnan(fraction) ? 0.0 : std::clamp(fraction, 0.0, 1.0);
  const int width = 30;
  const int filled = static_cast<int>(std::lround(fraction * width));
  std::fprintf(stderr, "\r[%.*s%*s] %3d%% %-40.40s", filled,
               "==============================", width - filled, "",
               static_cast<int>(std::lround(fraction * 100.0)), stage.c_str());
  if (fraction >= 1.0) std::fputc('\n', stderr);
  std::fflush(stderr);
}

}  // namespace fesim::cli
