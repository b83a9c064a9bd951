// End-to-end tests of `fesim render` through the built binary (FESIM_BIN).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "base/trial.h"
#include "tests/testing/process.h"

namespace fesim {
namespace {

using ::fesim::test_util::FindProgram;
using ::fesim::test_util::RunCommand;

namespace fs = std::filesystem;

/// Movie of the MP4 test: size, rate and the trial span give the frame count.
constexpr int kWidth = 160;
constexpr int kHeight = 120;
constexpr int kFps = 10;
constexpr double kTrialSpan_s = 1.0;
constexpr int kExpectedFrames = 11;  // t = 0, 0.1, …, 1.0

std::string FesimBin() {
  const char* env = std::getenv("FESIM_BIN");
  return env != nullptr && *env != '\0' ? env : FESIM_BIN_PATH;
}

struct Result {
  int exit_code = -1;
  std::string err;
};

/// Runs `fesim ARGS` and returns its exit code and stderr.
Result RunFesim(const std::string& args, const fs::path& err_file) {
  const std::string cmd = FesimBin() + " " + args + " >/dev/null 2>'" + err_file.string() + "'";
  const int status = std::system(cmd.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ReadFile(err_file.string())};
}

/// A fresh directory per test, with inputs in in/ and outputs in out/.
class RenderCmdTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = fs::path(::testing::TempDir()) / (std::string("render_cmd_") + info->name());
    fs::remove_all(root_);
    fs::create_directories(root_ / "in");
    fs::create_directories(root_ / "out");
    scenario_ = (root_ / "in" / "sc.yaml").string();
    WriteFileAtomic(scenario_,
                    "name: render-test\n"
                    "coordinates: {shoulder_elv_plane: {initial_deg: 60}, "
                    "shoulder_elevation: {initial_deg: 40}}\n"
                    "stimulation: {duration_s: 1, type: constant, values_us: {ext: 100}}\n");
  }

  /// A trial over [0, kTrialSpan_s] at 50 Hz with the given q.* columns (elbow ramp 0 → 1.5 rad)
  /// plus u.ext, u.flex and a.BIC.
  std::string WriteTrial(const std::string& name, const std::vector<std::string>& q_names) {
    Trial t;
    const int n = 51;
    for (int i = 0; i < n; ++i) t.time.push_back(kTrialSpan_s * i / (n - 1));
    for (const auto& q : q_names) {
      std::vector<double> v(n);
      for (int i = 0; i < n; ++i) v[i] = 1.5 * i / (n - 1);
      t.AddColumn(q, v);
    }
    std::vector<double> u(n), a(n);
    for (int i = 0; i < n; ++i) {
      u[i] = 300.0 * i / (n - 1);
      a[i] = static_cast<double>(i) / (n - 1);
    }
    t.AddColumn("u.ext", u);
    t.AddColumn("u.flex", std::vector<double>(n, 50.0));
    t.AddColumn("a.BIC", a);
    std::string path = (root_ / "in" / name).string();
    WriteFileAtomic(path, FormatTrialCsv(t));
    return path;
  }

  std::vector<std::string> OutEntries() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(root_ / "out")) {
      names.push_back(e.path().filename().string());
    }
    return names;
  }

  /// Runs a command that must fail: non-zero exit, one stderr line containing `expected`,
  /// nothing in out/.
  void ExpectFailure(const std::string& args, const std::string& expected) {
    const Result r = RunFesim(args, root_ / "err.txt");
    EXPECT_NE(r.exit_code, 0) << args;
    std::string msg = r.err;
    while (!msg.empty() && (msg.front() == '\n' || msg.front() == '\r')) msg.erase(0, 1);
    while (!msg.empty() && (msg.back() == '\n' || msg.back() == '\r')) msg.pop_back();
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "more than one line: " << r.err;
    EXPECT_NE(msg.find(expected), std::string::npos) << "stderr: " << r.err;
    EXPECT_TRUE(OutEntries().empty()) << args;
  }

  fs::path root_;
  std::string scenario_;
};

TEST_F(RenderCmdTest, Mp4DecodesWithRequestedSizeRateAndFrameCount) {
  const std::string ffprobe = FindProgram("ffprobe");
  ASSERT_FALSE(ffprobe.empty()) << "ffprobe not found in PATH (apt-get install ffmpeg)";
  const std::string trial = WriteTrial("trial.csv", {"q.elbow_flexion", "q.wrist_flexion"});
  const std::string ghost = WriteTrial("ghost.csv", {"q.elbow_flexion"});
  const std::string movie = (root_ / "out" / "movie.mp4").string();
  const Result r =
      RunFesim("render " + trial + " --scenario " + scenario_ + " --out " + movie + " --width " +
                   std::to_string(kWidth) + " --height " + std::to_string(kHeight) + " --fps " +
                   std::to_string(kFps) + " --compare " + ghost,
               root_ / "err.txt");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(OutEntries(), std::vector<std::string>{"movie.mp4"});  // no temporary left
  const std::string probe =
      RunCommand(ffprobe + " -v error -select_streams v:0 -count_frames -show_entries " +
                 "stream=codec_name,width,height,r_frame_rate,nb_read_frames -of " +
                 "default=noprint_wrappers=1 '" + movie + "'");
  EXPECT_NE(probe.find("codec_name=h264"), std::string::npos) << probe;
  EXPECT_NE(probe.find("width=" + std::to_string(kWidth) + "\n"), std::string::npos) << probe;
  EXPECT_NE(probe.find("height=" + std::to_string(kHeight) + "\n"), std::string::npos) << probe;
  EXPECT_NE(probe.find("r_frame_rate=" + std::to_string(kFps) + "/1"), std::string::npos) << probe;
  EXPECT_NE(probe.find("nb_read_frames=" + std::to_string(kExpectedFrames) + "\n"),
            std::string::npos)
      << probe;
}

