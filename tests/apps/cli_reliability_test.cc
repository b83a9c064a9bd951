// Issue 10 through the built binary (FESIM_BIN): bad input files give one-line errors naming the
// file, line and column or key and leave no output; SIGINT/SIGTERM leave complete files or none
// and no temporary files (docs/reliability.md).
#include <dirent.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "base/trial.h"

namespace fesim {
namespace {

std::string Bin() {
  const char* env = std::getenv("FESIM_BIN");
  return env != nullptr && *env != '\0' ? env : FESIM_BIN_PATH;
}

std::string Dir(const std::string& name) {
  std::string d = ::testing::TempDir() + "cli_rel_" + name;
  std::system(("rm -rf '" + d + "'").c_str());
  ::mkdir(d.c_str(), 0755);
  return d;
}

bool Exists(const std::string& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0;
}

std::vector<std::string> List(const std::string& dir) {
  std::vector<std::string> out;
  DIR* d = ::opendir(dir.c_str());
  if (d == nullptr) return out;
  while (const dirent* e = ::readdir(d)) {
    const std::string n = e->d_name;
    if (n != "." && n != "..") out.push_back(n);
  }
  ::closedir(d);
  return out;
}

/// Starts `fesim ARGS...` with stdout to /dev/null and stderr to `err_file`.
pid_t Spawn(const std::vector<std::string>& args, const std::string& err_file) {
  // Everything the child needs is prepared before fork(): it only opens, dups and execs.
  std::vector<std::string> all = {Bin()};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  argv.reserve(all.size() + 1);
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int out = ::open("/dev/null", O_WRONLY);
    const int err = ::open(err_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(out, 1);
    ::dup2(err, 2);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  return pid;
}

struct Result {
  int exit_code = -1;
  std::string err;
};

Result RunFesim(const std::vector<std::string>& args, const std::string& err_file) {
  const pid_t pid = Spawn(args, err_file);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ReadFile(err_file)};
}

/// Waits until the file contains `text` (true) or `seconds` pass (false).
bool WaitFor(const std::string& file, const std::string& text, double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    if (Exists(file) && ReadFile(file).find(text) != std::string::npos) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

void ExpectOneLineError(const Result& r, const std::string& expected) {
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find(expected), std::string::npos)
      << "expected '" << expected << "' in " << r.err;
  // The error is the last line, alone on it (progress output, if any, comes before it).
  const std::size_t at = r.err.find(": error: ");
  ASSERT_NE(at, std::string::npos) << r.err;
  const std::size_t begin = r.err.rfind('\n', at);
  ASSERT_NE(begin, std::string::npos) << "error not on a line of its own: " << r.err;
  EXPECT_EQ(r.err.find('\n', begin + 1), r.err.size() - 1) << "not one line: " << r.err;
}

constexpr const char* kSteps =
    "stimulation: {duration_s: %s, type: steps, steps: [{time_s: 0.2, values_us: {bic: 200}}]}\n"
    "integrator: {method: cvodes, tolerance: 1.0e-4}\n";

std::string WriteScenario(const std::string& dir, const std::string& name, const char* duration) {
  char body[512];
  std::snprintf(body, sizeof body, kSteps, duration);
  std::string path = dir + "/" + name + ".yaml";
  WriteFileAtomic(path, "name: " + name + "\n" + body);
  return path;
}

TEST(CliBadInput, IdentifyNamesFileLineAndColumnAndWritesNothing) {
  const std::string dir = Dir("identify");
  const std::string out = dir + "/out";
  const std::string err = dir + "/err.txt";
  const auto identify = [&](const std::string& train) {
    return RunFesim({"identify", "--method", "spline-arx", "--train", train, "--out", out}, err);
  };
  WriteFileAtomic(dir + "/units.csv", "time,u.bic,q.elbow_flexion\n0,0,0\n0.025,350,0\n");
  ExpectOneLineError(identify(dir + "/units.csv"),
                     "units.csv:3: column u.bic: 350 is outside [0, 300] (pulse width in µs)");
  WriteFileAtomic(dir + "/time.csv", "time,u.bic\n0,0\n0.5,1\n0.5,2\n");
  ExpectOneLineError(identify(dir + "/time.csv"),
                     "time.csv:4: column time: 0.5 is not greater than the previous time");
  WriteFileAtomic(dir + "/cells.csv", "time,u.bic,q.elbow_flexion\n0,1\n");
  ExpectOneLineError(identify(dir + "/cells.csv"), "cells.csv:2: expected 3 cells, found 2");
  WriteFileAtomic(dir + "/empty.csv", "");
  ExpectOneLineError(identify(dir + "/empty.csv"), "empty.csv:0: no header row");
  ExpectOneLineError(identify(dir + "/missing.csv"),
                     "missing.csv: cannot open for reading: No such file or directory");
  ExpectOneLineError(identify(dir), dir + ": cannot open for reading: is a directory");
  EXPECT_FALSE(Exists(out));
}

TEST(CliBadInput, SimulateStimulationCsvAndOutputDirectory) {
  const std::string dir = Dir("simulate");
  const std::string err = dir + "/err.txt";
  WriteFileAtomic(dir + "/u.csv",
                  "time,u.ext,u.flex,u.bic,u.tri,u.delt_ant,u.delt_post\n"
                  "0,0,0,0,0,0,0\n1,0,0,0,0,0,0\n1,0,0,0,0,0,0\n");
  WriteFileAtomic(dir + "/sc.yaml",
                  "name: sc\nstimulation: {duration_s: 2, type: csv, file: u.csv}\n");
  ExpectOneLineError(RunFesim({"simulate", dir + "/sc.yaml", "--out", dir + "/out"}, err),
                     "sc.yaml: stimulation.file: " + dir +
                         "/u.csv:4: column time: 1 is not greater than the previous time");
  EXPECT_FALSE(Exists(dir + "/out"));
  // A scenario that is a directory.
  ExpectOneLineError(RunFesim({"simulate", dir, "--out", dir + "/out"}, err),
                     dir + ": cannot open for reading: is a directory");
  // --out below a regular file: the directory cannot be made.
  WriteFileAtomic(dir + "/file", "x");
  const std::string sc = WriteScenario(dir, "tiny", "0.3");
  ExpectOneLineError(RunFesim({"simulate", sc, "--out", dir + "/file/out"}, err),
                     dir + "/file/out: cannot create directory: Not a directory");
}

// Issue 28: a scenario name that would leave --out ('../escaped'), make hidden files ('') or a
// sub-directory ('a/b') is refused at load, before anything is simulated or written.
TEST(CliOutputPaths, ScenarioNameCannotLeaveOrHideInTheOutputDirectory) {
  const std::string dir = Dir("stem");
  const std::string sub = dir + "/sub";
  ::mkdir(sub.c_str(), 0755);
  const std::string err = dir + "/err.txt";
  for (const std::string name : {"../escaped", "", "a/b", ".hidden"}) {
    const std::string sc = sub + "/sc.yaml";
    WriteFileAtomic(sc, "name: \"" + name + "\"\n" +
                            "stimulation: {duration_s: 0.3, type: constant, values_us: {}}\n");
    ExpectOneLineError(RunFesim({"simulate", sc, "--out", sub + "/out"}, err),
                       sc + ": name: '" + name + "' cannot name output files");
    EXPECT_EQ(List(sub), std::vector<std::string>{"sc.yaml"}) << name;
    EXPECT_EQ(List(dir).size(), 2u) << name;  // sub and err.txt: no escaped.csv
  }
}

// Issue 28: `--out ""` is refused by every command that writes (it used to write /default.csv,
// /manifest.json, /model.yaml ...), before reading the inputs.
TEST(CliOutputPaths, EmptyOutIsRefusedByEveryWritingCommand) {
  const std::string dir = Dir("empty_out");
  const std::string err = dir + "/err.txt";
  const std::string sc = WriteScenario(dir, "tiny", "0.3");
  WriteFileAtomic(dir + "/t.csv", "time,u.bic,q.elbow_flexion\n0,0,0\n0.01,0,0\n");
  const std::string study =
      std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/bench_hand_array_quick.yaml";
  const std::string bench = std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/default_study.yaml";
  const std::vector<std::vector<std::string>> commands = {
      {"simulate", sc, "--out", ""},
      {"simulate", study, "--out="},
      {"identify", "--method", "spline-arx", "--train", dir + "/t.csv", "--out", ""},
      {"diagnose", dir + "/t.csv", "--scenario", sc, "--out", ""},
      {"benchmark", bench, "--quick", "--out", ""},
      {"render", dir + "/t.csv", "--scenario", sc, "--out", ""},
  };
  for (const auto& c : commands) {
    ExpectOneLineError(RunFesim(c, err), "option --out: empty path");
  }
  ExpectOneLineError(RunFesim({"render", dir + "/t.csv", "--scenario", sc, "--frames", ""}, err),
                     "option --frames: empty path");
  std::vector<std::string> files = List(dir);
  std::sort(files.begin(), files.end());
  EXPECT_EQ(files, (std::vector<std::string>{"err.txt", "t.csv", "tiny.yaml"}));
}

// An integrator that cannot advance (stiff blow-up: 10 kN muscles, stiff joint limits, Simbody's
// explicit integrator at a loose tolerance) stops with one line naming the time, and writes
// nothing. Simbody's own message spans several lines; main() joins them.
TEST(CliNumerics, IntegratorFailureIsOneLineAndWritesNothing) {
  const std::string dir = Dir("blowup");
  WriteFileAtomic(dir + "/blow.yaml", R"(name: blow
coordinates:
  elbow_flexion: {initial_speed_deg_s: 2000, limit_stiffness_nm_per_rad: 10000,
                  limit_sharpness_per_rad: 200, damping_nms_per_rad: 0}
  wrist_flexion: {initial_speed_deg_s: 2000, limit_stiffness_nm_per_rad: 10000,
                  limit_sharpness_per_rad: 200, damping_nms_per_rad: 0}
muscles:
  BIC: {max_isometric_force_n: 10000, omega_rad_s: 100}
  FCR: {max_isometric_force_n: 10000, omega_rad_s: 100}
stimulation: {duration_s: 5, type: constant, values_us: {bic: 300, flex: 300, ext: 300}}
integrator: {method: simbody-rkm, tolerance: 1.0e-2}
)");
  const Result r =
      RunFesim({"simulate", dir + "/blow.yaml", "--out", dir + "/out"}, dir + "/err.txt");
  ExpectOneLineError(r, "step failed at time");
  EXPECT_FALSE(Exists(dir + "/out"));
}

TEST(CliInterrupt, SignalMidSimulationLeavesNoOutput) {
  for (const int sig : {SIGINT, SIGTERM}) {
    const std::string dir = Dir("sig" + std::to_string(sig));
    const std::string sc = WriteScenario(dir, "long", "600");
    const std::string err = dir + "/err.txt";
    const pid_t pid = Spawn({"simulate", sc, "--out", dir + "/out"}, err);
    ASSERT_TRUE(WaitFor(err, "%", 60.0)) << "no progress shown";
    ::kill(pid, sig);
    int status = 0;
    ::waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << "exited with " << WEXITSTATUS(status);
    EXPECT_EQ(WTERMSIG(status), sig);
    EXPECT_FALSE(Exists(dir + "/out"));  // nothing is written before the trial is complete
  }
}

// The signal arrives while an output file is being written: the handler removes the temporary
// file. A FIFO at the temporary file's name (path.tmp.PID.HOST) holds the writer in open() until
// the signal, so the test does not depend on timing; without the handler the FIFO stays behind.
TEST(CliInterrupt, SignalDuringAtomicWriteRemovesTheTemporaryFile) {
  const std::string dir = Dir("fifo");
  const std::string sc = WriteScenario(dir, "short", "0.3");
  const std::string out = dir + "/out";
  ::mkdir(out.c_str(), 0755);
  const std::string err = dir + "/err.txt";
  const pid_t pid = Spawn({"simulate", sc, "--out", out}, err);
  const std::string fifo = out + "/short.csv.tmp." + std::to_string(pid) + "." + TempSuffixHost();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  ASSERT_TRUE(WaitFor(err, "100 %", 60.0)) << "simulation did not finish";
  // Give the writer time to reach open() on the FIFO (it then blocks there).
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ::kill(pid, SIGTERM);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status))
      << "exited with " << WEXITSTATUS(status) << ": " << ReadFile(err);
  EXPECT_EQ(WTERMSIG(status), SIGTERM);
  EXPECT_EQ(List(out), std::vector<std::string>{});  // no short.csv, no short.csv.tmp.PID
  // A rerun completes and writes every file.
  ASSERT_EQ(RunFesim({"simulate", sc, "--out", out}, err).exit_code, 0) << ReadFile(err);
  for (const char* f :
       {"short.csv", "short.sto", "short_truth.csv", "short.osim", "short.mot", "manifest.json"}) {
    EXPECT_TRUE(Exists(out + "/" + f)) << f;
  }
  EXPECT_EQ(List(out).size(), 6u);
}

