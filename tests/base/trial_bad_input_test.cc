// Issue 10: every class of bad trial CSV input fails with a one-line message naming the file, the
// line and the column; fuzzer findings (fuzz/fuzz_trial_csv.cc) are kept here as regressions.
#include <dirent.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "base/trial.h"

namespace fesim {
namespace {

/// No WriteFileAtomic left its temporary file registered for the signal handler.
void ExpectNoRegisteredTempFile() {
  for (int k = 0; k < kMaxRegisteredTempFiles; ++k) EXPECT_STREQ(RegisteredTempFile(k), "") << k;
}

std::string ErrorOf(const std::string& text) {
  try {
    ParseTrialCsv(text, "x.csv");
  } catch (const std::runtime_error& e) {
    std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << "not one line: " << what;
    return what;
  }
  return "(no error)";
}

TEST(TrialBadInput, FileOverTheSizeLimitIsRefusedBeforeReading) {
  // A sparse file: 5 GiB long, no disk blocks, never read.
  const std::string path = ::testing::TempDir() + "huge_sparse.csv";
  FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr);
  ASSERT_EQ(::ftruncate(::fileno(f), static_cast<off_t>(5ull << 30)), 0);
  std::fclose(f);
  try {
    ReadTrialCsv(path);
    ADD_FAILURE() << "accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path + ": 5.0 GiB is larger than the 4 GiB limit"),
              std::string::npos)
        << e.what();
  }
  std::remove(path.c_str());
}

TEST(TrialBadInput, MalformedNumbers) {
  EXPECT_EQ(ErrorOf("time,q.a\n0,1.2.3\n"), "x.csv:2: column q.a: '1.2.3' is not a number");
  EXPECT_EQ(ErrorOf("time,q.a\n0,1e\n"), "x.csv:2: column q.a: '1e' is not a number");
  EXPECT_EQ(ErrorOf("time,q.a\n0,0x10\n"), "x.csv:2: column q.a: '0x10' is not a number");
  EXPECT_EQ(ErrorOf("time,q.a\n0,--1\n"), "x.csv:2: column q.a: '--1' is not a number");
  EXPECT_EQ(ErrorOf("time,q.a\n0,1 2\n"), "x.csv:2: column q.a: '1 2' is not a number");
  EXPECT_EQ(ErrorOf("time,q.a\nzero,1\n"), "x.csv:2: column time: 'zero' is not a finite number");
  // A decimal comma (German locale) shows up as a wrong cell count.
  EXPECT_EQ(ErrorOf("time,q.a\n0,0,5\n"), "x.csv:2: expected 2 cells, found 3");
}

TEST(TrialBadInput, WrongColumnCounts) {
  EXPECT_EQ(ErrorOf("time,q.a,q.b\n0,1\n"), "x.csv:2: expected 3 cells, found 2");
  EXPECT_EQ(ErrorOf("time,q.a\n0,1\n1,2,3,4\n"), "x.csv:3: expected 2 cells, found 4");
  EXPECT_EQ(ErrorOf("time,,q.b\n0,1,2\n"), "x.csv:1: column 2 has no name");
}

TEST(TrialBadInput, DuplicateColumns) {
  EXPECT_EQ(ErrorOf("time,q.a,q.a_deg\n0,1,2\n"), "x.csv:1: column q.a_deg: duplicate column name");
  EXPECT_EQ(ErrorOf("time,q.a,time\n0,1,2\n"), "x.csv:1: column time: duplicate column name");
}

TEST(TrialBadInput, NonMonotonicOrRepeatedTime) {
  EXPECT_EQ(ErrorOf("time,q.a\n0,1\n1,1\n0.5,1\n"),
            "x.csv:4: column time: 0.5 is not greater than the previous time");
  EXPECT_EQ(ErrorOf("# a: b\ntime,q.a\n0,1\n\n0,1\n"),
            "x.csv:5: column time: 0 is not greater than the previous time");
}

TEST(TrialBadInput, NanAndInf) {
  EXPECT_EQ(ErrorOf("time,q.a\nnan,1\n"), "x.csv:2: column time: 'nan' is not a finite number");
  EXPECT_EQ(ErrorOf("time,q.a\n,1\n"), "x.csv:2: column time: '' is not a finite number");
  EXPECT_EQ(ErrorOf("time,q.a\ninf,1\n"), "x.csv:2: column time: 'inf' is not a finite number");
  EXPECT_EQ(ErrorOf("time,q.a\n0,-inf\n"), "x.csv:2: column q.a: '-inf' is not a number");
  EXPECT_EQ(ErrorOf("time,q.a\n0,Infinity\n"), "x.csv:2: column q.a: 'Infinity' is not a number");
  EXPECT_EQ(ErrorOf("time,q.a\n0,1e999\n"), "x.csv:2: column q.a: '1e999' is not a number");
  // NaN in a data column is a tracker dropout and allowed.
  EXPECT_TRUE(std::isnan(ParseTrialCsv("time,q.a\n0,NaN\n", "m").Column("q.a")[0]));
}

