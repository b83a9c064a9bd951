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
  EXPECT_EQ(ErrorOf("name: \"x\\ty\\u00e9\"\n" + stim), "s.yaml: name: 'x\\x09y\xc3\xa9" + allowed);
  EXPECT_EQ(ErrorOf("name: " + std::string(201, 'a') + "\n" + stim).find("s.yaml: name: 'aaa"), 0u);
  EXPECT_EQ(ParseScenario("name: Trial-1_v2.0\n" + stim, "s.yaml").name, "Trial-1_v2.0");
}

// Issue 28: yaml-cpp keeps both entries of a repeated key and finds the first, so the second
// setting was silently ignored; refused naming both lines, at any depth.
TEST(ScenarioBadInput, DuplicateKeysNameBothLines) {
  EXPECT_EQ(ErrorOf("name: a\nstimulation: {type: constant, duration_s: 1, values_us: {}}\n"
                    "name: b\n"),
            "s.yaml:3: name: key given twice (lines 1 and 3)");
  EXPECT_EQ(ErrorOf("name: a\nstimulation:\n  type: constant\n  duration_s: 1\n"
                    "  values_us: {bic: 100}\n  duration_s: 2\n"),
            "s.yaml:6: stimulation.duration_s: key given twice (lines 4 and 6)");
  EXPECT_EQ(ErrorOf("name: a\nstimulation: {type: constant, duration_s: 1, values_us: {}}\n"
                    "muscles:\n  BIC: {alpha: 0.1}\n  BIC: {alpha: 0.2}\n"),
            "s.yaml:5: muscles.BIC: key given twice (lines 4 and 5)");
}

// yaml-cpp skips a leading UTF-8 byte order mark itself; kept as a regression.
TEST(ScenarioBadInput, ByteOrderMarkIsSkipped) {
  EXPECT_EQ(ParseScenario("\xEF\xBB\xBFname: bom\n"
                          "stimulation: {type: constant, duration_s: 1, values_us: {}}\n",
                          "s.yaml")
                .name,
            "bom");
}

// Issue 28: an in-range but huge request is refused at load with the key that makes it so; it
// used to die mid-simulation with a bare std::bad_alloc.
TEST(ScenarioBadInput, OutputTooLargeToWriteIsRefusedNamingTheRate) {
  const std::string hour =
      "name: big\nstimulation: {type: constant, duration_s: 3600, values_us: {}}\n";
  const std::string truth = ErrorOf(hour + "sensors: {truth_rate_hz: 20000}\n");
  EXPECT_EQ(truth.find("s.yaml: sensors.truth_rate_hz: 20000 Hz for 3600 s makes the truth record "
                       "~7.2e+07 rows x "),
            0u)
      << truth;
  EXPECT_NE(truth.find("more than the 4 GiB a trial file may hold"), std::string::npos) << truth;
  const std::string angles = ErrorOf(hour + "sensors: {angles: {rate_hz: 20000}}\n");
  EXPECT_EQ(angles.find("s.yaml: sensors.angles.rate_hz: 20000 Hz for 3600 s makes the measured "
                        "record"),
            0u)
      << angles;
  // An hour at the default rates, and a minute of 20 kHz truth, are fine.
  EXPECT_EQ(ErrorOf(hour), "(no error)");
  EXPECT_EQ(ErrorOf("name: m\nstimulation: {type: constant, duration_s: 60, values_us: {}}\n"
                    "sensors: {truth_rate_hz: 20000}\n"),
            "(no error)");
}

}  // namespace
}  // namespace fesim
