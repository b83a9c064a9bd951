#include "apps/cli.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

namespace fesim::cli {
namespace {

/// A progress reporter writing to a memory buffer on a clock the test sets.
struct Captured {
  double now = 0.0;
  char* text = nullptr;
  std::size_t size = 0;
  std::FILE* out = open_memstream(&text, &size);

  ~Captured() {
    std::fclose(out);
    std::free(text);
  }
  Progress Make(ProgressOptions::Mode mode, int columns = 80) {
    ProgressOptions o;
    o.mode = mode;
    o.columns = columns;
    o.out = out;
    o.clock = [this] { return now; };
    o.time_of_day = [] { return std::string("12:00:00"); };
    return Progress(o);
  }
  std::string Text() {
    std::fflush(out);
    return std::string(text, size);
  }
};

int Count(const std::string& s, const std::string& what) {
  int n = 0;
  for (std::size_t at = s.find(what); at != std::string::npos; at = s.find(what, at + 1)) ++n;
  return n;
}

TEST(Cli, FormatDurationReadsAsSecondsMinutesOrHours) {
  EXPECT_EQ(FormatDuration(42.4), "42 s");
  EXPECT_EQ(FormatDuration(185.0), "3 min 05 s");
  EXPECT_EQ(FormatDuration(3720.0), "1 h 02 min");
  EXPECT_EQ(FormatDuration(-1.0), "0 s");
}

// Into a pipe or a file: plain lines, never a carriage return, at most one per 5 s (and the last).
TEST(Cli, ProgressIntoAFileIsTimeStampedLinesAtMostEveryFiveSeconds) {
  Captured c;
  const Progress p = c.Make(ProgressOptions::Mode::kLines);
  for (int k = 0; k <= 100; ++k) {  // one report per 0.5 s for 50 s
    c.now = 0.5 * k;
    p(k / 100.0, "item " + std::to_string(k));
  }
  const std::string s = c.Text();
  EXPECT_EQ(Count(s, "\r"), 0) << s;
  EXPECT_EQ(Count(s, "\n"), 11) << s;  // t = 0, 5, …, 45 s and the last at 50 s
  EXPECT_EQ(s.rfind("[12:00:00] 0 % item 0 (0 s elapsed)\n", 0), 0u) << s;
  EXPECT_NE(s.find("[12:00:00] 100 % item 100 (50 s elapsed)\n"), std::string::npos) << s;
}

// The pace is measured from the first report above 0: a slow start-up before it (a model build,
// the first item) does not inflate the ETA. Here 20 s of start-up, then 1 % per second.
TEST(Cli, TheEtaComesFromThePaceSinceTheFirstItem) {
  Captured c;
  const Progress p = c.Make(ProgressOptions::Mode::kLines);
  c.now = 20.0;
  p(0.01, "a");
  c.now = 30.0;
  p(0.11, "b");
  EXPECT_NE(c.Text().find("b (30 s elapsed, ETA 1 min 29 s)"), std::string::npos) << c.Text();
}

TEST(Cli, ALiveBarKeepsItsEtaWhateverTheLabelAndEndsWithANewline) {
  Captured c;
  const Progress p = c.Make(ProgressOptions::Mode::kBar, 80);
  c.now = 0.0;
  p(0.1, "x");
  c.now = 10.0;
  p(0.5, std::string(200, 'L'));
  const std::string s = c.Text();
  const std::string last = s.substr(s.rfind('\r') + 1);
  EXPECT_LE(last.size(), 79u) << last;
  EXPECT_NE(last.find("ETA 13 s"), std::string::npos) << last;  // 0.4 in 10 s, 0.5 left
  EXPECT_NE(last.find("LLL..."), std::string::npos) << last;
  c.now = 20.0;
  p(1.0, "done");
  p(1.0, "done");  // the end once
  EXPECT_EQ(Count(c.Text(), "\n"), 1);
  EXPECT_EQ(c.Text().back(), '\n');
}

TEST(Cli, QuietShowsNothing) {
  Captured c;
  const Progress p = c.Make(ProgressOptions::Mode::kQuiet);
  p(0.5, "half");
  p(1.0, "done");
  EXPECT_EQ(c.Text(), "");
  const char* argv[] = {"fesim", "simulate", "--quiet"};
  EXPECT_EQ(ProgressFor(Parse(3, const_cast<char**>(argv), 2, {"quiet"}, {})).mode,
            ProgressOptions::Mode::kQuiet);
}

}  // namespace
}  // namespace fesim::cli