TEST_F(RenderCmdTest, InterruptedMp4LeavesNoTemporaryFile) {
  // A 120 s trial at 30 fps (3 600 frames) is still encoding when the signal arrives.
  Trial t;
  const int n = 1201;
  std::vector<double> q(n);
  for (int i = 0; i < n; ++i) {
    t.time.push_back(0.1 * i);
    q[i] = 0.5 + 0.5 * std::sin(0.05 * i);
  }
  t.AddColumn("q.elbow_flexion", q);
  const std::string trial = (root_ / "in" / "long.csv").string();
  WriteFileAtomic(trial, FormatTrialCsv(t));
  const std::string movie = (root_ / "out" / "movie.mp4").string();
  for (const int sig : {SIGINT, SIGTERM}) {
    const std::string cmd = "exec " + FesimBin() + " render " + trial + " --scenario " + scenario_ +
                            " --out " + movie + " --fps 30 >/dev/null 2>&1";
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      ::setpgid(0, 0);  // like a terminal's foreground job: ffmpeg gets the signal too
      ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    // Wait (at most 60 s) until the hidden temporary movie exists, then interrupt the group.
    bool seen = false;
    for (int k = 0; k < 600 && !seen; ++k) {
      for (const auto& name : OutEntries()) seen = seen || name.find(".tmp-") != std::string::npos;
      if (!seen) ::usleep(100000);
    }
    EXPECT_TRUE(seen) << "no temporary movie appeared";
    ::kill(-pid, sig);
    int status = 0;
    ::waitpid(pid, &status, 0);
    EXPECT_TRUE(WIFSIGNALED(status)) << "signal " << sig;
    EXPECT_TRUE(OutEntries().empty()) << "signal " << sig << ": " << OutEntries()[0];
  }
}

TEST_F(RenderCmdTest, FramesWritesOnePngPerFrame) {
  const std::string trial = WriteTrial("trial.csv", {"q.elbow_flexion"});
  const fs::path dir = root_ / "out" / "frames";
  // Odd sizes are fine for PNG; 5 fps over 1 s: 6 frames.
  const Result r = RunFesim("render " + trial + " --scenario " + scenario_ + " --frames " +
                                dir.string() + " --width 81 --height 61 --fps 5 --camera side",
                            root_ / "err.txt");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir)) files.push_back(e.path().filename().string());
  std::sort(files.begin(), files.end());
  ASSERT_EQ(files.size(), 6u);
  EXPECT_EQ(files.front(), "frame_000000.png");
  EXPECT_EQ(files.back(), "frame_000005.png");
  const std::string png = ReadFile((dir / files.front()).string());
  ASSERT_GT(png.size(), 24u);
  EXPECT_EQ(png.substr(1, 3), "PNG");
  // IHDR width and height, big-endian at bytes 16–23.
  const auto be32 = [&png](std::size_t at) {
    return (static_cast<unsigned char>(png[at]) << 24) |
           (static_cast<unsigned char>(png[at + 1]) << 16) |
           (static_cast<unsigned char>(png[at + 2]) << 8) | static_cast<unsigned char>(png[at + 3]);
  };
  EXPECT_EQ(be32(16), 81);
  EXPECT_EQ(be32(20), 61);
  // The elbow moves during the trial: first and last frames differ.
  EXPECT_NE(png, ReadFile((dir / files.back()).string()));
}

TEST_F(RenderCmdTest, BadInputIsAOneLineErrorAndLeavesNoOutput) {
  const std::string good = WriteTrial("good.csv", {"q.elbow_flexion"});
  const std::string no_q = WriteTrial("no_q.csv", {});
  const std::string unknown = WriteTrial("unknown.csv", {"q.elbow_flexion", "q.knee_flexion"});
  const std::string movie = (root_ / "out" / "movie.mp4").string();
  const std::string base = " --scenario " + scenario_ + " --out " + movie + " --fps 5";
  ExpectFailure("render " + no_q + base, "no_q.csv: no q.<coordinate> column");
  ExpectFailure("render " + unknown + base, "q.knee_flexion is not a model coordinate");
  ExpectFailure("render " + good + base + " --width 0", "--width: 0 must be in [2, 8192] and even");
  ExpectFailure("render " + good + base + " --height 121",
                "--height: 121 must be in [2, 8192] and even");
  ExpectFailure("render " + good + base + " --fps 0", "--fps: '0' is outside (0, 1000]");
  ExpectFailure("render " + good + base + " --camera fisheye", "--camera: 'fisheye'");
  ExpectFailure("render " + (root_ / "in" / "missing.csv").string() + base, "missing.csv");
  ExpectFailure(
      "render " + good + " --scenario " + (root_ / "in" / "nope.yaml").string() + " --out " + movie,
      "nope.yaml");
  ExpectFailure("render " + good + " --scenario " + scenario_ + " --frames " +
                    (root_ / "out" / "f").string() + " --width 0",
                "--width: 0 must be in [1, 8192], pixels");
  ExpectFailure("render " + good + " --scenario " + scenario_ + " --compare " + no_q +
                    " --frames " + (root_ / "out" / "f").string(),
                "no_q.csv: no q.<coordinate> column");
}

}  // namespace
}  // namespace fesim
