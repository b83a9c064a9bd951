// The default model's benchmark trial (docs/performance.md "Default model real-time factor" and
// "Work–precision against MuJoCo"): scenarios/default.yaml, every one of the six channels
// stimulated with levels that change every 2 s through a fixed pattern (all muscles active).
#pragma once

#include <string>
#include <vector>

#include "scenarios/scenario.h"

namespace fesim::bench {

/// The default scenario with that stimulation over `duration_s` (≤ 60 s: 30 levels of 2 s).
inline Scenario DefaultModelTrial(double duration_s = 60.0) {
  Scenario sc = LoadScenario(std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/default.yaml");
  sc.trial.duration_s = duration_s;
  auto& stim = sc.trial.stimulation;
  stim.times.clear();
  stim.values.clear();
  const double levels[] = {120, 200, 90, 260, 150, 60, 230, 180};
  for (int k = 0; k < 30; ++k) {
    stim.times.push_back(2.0 * k);
    std::vector<double> u;
    u.reserve(6);
    for (int c = 0; c < 6; ++c) u.push_back(levels[(k + 3 * c) % 8]);
    stim.values.push_back(u);
  }
  return sc;
}

}  // namespace fesim::bench
