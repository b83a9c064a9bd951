// What the subcommands do, as functions on values rather than files: `fesim simulate` and
// `fesim identify` call them, and so does the Python module (python/module.cc), so that both
// compute the same things and fail with the same one-line messages.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "base/json.h"
#include "base/trial.h"
#include "identification/method.h"
#include "scenarios/scenario.h"
#include "sim/trial_runner.h"

namespace fesim {

/// One simulated trial of a scenario: the measured trial and the truth, each stamped with the
/// scenario's name, the FNV-1a hash of its file and the fesim version (metadata `scenario`,
/// `scenario_hash`, `fesim_version`), and the integrator's statistics.
struct SimulatedTrial {
  Trial measured, truth;
  Json stats = Json::Object();  ///< steps, rhs_evaluations, jacobian_evaluations, breakpoints,
                                ///< fibre_length_clamped.
};

/// Runs the scenario's trial (its seed in sc.trial.seed); `progress` gets the fraction of
/// simulated time. A reaching scenario is refused (std::runtime_error naming it: `fesim simulate`
/// writes one trial per reach). Integration failures throw std::runtime_error (sim::RunTrial).
SimulatedTrial SimulateScenario(const Scenario& sc,
                                const std::function<void(double)>& progress = nullptr);

/// The integrator statistics of a trial as JSON (the `integration` record of manifest.json).
Json IntegrationStatsJson(const sim::TrialResult& r);

/// Every identification method: identification/'s own, then ExtraIdentificationMethods().
std::vector<identification::MethodEntry> AllIdentificationMethods();

/// The method called `name`; std::runtime_error "unknown method 'NAME' (allowed: …)" otherwise.
const identification::MethodEntry& FindIdentificationMethod(
    const std::vector<identification::MethodEntry>& methods, const std::string& name);

}  // namespace fesim
