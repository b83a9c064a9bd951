// Issue 10: scenario files that once escaped the loader's one-line errors (fuzz/fuzz_scenario.cc
// findings, kept as regressions) and the other bad-input classes of docs/reliability.md.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "scenarios/scenario.h"

namespace fesim {
namespace {

std::string ErrorOf(const std::string& text) {
  try {
    ParseScenario(text, "s.yaml");
  } catch (const std::runtime_error& e) {
    std::string what = e.what();
    EXPECT_EQ(what.rfind("s.yaml", 0), 0u) << "does not name the file: " << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << "not one line: " << what;
    return what;
  }
  return "(no error)";
}

// Fuzzer finding 1: a mapping used as a key made yaml-cpp throw "bad conversion" from inside the
// key check, a message naming neither the file nor the line.
TEST(ScenarioBadInput, FuzzFinding1MappingAsKey) {
  EXPECT_EQ(ErrorOf("name: c\nstimulation: {{ext: 100, flex: 50}}\n"),
            "s.yaml:2: unexpected YAML structure (bad conversion)");
  EXPECT_EQ(ErrorOf("[a, b]: 1\nname: c\n"),
            "s.yaml:1: unexpected YAML structure (bad conversion)");
}

TEST(ScenarioBadInput, EmptyAndNonMappingFiles) {
  EXPECT_EQ(ErrorOf(""), "s.yaml: expected a mapping");
  EXPECT_EQ(ErrorOf("- 1\n- 2\n"), "s.yaml: expected a mapping");
  EXPECT_EQ(ErrorOf("name: [\n"), "s.yaml:2: YAML syntax: end of sequence flow not found");
}

TEST(ScenarioBadInput, MalformedNumbersNanInfAndWrongUnits) {
  const std::string head = "name: x\nstimulation: {type: constant, values_us: {}, duration_s: ";
  EXPECT_EQ(ErrorOf(head + "1.2.3}\n"),
            "s.yaml: stimulation.duration_s: expected a number in [0.001, 3600]");
  EXPECT_EQ(ErrorOf(head + ".nan}\n"),
            "s.yaml: stimulation.duration_s: nan is outside [0.001, 3600]");
  EXPECT_EQ(ErrorOf(head + ".inf}\n"),
            "s.yaml: stimulation.duration_s: inf is outside [0.001, 3600]");
  // Wrong units: a pulse width in ms would be caught by range only when out of range; one in ns is.
  EXPECT_EQ(
      ErrorOf("name: x\nstimulation: {type: constant, duration_s: 1, values_us: {ext: 2e5}}\n"),
      "s.yaml: stimulation.values_us.ext: 200000 is outside [0, 300]");
}

// Issue 28: the name becomes DIR/<name>.csv, .sto and _truth.csv, so it is checked as a file
// stem at load: nothing may leave DIR ('..', '/'), be hidden ('.x', '') or carry control bytes.
TEST(ScenarioBadInput, NameMustBeAFileStem) {
  const std::string stim = "stimulation: {type: constant, duration_s: 1, values_us: {}}\n";
  const std::string allowed =
      "' cannot name output files (allowed: 1-200 of A-Z a-z 0-9 . _ -, not starting with '.')";
  EXPECT_EQ(ErrorOf("name: \"../escaped\"\n" + stim), "s.yaml: name: '../escaped" + allowed);
  EXPECT_EQ(ErrorOf("name: \"\"\n" + stim), "s.yaml: name: '" + allowed);
  EXPECT_EQ(ErrorOf("name: a/b\n" + stim), "s.yaml: name: 'a/b" + allowed);
  EXPECT_EQ(ErrorOf("name: .hidden\n" + stim), "s.yaml: name: '.hidden" + allowed);
  EXPECT_EQ(ErrorOf("name: \"a b\"\n" + stim), "s.yaml: name: 'a b" + allowed);
  EXPECT_EQ(ErrorOf("name: \"x\\ty\\u00e9\"\n" + stim),
            "s.yaml: name: 'x\\x09y\\xc3\\xa9" + allowed);
  EXPECT_EQ(ErrorOf("name: " + std::string(201, 'a') + "\n" + stim).find("s.yaml: name: 'aaa"), 0u);
  EXPECT_EQ(ParseScenario("name: Trial-1_v2.0\n" + stim, "s.yaml").name, "Trial-1_v2.0");
}

}  // namespace
}  // namespace fesim
