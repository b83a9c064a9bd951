// `fesim simulate|benchmark` as MPI jobs (issue 9): the same bytes / figures as the
// single-process run whatever the rank count, a failed work item reported by name and redone
// alone by a rerun. Runs mpirun with --oversubscribe (three ranks on two cores).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "base/json.h"
#include "base/trial.h"

namespace fesim {
namespace {

namespace fs = std::filesystem;

const std::string kSrc = FESIM_SOURCE_DIR_PATH;

bool MpiAvailable() {
#if FESIM_TEST_WITH_MPI
  return std::system("command -v mpirun >/dev/null 2>&1") == 0;
#else
  return false;
#endif
}

/// Runs `fesim ARGS` on `ranks` MPI ranks (0: without mpirun); stderr to `err_file`.
int RunFesim(int ranks, const std::string& args, const std::string& err_file,
             const std::string& env = "") {
  std::string cmd = "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 " + env + " ";
  if (ranks > 0) cmd += "mpirun -np " + std::to_string(ranks) + " --oversubscribe ";
  cmd += std::string(FESIM_BIN_PATH) + " " + args + " >/dev/null 2>" + err_file;
  return WEXITSTATUS(std::system(cmd.c_str()));
}

/// `j` without the members named in `drop`, members whose key contains "wall_s", and objects
/// flagged `measured_time`: what measures the run (wall times, thread and rank counts, work
/// counters, findings on measured times) rather than the data.
Json WithoutRunFigures(const Json& j, const std::set<std::string>& drop) {
  if (j.IsObject()) {
    if (const Json* m = j.Find("measured_time"); m != nullptr && m->AsBool()) return Json();
    Json out = Json::Object();
    for (std::size_t k = 0; k < j.Keys().size(); ++k) {
      const std::string& key = j.Keys()[k];
      if (drop.count(key) || key.find("wall_s") != std::string::npos) continue;
      out.Set(key, WithoutRunFigures(j.Items()[k], drop));
    }
    return out;
  }
  if (j.IsArray()) {
    Json out = Json::Array();
    for (const auto& v : j.Items()) out.Push(WithoutRunFigures(v, drop));
    return out;
  }
  return j;
}

/// results.json's figures of the cohort.
Json Figures(const Json& j) {
  return WithoutRunFigures(j, {"threads", "ranks", "fits_run", "fits_cached", "trials_simulated",
                               "thread_seconds_by_kind", "work_loops", "scaling_estimate"});
}

Json Results(const std::string& dir) {
  return Json::Parse(ReadFile(dir + "/results.json"), dir + "/results.json");
}

/// Every regular file under `dir` (relative paths) whose name passes `keep`.
std::set<std::string> Files(const std::string& dir, bool (*keep)(const std::string&)) {
  std::set<std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    const std::string rel = fs::relative(e.path(), dir).string();
    if (keep(rel)) out.insert(rel);
  }
  return out;
}

int CountOf(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

TEST(MpiSimulate, StudyBytesDoNotDependOnRanks) {
  if (!MpiAvailable()) GTEST_SKIP() << "built without MPI or no mpirun";
  const std::string base = ::testing::TempDir() + "mpi_simulate";
  fs::remove_all(base);
  const std::string study = kSrc + "/scenarios/bench_hand_array_quick.yaml";
  ASSERT_EQ(RunFesim(0, "simulate " + study + " --threads 2 --out " + base + "/one", base + ".e1"),
            0)
      << ReadFile(base + ".e1");
  ASSERT_EQ(RunFesim(3, "simulate " + study + " --out " + base + "/three", base + ".e3"), 0)
      << ReadFile(base + ".e3");
  const auto all = [](const std::string&) { return true; };
  const auto one = Files(base + "/one", all), three = Files(base + "/three", all);
  EXPECT_EQ(one, three);
  EXPECT_GE(one.size(), 9u);  // 4 trials × (measured, truth) + manifest
  for (const auto& f : one) {
    EXPECT_EQ(ReadFile(base + "/one/" + f), ReadFile(base + "/three/" + f)) << f;
  }
}

TEST(MpiBenchmark, QuickStudySameFiguresOnAnyRankCountAndFailedItemRedoneAlone) {
  if (!MpiAvailable()) GTEST_SKIP() << "built without MPI or no mpirun";
  const std::string base = ::testing::TempDir() + "mpi_benchmark";
  fs::remove_all(base);
  const std::string study = kSrc + "/scenarios/default_study.yaml --quick";
  // One process, two threads: the reference.
  ASSERT_EQ(RunFesim(0, "benchmark " + study + " --threads 2 --out " + base + "/one", base + ".e1"),
            0)
      << ReadFile(base + ".e1");
  const Json one = Results(base + "/one");
  // Two ranks.
  ASSERT_EQ(RunFesim(2, "benchmark " + study + " --out " + base + "/two", base + ".e2"), 0)
      << ReadFile(base + ".e2");
  const Json two = Results(base + "/two");
  EXPECT_EQ(two.Find("ranks")->AsNumber(), 2);
  EXPECT_EQ(Figures(one).Dump(), Figures(two).Dump());
  // The same work, done once: as many trials and fits as the single process.
  EXPECT_EQ(two.Find("fits_run")->AsNumber(), one.Find("fits_run")->AsNumber());
  EXPECT_EQ(two.Find("trials_simulated")->AsNumber(), one.Find("trials_simulated")->AsNumber());
  // Byte-identical trials, fitted models, predictions and plots.
  const auto artefact = [](const std::string& rel) {
    return rel.rfind("cache/trials/", 0) == 0 || rel.rfind("plots/", 0) == 0 ||
           (rel.rfind("cache/fits/", 0) == 0 &&
            (rel.find("model.yaml") != std::string::npos ||
             rel.find("predictions.json") != std::string::npos));
  };
  const auto files_one = Files(base + "/one", artefact);
  EXPECT_EQ(files_one, Files(base + "/two", artefact));
  EXPECT_GT(files_one.size(), 50u);
  for (const auto& f : files_one) {
    EXPECT_EQ(ReadFile(base + "/one/" + f), ReadFile(base + "/two/" + f)) << f;
  }

  // Three ranks, one Hammerstein fit made to fail: reported once, by name, and no report.
  const std::string three = base + "/three";
  const int rc = RunFesim(3, "benchmark " + study + " --out " + three, base + ".e3",
                          "FESIM_FAIL_ITEM='hand_array hammerstein fit 1'");
  const std::string err = ReadFile(base + ".e3");
  EXPECT_NE(rc, 0);
  // The item runs on whichever rank is free: "(rank r)" follows its name unless r = 0
  // (paper_benchmark/work.cc).
  EXPECT_EQ(CountOf(err, "error: hand_array hammerstein fit 1"), 1) << err;
  EXPECT_EQ(CountOf(err, "injected fault"), 1) << err;
  EXPECT_FALSE(fs::exists(three + "/results.json"));
  EXPECT_FALSE(fs::exists(three + "/report.md"));
  // The rerun does that fit again, and the rest of the loop comes from the cache.
  ASSERT_EQ(RunFesim(3, "benchmark " + study + " --out " + three, base + ".e3b"), 0)
      << ReadFile(base + ".e3b");
  const Json rerun = Results(three);
  const double hammerstein_fits =
      one.Find("sections")->Find("hand_array")->Find("participants")->AsNumber() *
      one.Find("sections")->Find("hand_array")->Find("folds")->AsNumber();
  EXPECT_EQ(rerun.Find("fits_run")->AsNumber(),
            one.Find("fits_run")->AsNumber() - (hammerstein_fits - 1));
  EXPECT_EQ(rerun.Find("fits_cached")->AsNumber(), hammerstein_fits - 1);
  EXPECT_EQ(Figures(one).Dump(), Figures(rerun).Dump());
}

/// diagnosis.json's figures (without wall time and the counts of simulations and cached results).
Json DiagnosisFigures(const Json& j) {
  return WithoutRunFigures(j, {"simulations", "cached_results", "threads"});
}

TEST(MpiDiagnose, SameDiagnosisOnThreeRanks) {
  if (!MpiAvailable()) GTEST_SKIP() << "built without MPI or no mpirun";
  const std::string base = ::testing::TempDir() + "mpi_diagnose";
  fs::remove_all(base);
  fs::create_directories(base);
  // The hand rig, 20 s of steps, with a planted wrist tremor the diagnosis must name (on 12 s
  // the wrist's calibrated damping rings like it: docs/diagnosis.md, Known limits).
  std::string rig = ReadFile(kSrc + "/scenarios/hand_rig.yaml");
  rig.replace(rig.find("stimulation:"), std::string::npos,
              "stimulation:\n  duration_s: 20\n  type: steps\n  steps: [{time_s: 2, values_us: "
              "{ext: 200}}, {time_s: 5, values_us: {flex: 150}}, {time_s: 8, values_us: {ext: "
              "0}}, {time_s: 11, values_us: {flex: 0}}, {time_s: 14, values_us: {ext: 150}}, "
              "{time_s: 17, values_us: {ext: 0}}]\n");
  WriteFileAtomic(base + "/rig.yaml", rig);
  WriteFileAtomic(base + "/planted.yaml",
                  rig +
                      "mechanisms:\n  tremor: {coordinate: wrist_flexion, frequency_hz: 6.3, "
                      "amplitude_nm: 0.12}\n");
  ASSERT_EQ(RunFesim(0, "simulate " + base + "/planted.yaml --seed 4 --out " + base + "/sim",
                     base + "/e0"),
            0)
      << ReadFile(base + "/e0");
  const std::string args =
      "diagnose " + base + "/sim/hand_rig.csv --scenario " + base + "/rig.yaml --out ";
  ASSERT_EQ(RunFesim(0, args + base + "/one --threads 2", base + "/e1"), 0)
      << ReadFile(base + "/e1");
  ASSERT_EQ(RunFesim(3, args + base + "/three", base + "/e3"), 0) << ReadFile(base + "/e3");
  const Json one = Json::Parse(ReadFile(base + "/one/diagnosis.json"));
  const Json three = Json::Parse(ReadFile(base + "/three/diagnosis.json"));
  EXPECT_EQ(one.Find("cause")->AsString(), "tremor");
  EXPECT_EQ(DiagnosisFigures(one).Dump(), DiagnosisFigures(three).Dump());
  EXPECT_NE(ReadFile(base + "/e3").find("3 MPI ranks"), std::string::npos)
      << ReadFile(base + "/e3");
  for (const char* png : {"residuals_wrist_flexion.png", "spectrum_wrist_flexion.png"}) {
    EXPECT_EQ(ReadFile(base + "/one/" + png), ReadFile(base + "/three/" + png)) << png;
  }
}

}  // namespace
}  // namespace fesim
