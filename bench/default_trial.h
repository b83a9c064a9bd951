// The default model's benchmark trial (docs/performance.md "Default model real-time factor" and
// "Work–precision against MuJoCo"): scenarios/default.yaml, every one of the six channels
// stimulated with levels that change every 2 s through a fixed pattern (all muscles active).
#pragma once

#include <string>
#include <vector>

#include "scenarios/scenario.h"
#include "sim/integrator.h"
#include "sim/sensors.h"
#include "sim/trial_runner.h"
#include "sim/upper_limb_model.h"

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

/// The scenario's trial on `model` recording only q (rad) at `rate_hz`, as the fits simulate and
/// as MuJoCo's rows of bench/mujoco_work_precision.cc record (sim::IntegrateTrialVariables, no
/// truth or sensor records): q[sample * kNumCoordinates + coordinate] into *q (cleared first).
inline sim::IntegrationStats SimulateCoordinates(const sim::UpperLimbModel& model,
                                                 const Scenario& sc,
                                                 const sim::IntegratorParams& integrator,
                                                 double rate_hz, std::vector<double>* q) {
  const std::vector<double> times = sim::SampleTimes(rate_hz, sc.trial.duration_s);
  q->clear();
  q->reserve(times.size() * sim::kNumCoordinates);
  SimTK::State state = model.MakeInitialState();
  return sim::IntegrateTrialVariables(
      model, integrator, sim::MuscleStimulation(model.params(), sc.trial.stimulation), times,
      &state,
      [&](double, const double* y) {
        for (int c = 0; c < sim::kNumCoordinates; ++c) q->push_back(model.GetQ(state, y, c));
      },
      sim::VariablesObserved::kPositionsAndSpeeds);
}

}  // namespace fesim::bench
