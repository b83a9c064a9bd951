// libFuzzer target: how `fesim identify` takes the rows and the sample period of a measured trial
// (identification/method_support.h SensorRows, UniformSamplePeriod; issue 28). The input is a
// trial CSV; a parsed one is split into the rows of its q.* sensor (else of its first column) and
// its period is checked. Anything but a result or std::runtime_error (crash, sanitizer report,
// other exception) is a finding, and so is a result that breaks the documented invariants.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "base/trial.h"
#include "identification/method_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  fesim::Trial t;
  try {
    t = fesim::ParseTrialCsv(text, "fuzz.csv");
  } catch (const std::runtime_error&) {
    return 0;
  }
  std::vector<std::string> needed = t.NamesWithPrefix("q.");
  if (needed.empty() && !t.names.empty()) needed = {t.names[0]};
  const fesim::Trial rows = fesim::identification::SensorRows(t, needed);
  // A subset of the rows, in order, with every column kept.
  if (rows.size() > t.size() || rows.names != t.names || rows.columns.size() != t.columns.size()) {
    std::abort();
  }
  for (std::size_t i = 1; i < rows.size(); ++i) {
    if (!(rows.time[i] > rows.time[i - 1])) std::abort();
  }
  try {
    const double T = fesim::identification::UniformSamplePeriod(rows, "fuzz trial");
    if (!(T >= fesim::identification::kMinSamplePeriodS &&
          T <= fesim::identification::kMaxSamplePeriodS)) {
      std::abort();
    }
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).rfind("fuzz trial", 0) != 0) std::abort();  // names the trial
  }
  return 0;
}