TEST(TrialBadInput, EmptyFiles) {
  EXPECT_EQ(ErrorOf(""), "x.csv:0: no header row (expected 'time,...')");
  EXPECT_EQ(ErrorOf("\n\n  \n"), "x.csv:3: no header row (expected 'time,...')");
  EXPECT_EQ(ErrorOf("# only: metadata\n"), "x.csv:1: no header row (expected 'time,...')");
  EXPECT_EQ(ErrorOf("time\n"), "x.csv:1: no data rows");
  // Binary junk: control bytes are shown escaped, so the message stays one printable line.
  EXPECT_EQ(ErrorOf(std::string("\0\0\r\x01,", 5)),
            "x.csv:1: header must start with column 'time', found '\\x00\\x00\\x0d\\x01'");
  // A huge first line is shown cut to 40 characters.
  EXPECT_EQ(
      ErrorOf(std::string(100000, 'x') + "\n"),
      "x.csv:1: header must start with column 'time', found '" + std::string(40, 'x') + "...'");
}

TEST(TrialBadInput, WrongUnits) {
  // Pulse widths in ms or ns instead of µs, and angles in degrees without the _deg suffix.
  EXPECT_EQ(ErrorOf("time,u.bic\n0,0\n0.025,350\n"),
            "x.csv:3: column u.bic: 350 is outside [0, 300] (pulse width in µs)");
  EXPECT_EQ(ErrorOf("time,u.bic\n0,-1\n"),
            "x.csv:2: column u.bic: -1 is outside [0, 300] (pulse width in µs)");
  EXPECT_EQ(ErrorOf("time,q.elbow\n0,90\n"),
            "x.csv:2: column q.elbow: 90 is beyond a full turn (angles are in rad; degrees need "
            "the suffix _deg)");
  EXPECT_EQ(ErrorOf("time,q.elbow_deg\n0,400\n"),
            "x.csv:2: column q.elbow: 400 is beyond a full turn");
  // In range: accepted, and the other prefixes are not unit-checked.
  const Trial t = ParseTrialCsv("time,u.bic,q.elbow_deg,tau.elbow\n0,300,-270,500\n", "m");
  EXPECT_EQ(t.Column("u.bic")[0], 300.0);
  EXPECT_NEAR(t.Column("q.elbow")[0], -1.5 * M_PI, 1e-12);
}

// Fuzzer finding 1 (fuzz_trial_csv, round-trip invariant): a `_deg` column whose name ends in
// carriage returns before the suffix kept them in the name, so the trial could not be written and
// read back. Names are now trimmed after the suffix (and control characters are rejected).
TEST(TrialBadInput, FuzzFinding1ControlCharactersInColumnName) {
  const std::string crash =
      "time,q.:a,q.\x9d\r\r\r\r\r\r\r\r\r\r\r\r\r\r\r\r\r\r\r\r\r\r\r\r\r_deg\n0,1,2\n";
  const Trial t = ParseTrialCsv(crash, "m");
  EXPECT_EQ(t.names, (std::vector<std::string>{"q.:a", "q.\x9d"}));
  const Trial back = ParseTrialCsv(FormatTrialCsv(t), "m");
  EXPECT_EQ(back.names, t.names);
  EXPECT_EQ(back.columns, t.columns);
  EXPECT_EQ(ErrorOf("time,q.\x01"
                    "a\n0,1\n"),
            "x.csv:1: column 2: name contains a control character");
  EXPECT_EQ(ParseTrialCsv("time,q.b  _deg\n0,1\n", "m").names, std::vector<std::string>{"q.b"});
}

// Fuzzer finding 2 (round-trip invariant): `q.a_deg_deg` became column `q.a_deg`, which the
// writer wrote back as `q.a_deg` and the reader then converted a second time.
TEST(TrialBadInput, FuzzFinding2DegreeSuffixTwice) {
  EXPECT_EQ(ErrorOf("time,.:\xff\xff\xff"
                    "a,q.a_deg_deg\n0,1,2"),
            "x.csv:1: column q.a_deg_deg: suffix _deg given twice");
}

// Issue 28: a UTF-8 byte order mark (some spreadsheet exports write one) is skipped; it used to
// give "header must start with column 'time', found 'time'" (the mark is invisible).
TEST(TrialBadInput, ByteOrderMarkIsSkipped) {
  const Trial t = ParseTrialCsv("\xEF\xBB\xBFtime,q.x\n0,1\n0.1,2\n", "x.csv");
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t.names, std::vector<std::string>{"q.x"});
}