// A discrete model is also written for MATLAB (README "MATLAB"; the fields are tested in
// matfile_test, the polynomials against the method's prediction in spline_hammerstein_test).
TEST(CliIdentify, ADiscreteModelIsAlsoAMatFileWithItsSampleTime) {
  const std::string dir = Dir("identify_mat");
  // A first-order response (pole 0.9) to a quadratic recruitment of stimulation bursts, 50 Hz.
  Trial t;
  std::vector<double> u(600), q(600);
  double y = 0.0;
  for (int k = 0; k < 600; ++k) {
    t.time.push_back(0.02 * k);
    u[k] = (k / 40) % 2 ? 40.0 + 4.0 * (k % 50) : 0.0;
    q[k] = y;
    y = 0.9 * y + 0.1 * (u[k] / 250.0) * (u[k] / 250.0);
  }
  t.AddColumn("u.ext", u);
  t.AddColumn("q.wrist_flexion", q);
  WriteFileAtomic(dir + "/t.csv", FormatTrialCsv(t));
  const Result r = RunFesim(
      {"identify", "--method", "spline-oe", "--train", dir + "/t.csv", "--out", dir + "/out"},
      dir + "/err.txt");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(ReadFile(dir + "/out/model.mat").substr(0, 6), "MATLAB");
  EXPECT_NE(ReadFile(dir + "/out/model.yaml").find("sample_time_s: {value: 0.02, unit: \"s\"}"),
            std::string::npos);
}

