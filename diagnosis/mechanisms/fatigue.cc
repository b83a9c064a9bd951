// fatigue: muscle force falling with accumulated stimulation (Riener, Quintern & Schmidt 1996,
// sim/mechanisms.h). Extension: fatigue.rate_per_s = 1/T_fat, 1/s (0 = off). Planted: T_fat = 5
// s/s.
#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {

Mechanism FatigueMechanism() {
  Mechanism m;
  m.id = "fatigue";
  m.description = "muscle fatigue (force falling with accumulated stimulation)";
  m.reduced_model_form = true;
  m.candidates = [](const sim::ModelParams&, const LibraryContext&) {
    Candidate c;
    c.params.push_back(
        Param("fatigue.rate_per_s", "1/s", 0.0, 0.0, 1.0, 0.01, [](double v, sim::ModelParams* p) {
          p->mechanisms.fatigue.enabled = v > 1e-12;
          if (v > 1e-12) p->mechanisms.fatigue.fatigue_time_s = 1.0 / v;
        }));
    c.probes = {ProbeAt(c.params, 0, 0.05)};
    c.one_sided = {true};
    return std::vector<Candidate>{c};
  };
  m.plant = [](const PlantContext& ctx, sim::ModelParams* truth, sim::SensorSuite*,
               std::vector<NamedValue>* planted) {
    truth->mechanisms.fatigue.enabled = true;
    truth->mechanisms.fatigue.fatigue_time_s = 5.0 / ctx.scale;
    planted->push_back({"fatigue:fatigue.rate_per_s", "1/s", ctx.scale / 5.0, NAN});
  };
  m.evidence = UseEvidence;
  return m;
}

}  // namespace fesim::diagnosis
