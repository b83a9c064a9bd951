// libFuzzer target: the trial CSV reader (base/trial.h ParseTrialCsv).
// Any input must either parse or throw std::runtime_error; anything else (crash, sanitizer
// report, other exception, hang) is a finding. A parsed trial must satisfy the documented
// invariants and survive a format/parse round trip.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "base/trial.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  fesim::Trial t;
  try {
    t = fesim::ParseTrialCsv(text, "fuzz.csv");
  } catch (const std::runtime_error&) {
    return 0;
  }
  // Invariants of a parsed trial: time non-empty, finite, strictly increasing; columns match.
  if (t.time.empty() || t.names.size() != t.columns.size()) std::abort();
  for (std::size_t i = 0; i < t.time.size(); ++i) {
    if (!std::isfinite(t.time[i])) std::abort();
    if (i > 0 && !(t.time[i] > t.time[i - 1])) std::abort();
  }
  for (const auto& c : t.columns) {
    if (c.size() != t.time.size()) std::abort();
    for (double v : c) {
      if (std::isinf(v)) std::abort();
    }
  }
  // Round trip: what we write we can read back.
  try {
    const fesim::Trial r = fesim::ParseTrialCsv(fesim::FormatTrialCsv(t), "roundtrip.csv");
    if (r.time != t.time || r.names != t.names) std::abort();
  } catch (const std::runtime_error&) {
    // Metadata keys/values or column names can hold characters (',', ':', leading '#') that
    // FormatTrialCsv does not quote; such trials do not round-trip and that is allowed.
  }
  return 0;
}
