// End-to-end tests of `fesim simulate` through the built binary (FESIM_BIN).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "base/trial.h"

namespace fesim {
namespace {

struct Result {
  int exit_code;
  std::string err;
};

Result RunFesim(const std::string& args) {
  // One stderr file per test: ctest runs the tests of this binary in parallel processes.
  const std::string err_file = ::testing::TempDir() + "sim_stderr_" +
                               ::testing::UnitTest::GetInstance()->current_test_info()->name() +
                               ".txt";
  const std::string cmd = std::string(FESIM_BIN_PATH) + " " + args + " 2>" + err_file;
  const int status = std::system(cmd.c_str());
  return {WEXITSTATUS(status), ReadFile(err_file)};
}

bool Exists(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0;
}

std::string Scenario(const std::string& name, const std::string& body) {
  std::string path = ::testing::TempDir() + name + ".yaml";
  WriteFileAtomic(path, "name: " + name + "\n" + body);
  return path;
}

const char* kShort = R"(coordinates: {elbow_flexion: {mode: locked, initial_deg: 90}}
stimulation: {duration_s: 1, type: steps, steps: [{time_s: 0.2, values_us: {bic: 200, ext: 120}}]}
sensors:
  angles: {rate_hz: 50, noise_std_deg: 1, coordinates: [wrist_flexion]}
  torques: {rate_hz: 200, noise_std_nm: 0.05, coordinates: [elbow_flexion]}
)";

TEST(SimulateCmd, SameSeedSameBytesDifferentSeedDifferentNoise) {
  const std::string sc = Scenario("short", kShort);
  const std::string dir = ::testing::TempDir() + "simout";
  ASSERT_EQ(RunFesim("simulate " + sc + " --out " + dir + "/a --seed 5").exit_code, 0);
  ASSERT_EQ(RunFesim("simulate " + sc + " --out " + dir + "/b --seed 5").exit_code, 0);
  ASSERT_EQ(RunFesim("simulate " + sc + " --out " + dir + "/c --seed 6").exit_code, 0);
  for (const char* f : {"/short.csv", "/short.sto", "/short_truth.csv", "/short.osim", "/short.mot",
                        "/manifest.json"}) {
    EXPECT_EQ(ReadFile(dir + "/a" + f), ReadFile(dir + "/b" + f)) << f;
  }
  EXPECT_NE(ReadFile(dir + "/a/short.csv"), ReadFile(dir + "/c/short.csv"));
  EXPECT_EQ(ReadFile(dir + "/a/short_truth.csv").substr(200),
            ReadFile(dir + "/c/short_truth.csv").substr(200));  // truth has no noise

  const Trial m = ReadTrialCsv(dir + "/a/short.csv");
  ASSERT_TRUE(m.Has("tau.elbow_flexion"));
  ASSERT_TRUE(m.Has("q.wrist_flexion"));
  // 200 Hz torque and 50 Hz angles: 201 rows, angles present on every fourth.
  EXPECT_EQ(m.size(), 201u);
  int angles = 0;
  for (double v : m.Column("q.wrist_flexion")) angles += !std::isnan(v);
  EXPECT_EQ(angles, 51);
  // The biceps pulls: the held elbow's torque rises after the step.
  EXPECT_GT(m.Column("tau.elbow_flexion").back(), m.Column("tau.elbow_flexion").front() + 1.0);
  const std::string sto = ReadFile(dir + "/a/short.sto");
  EXPECT_NE(sto.find("endheader"), std::string::npos);
  // OpenSim playback: the model and the truth's angles in degrees (sim/opensim.h, tested there).
  EXPECT_NE(ReadFile(dir + "/a/short.osim").find("<CustomJoint name=\"wrist_flexion\">"),
            std::string::npos);
  EXPECT_NE(ReadFile(dir + "/a/short.mot").find("inDegrees=yes\nendheader\ntime\t"),
            std::string::npos);
}

TEST(SimulateCmd, ExportWritesTheOpenSimModelAndMotionOfAnExistingTrial) {
  const std::string sc = Scenario("short", kShort);
  const std::string dir = ::testing::TempDir() + "simexport";
  ASSERT_EQ(RunFesim("simulate " + sc + " --out " + dir + " --seed 5").exit_code, 0);
  Result r = RunFesim("export " + dir + "/short.csv --scenario " + sc + " --out " + dir + "/os");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(ReadFile(dir + "/os/short.osim"), ReadFile(dir + "/short.osim"));
  const std::string mot = ReadFile(dir + "/os/short.mot");
  EXPECT_EQ(mot.rfind("short\nversion=1\nnRows=201\nnColumns=11\ninDegrees=yes\n", 0), 0u);
  r = RunFesim("export " + dir + "/short.csv --out " + dir + "/os2");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("nothing to export: give --scenario"), std::string::npos) << r.err;
  EXPECT_FALSE(Exists(dir + "/os2"));
}

