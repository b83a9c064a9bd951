// libFuzzer target: what `fesim diagnose` does with measured trials before it simulates
// (diagnosis/measured.h PrepareMeasured) — the trial CSV reader (degree columns, NaN gaps),
// the output rows, the checks against the rig and the training / held-out split.
// The input is one or more trial CSVs separated by a line "%%"; the first byte picks the
// held-out fraction. Any input must either be accepted or throw std::runtime_error whose message
// names the trial's file (or says "diagnose:"); an accepted input must give what the diagnosis
// relies on: outputs and stimulated channels, non-empty training and held-out views with a use
// mask per sample, at least kMinSamples counted samples on each side, uniform time steps.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include "base/trial.h"
#include "diagnosis/measured.h"
#include "sim/default_model.h"

namespace {

// The hand rig of scenarios/hand_rig.yaml: arm held, wrist and fingers free.
const fesim::sim::ModelParams& Rig() {
  static const fesim::sim::ModelParams rig = [] {
    fesim::sim::ModelParams m = fesim::sim::DefaultModelParams();
    for (const char* locked : {"shoulder_elv_plane", "shoulder_elevation", "shoulder_rotation",
                               "elbow_flexion", "pro_sup"}) {
      m.coordinates[fesim::sim::CoordinateIndex(locked)].mode = fesim::sim::CoordinateMode::kLocked;
    }
    return m;
  }();
  return rig;
}

bool StartsWith(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

void CheckView(const fesim::diagnosis::DataView& v, const std::vector<std::string>& outputs) {
  if (v.trials.empty() || v.trials.size() != v.use.size() || v.outputs != outputs) std::abort();
  std::size_t counted = 0;
  for (std::size_t t = 0; t < v.trials.size(); ++t) {
    const fesim::Trial& tr = v.trials[t];
    if (v.use[t].size() != tr.size()) std::abort();
    for (const auto& o : outputs) {
      if (tr.Column(o).size() != tr.size()) std::abort();
    }
    for (char u : v.use[t]) counted += u ? 1 : 0;
  }
  if (counted < fesim::diagnosis::kMinSamples) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const double holdout = 0.05 + 0.75 * (data[0] / 255.0);  // within (0, 0.8]
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  std::vector<fesim::Trial> trials;
  std::size_t start = 0;
  try {
    for (int k = 0; start <= text.size() && k < 8; ++k) {
      std::size_t end = text.find("\n%%\n", start);
      if (end == std::string::npos) end = text.size();
      const std::string name = "fuzz" + std::to_string(k) + ".csv";
      trials.push_back(fesim::ParseTrialCsv(text.substr(start, end - start), name));
      trials.back().metadata["source"] = name;
      start = end + 4;
    }
  } catch (const std::runtime_error& e) {
    if (!StartsWith(e.what(), "fuzz")) std::abort();
    return 0;
  }
  try {
    const fesim::diagnosis::MeasuredData d =
        fesim::diagnosis::PrepareMeasured(Rig(), trials, holdout);
    if (d.outputs.empty() || d.channels.empty() || d.split.empty()) std::abort();
    CheckView(d.train, d.outputs);
    CheckView(d.heldout, d.outputs);
    for (const auto& tr : d.train.trials) {
      const double dt0 = tr.time[1] - tr.time[0];
      if (!(dt0 > 0.0)) std::abort();
      for (std::size_t i = 1; i < tr.size(); ++i) {
        if (std::abs(tr.time[i] - tr.time[i - 1] - dt0) > 1e-3 * dt0 + 1e-12) std::abort();
      }
    }
  } catch (const std::runtime_error& e) {
    if (!StartsWith(e.what(), "fuzz") && !StartsWith(e.what(), "diagnose:")) std::abort();
  }
  return 0;
}