// Issue 28: binary garbage is escaped byte by byte; valid UTF-8 (µ, é) is shown as it is.
TEST(TrialBadInput, NonPrintableAndInvalidUtf8BytesAreEscaped) {
  EXPECT_EQ(ErrorOf("\x89PNG\r\n\x1a\n\x00\x00"),
            "x.csv:1: header must start with column 'time', found '\\x89PNG'");
  EXPECT_EQ(ErrorOf("time,q.x\n0,\xff\xfe\x01\n"),
            "x.csv:2: column q.x: '\\xff\\xfe\\x01' is not a number");
  EXPECT_EQ(ErrorOf("time,q.x\n0,5\xc2\xb5s\n"),
            "x.csv:2: column q.x: '5\xc2\xb5s' is not a number");
  // A sequence cut short or an overlong lead byte is escaped, not passed on.
  EXPECT_EQ(ShownInMessage("a\xc3"), "a\\xc3");
  EXPECT_EQ(ShownInMessage("\xc0\xaf"), "\\xc0\\xaf");
  EXPECT_EQ(ShownInMessage(std::string(50, 'a')), std::string(40, 'a') + "...");
}

TEST(TrialBadInput, ReadTrialCsvNamesUnreadablePaths) {
  const std::string dir = ::testing::TempDir() + "trial_bad_input_dir";
  ::mkdir(dir.c_str(), 0755);
  try {
    ReadTrialCsv(dir + "/missing.csv");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              dir + "/missing.csv: cannot open for reading: No such file or directory");
  }
  // A directory given as the file.
  try {
    ReadTrialCsv(dir);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), dir + ": cannot open for reading: is a directory");
  }
}

TEST(AtomicWriteFaults, FailureLeavesNoFileAndNoTemporary) {
  const std::string dir = ::testing::TempDir() + "atomic_fault_dir";
  ::mkdir(dir.c_str(), 0755);
  std::remove((dir + "/ok.csv").c_str());  // from an earlier run
  // A directory sits where the file should go: the rename fails, the temporary is removed.
  ::mkdir((dir + "/out.csv").c_str(), 0755);
  EXPECT_THROW(WriteFileAtomic(dir + "/out.csv", "data"), std::runtime_error);
  ExpectNoRegisteredTempFile();
  DIR* d = ::opendir(dir.c_str());
  ASSERT_NE(d, nullptr);
  int entries = 0;
  while (const dirent* e = ::readdir(d)) {
    const std::string n = e->d_name;
    if (n == "." || n == "..") continue;
    ++entries;
    EXPECT_EQ(n, "out.csv");
  }
  ::closedir(d);
  EXPECT_EQ(entries, 1);
  ::rmdir((dir + "/out.csv").c_str());
  // Success unregisters it too.
  WriteFileAtomic(dir + "/ok.csv", "data");
  ExpectNoRegisteredTempFile();
  EXPECT_EQ(ReadFile(dir + "/ok.csv"), "data");
}

}  // namespace
TEST(WriteFileAtomic, WritesOfTwoThreadsAreBothRegisteredForTheSignalHandler) {
  // FIFOs at both temporary paths hold each writer in open() until a reader comes, so both
  // writes are in progress at once without depending on timing.
  const std::string dir = ::testing::TempDir() + "atomic_two_threads";
  ::mkdir(dir.c_str(), 0755);
  std::vector<std::string> tmps;
  for (const char* name : {"a.csv", "b.csv"}) {
    std::remove((dir + "/" + name).c_str());
    tmps.push_back(dir + "/" + name + ".tmp." + std::to_string(::getpid()) + "." +
                   TempSuffixHost());
    std::remove(tmps.back().c_str());
    ASSERT_EQ(::mkfifo(tmps.back().c_str(), 0600), 0);
  }
  // fsync() of a FIFO fails, so each write then throws and removes its temporary: the point
  // here is only that both were registered while in progress.
  const auto write = [&](const std::string& name) {
    try {
      WriteFileAtomic(dir + "/" + name, "x");
    } catch (const std::runtime_error&) {
    }
  };
  std::thread a(write, "a.csv");
  std::thread b(write, "b.csv");
  const auto registered = [](const std::string& path) {
    for (int k = 0; k < kMaxRegisteredTempFiles; ++k) {
      if (path == RegisteredTempFile(k)) return true;
    }
    return false;
  };
  for (int wait = 0; wait < 1000 && !(registered(tmps[0]) && registered(tmps[1])); ++wait) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_TRUE(registered(tmps[0]));
  EXPECT_TRUE(registered(tmps[1]));
  for (const auto& t : tmps) {  // release the writers: read what they write
    const int fd = ::open(t.c_str(), O_RDONLY);
    ASSERT_GE(fd, 0);
    char c = 0;
    EXPECT_EQ(::read(fd, &c, 1), 1);
    ::close(fd);
  }
  a.join();
  b.join();
  ExpectNoRegisteredTempFile();
}

}  // namespace fesim
