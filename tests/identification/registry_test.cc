// identification/registry.cc: the table of built-in methods `fesim identify` offers.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "identification/method.h"

namespace fesim::identification {
namespace {

TEST(BuiltinMethods, NamesAreUniqueCliWordsEachWithASummaryAndARunner) {
  const std::vector<MethodEntry> methods = BuiltinMethods();
  ASSERT_EQ(methods.size(), 10u);
  std::set<std::string> names;
  for (const MethodEntry& m : methods) {
    EXPECT_TRUE(names.insert(m.name).second) << m.name << " twice";
    EXPECT_FALSE(m.name.empty());
    for (const char c : m.name) {
      EXPECT_TRUE((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-') << m.name;
    }
    EXPECT_FALSE(m.summary.empty()) << m.name;
    EXPECT_EQ(m.summary.find('\n'), std::string::npos) << m.name;  // one --help line
    EXPECT_TRUE(static_cast<bool>(m.run)) << m.name;
  }
}

TEST(BuiltinMethods, ExactlyTheMethodsThatSimulateInputsToOutputsOfferAFittedSimulator) {
  // The black-box reference of `fesim diagnose` (diagnosis/reference.h) uses every method with a
  // fit_simulator: the Hammerstein family maps u.* to q.* by simulation; the shoulder, inverse
  // dynamics and tremor methods do not.
  std::set<std::string> simulators;
  for (const MethodEntry& m : BuiltinMethods()) {
    if (m.fit_simulator) simulators.insert(m.name);
  }
  EXPECT_EQ(simulators, (std::set<std::string>{"hammerstein-mimo", "spline-arx", "spline-oe"}));
}

}  // namespace
}  // namespace fesim::identification
