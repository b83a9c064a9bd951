#include "apps/api.h"

#include <stdexcept>

#include "apps/commands.h"
#include "fesim/version.h"
#include "sim/upper_limb_model.h"

namespace fesim {

Json IntegrationStatsJson(const sim::TrialResult& r) {
  Json stats = Json::Object();
  stats.Set("steps", static_cast<double>(r.stats.steps))
      .Set("rhs_evaluations", static_cast<double>(r.stats.rhs_evaluations))
      .Set("jacobian_evaluations", static_cast<double>(r.stats.jacobian_evaluations))
      .Set("breakpoints", static_cast<double>(r.stats.breakpoints))
      .Set("fibre_length_clamped", r.fibre_clamped);
  return stats;
}

SimulatedTrial SimulateScenario(const Scenario& sc, const std::function<void(double)>& progress) {
  if (sc.reaching) {
    throw std::runtime_error(sc.path +
                             ": a reaching scenario is one trial per reach; run it with "
                             "`fesim simulate` (files per reach)");
  }
  const sim::UpperLimbModel model(sc.model);
  const sim::TrialResult r = sim::RunTrial(model, sc.trial, progress);
  SimulatedTrial out{r.measured, r.truth, IntegrationStatsJson(r)};
  const std::string hash = Fnv1a64Hex(sc.source_text);
  for (Trial* t : {&out.measured, &out.truth}) {
    t->metadata["scenario"] = sc.name;
    t->metadata["scenario_hash"] = hash;
    t->metadata["fesim_version"] = FESIM_VERSION;
  }
  return out;
}

std::vector<identification::MethodEntry> AllIdentificationMethods() {
  auto methods = identification::BuiltinMethods();
  for (auto& m : ExtraIdentificationMethods()) methods.push_back(std::move(m));
  return methods;
}

const identification::MethodEntry& FindIdentificationMethod(
    const std::vector<identification::MethodEntry>& methods, const std::string& name) {
  for (const auto& m : methods) {
    if (m.name == name) return m;
  }
  std::string list;
  for (const auto& m : methods) list += (list.empty() ? "" : ", ") + m.name;
  throw std::runtime_error("unknown method '" + name + "' (allowed: " + list + ")");
}

}  // namespace fesim
