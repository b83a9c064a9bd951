// libFuzzer target: the JSON reader (base/json.h Json::Parse) and the reader of cached
// predictions built on it (base/result_cache.h TrialsFromJson), which `fesim benchmark`
// and `fesim diagnose` use to resume from DIR/cache. Any input must either parse or throw
// std::runtime_error; a parsed value must print back to the same text (json.h: Dump(Parse(
// Dump(x))) == Dump(x)); TrialsFromJson either throws std::runtime_error or returns trials whose
// columns have the length of their time column.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "base/json.h"
#include "base/result_cache.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  fesim::Json value;
  try {
    value = fesim::Json::Parse(text, "fuzz.json");
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).rfind("fuzz.json", 0) != 0) std::abort();
    return 0;
  }
  for (const int indent : {0, 2}) {
    const std::string once = value.Dump(indent);
    if (fesim::Json::Parse(once, "dump").Dump(indent) != once) std::abort();
  }
  try {
    for (const fesim::Trial& t : fesim::TrialsFromJson(value, "fuzz.json")) {
      for (const auto& c : t.columns) {
        if (c.size() != t.time.size()) std::abort();
      }
    }
  } catch (const std::runtime_error&) {
  }
  return 0;
}
