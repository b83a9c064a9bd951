// End-to-end tests of `fesim diagnose` through the built binary: a run on a simulated trial and
// bad input (one-line error naming the file and column, non-zero exit, nothing written).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "scenarios/trial.h"

namespace fesim {
namespace {

struct Result {
  int exit_code;
  std::string err;
};

Result RunFesim(const std::string& args) {
  const std::string err_file = ::testing::TempDir() + "diag_stderr_" +
                               ::testing::UnitTest::GetInstance()->current_test_info()->name() +
                               ".txt";
  const int status =
      std::system((std::string(FESIM_BIN_PATH) + " " + args + " 2>" + err_file).c_str());
  return {WEXITSTATUS(status), ReadFile(err_file)};
}

bool Exists(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0;
}

/// Names of the files in `dir`, one per line.
std::string RunListing(const std::string& dir) {
  std::string names;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    names += e.path().filename().string() + "\n";
  }
  return names;
}

const std::string kRig = std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/hand_rig.yaml";

TEST(DiagnoseCmd, DiagnosesASimulatedTrialAndWritesTheReport) {
  const std::string dir = ::testing::TempDir() + "diag_cmd";
  const std::string scenario = dir + "_short.yaml";
  std::string text = ReadFile(kRig);
  text.replace(text.find("stimulation:"), std::string::npos,
               "stimulation:\n  duration_s: 30\n  type: steps\n  steps: [{time_s: 2, values_us: "
               "{ext: 200}}, {time_s: 8, values_us: {flex: 150}}, {time_s: 14, values_us: {ext: "
               "100, flex: 100}}, {time_s: 20, values_us: {ext: 250}}, {time_s: 26, values_us: "
               "{flex: 0}}]\nsensors:\n  angles: {rate_hz: 60, noise_std_deg: 1.0, coordinates: "
               "[wrist_flexion, mcp_flexion]}\n");
  WriteFileAtomic(scenario, text);
  ASSERT_EQ(RunFesim("simulate " + scenario + " --out " + dir + "/sim --seed 3").exit_code, 0);
  const Result r = RunFesim("diagnose " + dir + "/sim/hand_rig.csv --scenario " + scenario +
                            " --out " + dir + "/out --threads 2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string json = ReadFile(dir + "/out/diagnosis.json");
  EXPECT_NE(json.find("\"cause\": \"none\""), std::string::npos) << json.substr(0, 400);
  EXPECT_NE(json.find("\"candidates\": ["), std::string::npos);
  EXPECT_TRUE(Exists(dir + "/out/diagnosis.md"));
  EXPECT_TRUE(Exists(dir + "/out/residuals_wrist_flexion.png"));
  EXPECT_TRUE(Exists(dir + "/out/spectrum_mcp_flexion.png"));
}

TEST(DiagnoseCmd, InterruptedRunLeavesNoPartialReport) {
  const std::string dir = ::testing::TempDir() + "diag_cmd_interrupt";
  const std::string scenario = dir + "_short.yaml";
  std::string text = ReadFile(kRig);
  text.replace(text.find("stimulation:"), std::string::npos,
               "stimulation:\n  duration_s: 30\n  type: steps\n  steps: [{time_s: 2, values_us: "
               "{ext: 200}}, {time_s: 12, values_us: {flex: 150}}, {time_s: 22, values_us: "
               "{ext: 0}}]\n");
  WriteFileAtomic(scenario, text);
  ASSERT_EQ(RunFesim("simulate " + scenario + " --out " + dir + "/sim --seed 4").exit_code, 0);
  for (const int sig : {SIGINT, SIGTERM}) {
    const std::string out = dir + "/out" + std::to_string(sig);
    const std::string cmd = "exec " + std::string(FESIM_BIN_PATH) + " diagnose " + dir +
                            "/sim/hand_rig.csv --scenario " + scenario + " --out " + out +
                            " --threads 2 2>/dev/null";
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ::usleep(1500000);  // calibration is under way (a diagnosis takes tens of seconds)
    ::kill(pid, sig);
    int status = 0;
    ::waitpid(pid, &status, 0);
    EXPECT_TRUE(WIFSIGNALED(status)) << "signal " << sig;
    EXPECT_FALSE(Exists(out + "/diagnosis.json"));
    EXPECT_FALSE(Exists(out + "/diagnosis.md"));
    if (Exists(out)) {
      const std::string listing = RunListing(out);
      EXPECT_EQ(listing.find(".tmp"), std::string::npos) << listing;
    }
  }
}

TEST(DiagnoseCmd, BadInputIsAOneLineErrorAndWritesNothing) {
  const std::string dir = ::testing::TempDir() + "diag_bad";
  const std::string csv = ::testing::TempDir() + "diag_bad_locked.csv";
  std::string rows = "time,u.ext,q.elbow_flexion\n";
  for (int i = 0; i < 200; ++i) rows += std::to_string(i / 50.0) + ",100,1.5\n";
  WriteFileAtomic(csv, rows);
  Result r = RunFesim("diagnose " + csv + " --scenario " + kRig + " --out " + dir);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(csv + ": column q.elbow_flexion: joint is not free"), std::string::npos)
      << r.err;
  EXPECT_FALSE(Exists(dir));
  r = RunFesim("diagnose " + csv + " --out " + dir);
  EXPECT_NE(r.err.find("--scenario is required"), std::string::npos) << r.err;
  r = RunFesim("diagnose " + csv + " --scenario " + kRig + " --model hammerstein");
  EXPECT_NE(r.err.find("--model: 'hammerstein' is not available"), std::string::npos) << r.err;
  EXPECT_EQ(RunFesim("diagnose --help").exit_code, 0);
}

}  // namespace
}  // namespace fesim