TEST(SimulateCmd, BadInputFailsWithOneLineAndLeavesNoOutput) {
  const std::string dir = ::testing::TempDir() + "simbad";
  const std::string bad =
      Scenario("bad", "stimulation: {duration_s: -1, type: constant, values_us: {}}\n");
  Result r = RunFesim("simulate " + bad + " --out " + dir);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("bad.yaml: stimulation.duration_s: -1 is outside [0.001, 3600]"),
            std::string::npos)
      << r.err;
  // One line: main() starts it with a newline to end any progress bar.
  EXPECT_EQ(r.err.find('\n', 1), r.err.size() - 1) << r.err;
  EXPECT_FALSE(Exists(dir));

  r = RunFesim("simulate /nonexistent.yaml --out " + dir);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("/nonexistent.yaml: cannot open for reading"), std::string::npos);
  EXPECT_FALSE(Exists(dir));

  r = RunFesim("simulate " + Scenario("ok", kShort) + " --seed x --out " + dir);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("option --seed: 'x' is not an integer"), std::string::npos);
  EXPECT_FALSE(Exists(dir));
}

// Into a file (as into a pipe or a CI log) progress is plain lines, no carriage returns; --quiet
// shows none, and only the summary line remains.
TEST(SimulateCmd, ProgressIntoAFileIsPlainLinesAndQuietShowsNone) {
  const std::string dir = ::testing::TempDir() + "simprogress";
  const std::string sc = Scenario("short", kShort);
  Result r = RunFesim("simulate " + sc + " --out " + dir + "/a");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.find('\r'), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("] 100 % simulating short ("), std::string::npos) << r.err;
  r = RunFesim("simulate " + sc + " --quiet --out " + dir + "/b");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.find('%'), std::string::npos) << r.err;
  EXPECT_EQ(r.err.rfind("fesim simulate: ", 0), 0u) << r.err;
}

TEST(SimulateCmd, StudyResultsDoNotDependOnThreadCount) {
  const std::string dir = ::testing::TempDir() + "study";
  const std::string rig = Scenario("rig", kShort);
  WriteFileAtomic(::testing::TempDir() + "st.yaml", R"(study: st
scenario: rig.yaml
repetitions: 2
cohort: {size: 2, seed: 3, strength_scale: {mean: 1, sd: 0.2, min: 0.5, max: 1.5}}
protocols:
  - {name: hold, stimulation: {duration_s: 0.5, type: constant, values_us: {bic: 150}}}
)");
  const std::string st = ::testing::TempDir() + "st.yaml";
  ASSERT_EQ(RunFesim("simulate " + st + " --out " + dir + "/t1 --threads 1").exit_code, 0);
  ASSERT_EQ(RunFesim("simulate " + st + " --out " + dir + "/t2 --threads 2").exit_code, 0);
  for (const char* f :
       {"/manifest.json", "/p1/hold_r1.csv", "/p2/hold_r2.csv", "/p2/hold_r2_truth.csv"}) {
    EXPECT_EQ(ReadFile(dir + "/t1" + f), ReadFile(dir + "/t2" + f)) << f;
  }
  // Different participants, different strength: different held-elbow torque.
  const Trial a = ReadTrialCsv(dir + "/t1/p1/hold_r1_truth.csv");
  const Trial b = ReadTrialCsv(dir + "/t1/p2/hold_r1_truth.csv");
  EXPECT_NE(a.Column("tau.elbow_flexion").back(), b.Column("tau.elbow_flexion").back());
  EXPECT_NE(ReadFile(dir + "/t1/manifest.json").find("\"strength_scale\""), std::string::npos);
}

TEST(SimulateCmd, DefaultScenarioRuns) {
  const std::string dir = ::testing::TempDir() + "simdefault";
  const std::string sc = std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/default.yaml";
  ASSERT_EQ(RunFesim("simulate " + sc + " --out " + dir).exit_code, 0);
  const Trial t = ReadTrialCsv(dir + "/default_truth.csv");
  // Extensor stimulation (2–10 s) extends the wrist; flexor stimulation (10–14 s) flexes it.
  const auto& q = t.Column("q.wrist_flexion");
  EXPECT_LT(q[900], q[150] - 0.1);   // t = 9 s vs 1.5 s
  EXPECT_GT(q[1350], q[150] + 0.1);  // t = 13.5 s
}

}  // namespace
}  // namespace fesim
