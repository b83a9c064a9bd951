// libFuzzer target: the scenario YAML loader (scenarios/scenario.h ParseScenario).
// Any input must either load or throw std::runtime_error naming the file; anything else (crash,
// sanitizer report, other exception type, hang, runaway memory) is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "scenarios/scenario.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  // The path anchors `stimulation.file` names: a directory that does not exist keeps the fuzzer
  // off the real file system for relative names.
  const std::string path = "/nonexistent-fuzz-dir/fuzz.yaml";
  try {
    const fesim::Scenario sc = fesim::ParseScenario(text, path);
    if (!(sc.trial.duration_s > 0.0)) std::abort();  // the loader guarantees a positive duration
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).rfind(path, 0) != 0) std::abort();  // message must name the file
  }
  return 0;
}
