#include "scenarios/benchmark_spec.h"

#include <gtest/gtest.h>

#include <string>

#include "base/trial.h"

namespace fesim {
namespace {

const std::string kScenarios = std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/";

std::string Write(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "_test_" + name + ".yaml";
  WriteFileAtomic(path, text);
  return path;
}

std::string LoadError(const std::string& name, const std::string& text) {
  const std::string path = Write(name, text);
  std::string what;
  try {
    LoadBenchmarkSpec(path);
  } catch (const std::runtime_error& e) {
    what = e.what();
  }
  return what;
}

TEST(BenchmarkSpec, DefaultStudyHasEverySection) {
  const BenchmarkSpec s = LoadBenchmarkSpec(kScenarios + "default_study.yaml");
  EXPECT_EQ(s.name, "default_study");
  ASSERT_TRUE(s.hand_array && s.elbow_tests && s.tremor_wrist && s.shoulder && s.reaching);
  EXPECT_EQ(s.hand_array->methods, (std::vector<std::string>{"full-model", "hammerstein-mimo"}));
  EXPECT_EQ(s.elbow_tests->methods, (std::vector<std::string>{"spline-arx", "spline-oe"}));
  EXPECT_EQ(s.shoulder->methods.size(), 3u);
  EXPECT_NE(s.hand_array->quick_study_path, s.hand_array->study_path);
  // Paper 000 §5.1: the 29 most sensitive parameters, to convergence.
  EXPECT_EQ(s.full_model.keep, 29);
  EXPECT_FALSE(s.full_model.broyden);
  EXPECT_DOUBLE_EQ(s.full_model.relative_tolerance, 1e-4);
  EXPECT_EQ(s.quick_full_model.keep, 4);
  EXPECT_TRUE(s.full_model.rank_once);
  EXPECT_EQ(s.independent.participants, 2);
  EXPECT_EQ(s.quick_independent.participants, 1);
  EXPECT_EQ(s.quick_independent.seed, s.independent.seed);  // inherited
  EXPECT_EQ(s.tremor_wrist->options.at("tremor.eps"), "1.0e-5");
  EXPECT_EQ(s.assumption_participants, 2);
  // Paper 004's two subjects (issue 27): the dense and the sparse reaching scenarios.
  EXPECT_EQ(s.reaching->sparse_path, kScenarios + "bench_reaching_sparse.yaml");
  EXPECT_EQ(s.reaching->quick_sparse_path, kScenarios + "bench_reaching_sparse_quick.yaml");
  EXPECT_EQ(s.reaching->options.at("invdyn.length_scale_factor"), "2");
}

TEST(BenchmarkSpec, BadInputNamesFileKeyAndRange) {
  const std::string base = "benchmark: b\n";
  struct Case {
    std::string name, text, expect;
  };
  const Case cases[] = {
      {"unknown", base + "hand_arrays: {}\n", "hand_arrays: unknown key (allowed:"},
      {"none", base, "needs at least one of hand_array"},
      {"method",
       base + "elbow_tests: {study: " + kScenarios + "bench_elbow.yaml, methods: [spline-xx]}\n",
       "elbow_tests.methods: 'spline-xx' is not one of spline-arx|spline-oe"},
      {"missing_study", base + "shoulder: {study: nope.yaml}\n", "shoulder.study: "},
      {"keep",
       base + "hand_array: {study: " + kScenarios +
           "bench_hand_array.yaml, full_model: {keep: 40}}\n",
       "hand_array.full_model.keep: 40 is outside [1, 39]"},
      {"relative_tolerance",
       base + "hand_array: {study: " + kScenarios +
           "bench_hand_array.yaml, full_model: {relative_tolerance: 0.5}}\n",
       "hand_array.full_model.relative_tolerance: 0.5 is outside [1e-12, 0.1]"},
      {"independent",
       base + "hand_array: {study: " + kScenarios +
           "bench_hand_array.yaml, independent: {participants: 101}}\n",
       "hand_array.independent.participants: 101 is outside [0, 100]"},
      {"independent_key",
       base + "hand_array: {study: " + kScenarios +
           "bench_hand_array.yaml, quick_independent: {persons: 1}}\n",
       "hand_array.quick_independent.persons: unknown key"},
      {"option",
       base + "tremor_wrist: {study: " + kScenarios + "bench_tremor.yaml, options: {eps: 1}}\n",
       "tremor_wrist.options.eps: expected <method prefix>.<option>"},
      {"sparse_only_quick",
       base + "reaching: {scenario: " + kScenarios +
           "bench_reaching.yaml, quick_sparse_scenario: " + kScenarios +
           "bench_reaching_sparse_quick.yaml}\n",
       "reaching.quick_sparse_scenario: needs sparse_scenario"},
      {"sparse_in_study",
       base + "shoulder: {study: " + kScenarios + "bench_shoulder.yaml, sparse_scenario: x.yaml}\n",
       "shoulder.sparse_scenario: unknown key"},
      {"assumptions",
       base + "shoulder: {study: " + kScenarios +
           "bench_shoulder.yaml}\nassumptions: "
           "{participants: 2}\n",
       "assumptions: needs the hand_array section"},
  };
  for (const auto& c : cases) {
    const std::string what = LoadError(c.name, c.text);
    EXPECT_NE(what.find(c.expect), std::string::npos) << c.name << ": " << what;
    EXPECT_NE(what.find("_test_" + c.name + ".yaml"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

// Fuzz finding (fuzz/fuzz_benchmark_spec.cc, docs/reliability.md): a mapping used as a key made
// yaml-cpp throw "bad conversion" from the key check, a message naming neither file nor line.
TEST(BenchmarkSpecBadInput, FuzzFinding1MappingAsKey) {
  const std::string dir = ::testing::TempDir() + "_test_";
  EXPECT_EQ(LoadError("fuzz1", "benchmark: tiyem\n{ nsuhodstudy.yaml}"),
            dir + "fuzz1.yaml:2: unexpected YAML structure (bad conversion)");
  EXPECT_EQ(LoadError("fuzz1b", "benchmark: b\nelbow_tests: {{study: a}: 1}\n"),
            dir + "fuzz1b.yaml:2: unexpected YAML structure (bad conversion)");
}

}  // namespace
}  // namespace fesim