// A study interrupted after some trials were written: the rerun simulates only the others and
// the outputs are the bytes of an uninterrupted run.
TEST(CliInterrupt, InterruptedStudyResumesWithTheSameBytes) {
  const std::string dir = Dir("study_resume");
  const std::string study =
      std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/bench_hand_array_quick.yaml";
  const std::string err = dir + "/err.txt";
  ASSERT_EQ(RunFesim({"simulate", study, "--threads", "2", "--out", dir + "/ref"}, err).exit_code,
            0)
      << ReadFile(err);
  const std::string out = dir + "/out";
  const pid_t pid = Spawn({"simulate", study, "--threads", "1", "--out", out}, err);
  // Stopped once the first trial is finished: its files are on disk and, written last, its
  // record of their sizes and hashes in out/cache.
  bool some = false;
  for (int waited_ms = 0; waited_ms < 300000 && !some; waited_ms += 10) {
    if (Exists(out + "/cache")) {
      for (const auto& f : List(out + "/cache")) {
        some = some || f.find(".tmp.") == std::string::npos;
      }
    }
    if (!some) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(some) << ReadFile(err);
  ::kill(pid, SIGTERM);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "finished before the signal: " << ReadFile(err);
  EXPECT_FALSE(Exists(out + "/manifest.json"));
  const Result r = RunFesim({"simulate", study, "--threads", "2", "--out", out}, err);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::size_t at = r.err.find(" from an earlier run");
  ASSERT_NE(at, std::string::npos) << r.err;
  const std::size_t comma = r.err.rfind(", ", at);
  EXPECT_GE(std::stoi(r.err.substr(comma + 2)), 1) << r.err;  // "(k simulated, m from an …"
  EXPECT_EQ(List(out + "/p1"), List(dir + "/ref/p1"));
  for (const auto& p : {std::string("p1"), std::string("p2")}) {
    if (!Exists(dir + "/ref/" + p)) continue;
    for (const auto& f : List(dir + "/ref/" + p)) {
      EXPECT_EQ(ReadFile(out + "/" + p + "/" + f), ReadFile(dir + "/ref/" + p + "/" + f)) << f;
    }
  }
  EXPECT_EQ(ReadFile(out + "/manifest.json"), ReadFile(dir + "/ref/manifest.json"));
}

// Issue 28: a finished study whose measured CSV was truncated since (still a valid CSV when cut
// at a row boundary) or edited is not counted as finished on a rerun: the damaged file is named
// and its trial simulated again, giving the original bytes.
TEST(CliInterrupt, ResumedStudyRedoesAndNamesDamagedFiles) {
  const std::string dir = Dir("study_damaged");
  WriteScenario(dir, "rig", "0.4");
  WriteFileAtomic(dir + "/st.yaml", R"(study: st
scenario: rig.yaml
cohort: {size: 2, seed: 3}
protocols:
  - {name: hold, stimulation: {duration_s: 0.4, type: constant, values_us: {bic: 150}}}
)");
  const std::string out = dir + "/out";
  const std::string err = dir + "/err.txt";
  const std::vector<std::string> run = {"simulate", dir + "/st.yaml", "--threads",
                                        "2",        "--out",          out};
  ASSERT_EQ(RunFesim(run, err).exit_code, 0) << ReadFile(err);
  const std::string measured = ReadFile(out + "/p1/hold_r1.csv");
  const std::string truth = ReadFile(out + "/p2/hold_r1_truth.csv");
  const std::string manifest = ReadFile(out + "/manifest.json");
  // An untouched study resumes entirely from the earlier run.
  Result r = RunFesim(run, err);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("(0 simulated, 2 from an earlier run)"), std::string::npos) << r.err;
  // Damage: cut the measured CSV after its last complete row but one; change one digit of a
  // truth file (same size); delete the manifest.
  const std::size_t cut = measured.rfind('\n', measured.size() - 2) + 1;
  ASSERT_EQ(::truncate((out + "/p1/hold_r1.csv").c_str(), static_cast<off_t>(cut)), 0);
  std::string edited = truth;
  const std::size_t digit = edited.find_last_of("0123456789");
  edited[digit] = edited[digit] == '1' ? '2' : '1';
  WriteFileAtomic(out + "/p2/hold_r1_truth.csv", edited);
  std::remove((out + "/manifest.json").c_str());
  r = RunFesim(run, err);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find(out + "/p1/hold_r1.csv: " + std::to_string(cut) + " bytes, " +
                       std::to_string(measured.size()) + " were written"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find(out + "/p2/hold_r1_truth.csv: contents differ from what was written"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("(2 simulated, 0 from an earlier run)"), std::string::npos) << r.err;
  EXPECT_EQ(ReadFile(out + "/p1/hold_r1.csv"), measured);
  EXPECT_EQ(ReadFile(out + "/p2/hold_r1_truth.csv"), truth);
  EXPECT_EQ(ReadFile(out + "/manifest.json"), manifest);
}

// Issue 28: the README's simulate -> identify workflow on a shipped rig whose measured trials
// interleave 60 Hz angle rows with 100 Hz torque rows: identify takes the angle sensor's rows
// (it used to fail with "column time is not uniformly sampled (near t = 0.01 s)").
TEST(CliSampling, IdentifyReadsTheHandRigsMixedRateTrials) {
  const std::string dir = Dir("mixed_rates");
  const std::string err = dir + "/err.txt";
  const std::string study =
      std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/bench_hand_array_quick.yaml";
  ASSERT_EQ(RunFesim({"simulate", study, "--threads", "2", "--out", dir + "/t"}, err).exit_code, 0)
      << ReadFile(err);
  const Trial raw = ReadTrialCsv(dir + "/t/p1/step_grid_r1.csv");
  ASSERT_TRUE(raw.Has("tau.elbow_flexion"));  // the torque rows are there
  // The quick study stimulates two of six channels: two muscle units are what its steady states
  // identify (the default, one per channel, needs more than it has).
  for (const char* r : {"1", "2"}) {
    WriteFileAtomic(dir + "/r" + r + ".csv",
                    "# hammerstein.muscles_l: 2\n" +
                        ReadFile(dir + "/t/p1/step_grid_r" + std::string(r) + ".csv"));
  }
  const Result r = RunFesim({"identify", "--method", "hammerstein-mimo", "--train", dir + "/r1.csv",
                             "--test", dir + "/r2.csv", "--out", dir + "/x"},
                            err);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Trial pred = ReadTrialCsv(dir + "/x/prediction_0.csv");
  ASSERT_GT(pred.size(), 100u);
  for (std::size_t i = 0; i < 100; ++i) EXPECT_NEAR(pred.time[i], i / 60.0, 1e-9) << i;
  EXPECT_LT(pred.size(), raw.size());
}

// Issue 28: a trial whose time column is in ms (a 100 Hz record read as 0.1 Hz) is refused with
// the reason, naming the file and column; it used to run 42 s and exit 0 without a word.
TEST(CliSampling, ImplausibleSampleRateIsRefusedNamingFileAndColumn) {
  const std::string dir = Dir("time_ms");
  std::string csv = "time,u.fcr,u.ecr,q.wrist_flexion\n";
  for (int k = 0; k < 2000; ++k) {
    csv += std::to_string(10 * k) + "," + std::to_string(30 + k % 100) + ",45," +
           std::to_string(0.001 * (k % 37)) + "\n";
  }
  WriteFileAtomic(dir + "/ms.csv", csv);
  ExpectOneLineError(RunFesim({"identify", "--method", "tremor-arx", "--train", dir + "/ms.csv",
                               "--out", dir + "/x"},
                              dir + "/err.txt"),
                     "train trial 0 (" + dir +
                         "/ms.csv): column time: sample period 10 s (0.1 Hz) is implausible for "
                         "a measured trial (allowed: 1e-05 to 1 s; time in ms?)");
  EXPECT_FALSE(Exists(dir + "/x"));
}

// Issue 28: one --threads rule, [1, 256], for every command that takes it (simulate accepted
// 100000, benchmark capped at 256 and accepted 0).
TEST(CliOptions, OneThreadsRuleForEveryCommand) {
  const std::string dir = Dir("threads");
  const std::string err = dir + "/err.txt";
  const std::string sc = WriteScenario(dir, "tiny", "0.3");
  WriteFileAtomic(dir + "/t.csv", "time,u.bic,q.elbow_flexion\n0,0,0\n0.01,0,0\n");
  const std::string bench = std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/default_study.yaml";
  for (const std::string n : {"100000", "0", "-3", "257"}) {
    ExpectOneLineError(RunFesim({"simulate", sc, "--threads", n, "--out", dir + "/o"}, err),
                       "option --threads: " + n + " is outside [1, 256]");
    ExpectOneLineError(RunFesim({"benchmark", bench, "--threads", n, "--out", dir + "/o"}, err),
                       "option --threads: " + n + " is outside [1, 256]");
    ExpectOneLineError(RunFesim({"diagnose", dir + "/t.csv", "--scenario", sc, "--threads", n,
                                 "--out", dir + "/o"},
                                err),
                       "option --threads: " + n + " is outside [1, 256]");
  }
  EXPECT_FALSE(Exists(dir + "/o"));
}

}  // namespace
}  // namespace fesim
