#include "apps/cli.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <mutex>
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

std::string FormatDuration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0.0) seconds = 0.0;
  const long s = std::lround(seconds);
  char buf[32];
  if (s < 60) {
    std::snprintf(buf, sizeof buf, "%ld s", s);
  } else if (s < 3600) {
    std::snprintf(buf, sizeof buf, "%ld min %02ld s", s / 60, s % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%ld h %02ld min", s / 3600, (s % 3600) / 60);
  }
  return buf;
}

ProgressOptions ProgressFor(const Args& args) {
  ProgressOptions o;
  if (args.Has("quiet")) {
    o.mode = ProgressOptions::Mode::kQuiet;
  } else if (isatty(fileno(stderr))) {
    o.mode = ProgressOptions::Mode::kBar;
    winsize w{};
    if (ioctl(fileno(stderr), TIOCGWINSZ, &w) == 0 && w.ws_col >= 40) o.columns = w.ws_col;
  }
  return o;
}

struct Progress::State {
  ProgressOptions options;
  std::mutex mutex;
  double start_s = 0.0;
  double anchor_s = NAN, anchor_fraction = 0.0;  ///< first report with a fraction above 0.
  double last_line_s = -INFINITY;
  bool done = false;

  double Now() const {
    if (options.clock) return options.clock();
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }
  std::string TimeOfDay() const {
    if (options.time_of_day) return options.time_of_day();
    const std::time_t t = std::time(nullptr);
    std::tm tm{};
    localtime_r(&t, &tm);
    char buf[16];
    std::strftime(buf, sizeof buf, "%H:%M:%S", &tm);
    return buf;
  }
  /// "ETA …" from the pace since the anchor, "" while it is not measured yet.
  std::string Eta(double now, double fraction) const {
    if (fraction >= 1.0) return "";
    const double done_since = fraction - anchor_fraction;
    const double elapsed = now - anchor_s;
    if (!std::isfinite(anchor_s) || done_since < 0.02 || elapsed < 1.0) return "";
    return "ETA " + FormatDuration(elapsed / done_since * (1.0 - fraction));
  }
  void Bar(double fraction, const std::string& stage, const std::string& eta) {
    constexpr int kBarWidth = 30;
    const int filled = static_cast<int>(std::lround(fraction * kBarWidth));
    const std::string tail = eta.empty() ? "" : "  " + eta;
    // "[bar] 100 % " is kBarWidth + 9 characters; one column kept free against auto-wrap.
    const int room =
        std::max(8, options.columns - 1 - (kBarWidth + 9) - static_cast<int>(tail.size()));
    std::string label = stage;
    if (static_cast<int>(label.size()) > room) label = label.substr(0, room - 3) + "...";
    std::fprintf(options.out, "\r[%.*s%*s] %3d %% %-*s%s", filled,
                 "==============================", kBarWidth - filled, "",
                 static_cast<int>(std::lround(fraction * 100.0)), room, label.c_str(),
                 tail.c_str());
    if (fraction >= 1.0) std::fputc('\n', options.out);
  }
  void Line(double now, double fraction, const std::string& stage, const std::string& eta) {
    std::string text = "[" + TimeOfDay() + "] " +
                       std::to_string(static_cast<int>(std::lround(fraction * 100.0))) + " % " +
                       stage + " (" + FormatDuration(now - start_s) + " elapsed" +
                       (eta.empty() ? "" : ", " + eta) + ")";
    std::fprintf(options.out, "%s\n", text.c_str());
    last_line_s = now;
  }
};

Progress::Progress(ProgressOptions options) : state_(std::make_shared<State>()) {
  state_->options = std::move(options);
  state_->start_s = state_->Now();
}

void Progress::operator()(double fraction, const std::string& stage) const {
  State& s = *state_;
  if (s.options.mode == ProgressOptions::Mode::kQuiet) return;
  // NaN would make the integer conversions undefined: show it as 0.
  fraction = std::isnan(fraction) ? 0.0 : std::clamp(fraction, 0.0, 1.0);
  const std::lock_guard<std::mutex> lock(s.mutex);
  if (s.done) return;  // one final line, however often the end is reported
  const double now = s.Now();
  if (!std::isfinite(s.anchor_s) && fraction > 0.0) {
    s.anchor_s = now;
    s.anchor_fraction = fraction;
  }
  const std::string eta = s.Eta(now, fraction);
  s.done = fraction >= 1.0;
  if (s.options.mode == ProgressOptions::Mode::kBar) {
    s.Bar(fraction, stage, eta);
  } else if (s.done || now - s.last_line_s >= s.options.line_interval_s) {
    s.Line(now, fraction, stage, eta);
  }
  std::fflush(s.options.out);
}

}  // namespace fesim::cli
