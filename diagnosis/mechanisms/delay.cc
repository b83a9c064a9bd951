// delay: electromechanical delay δ between stimulation and force (Cavanagh & Komi 1979;
// sim/mechanisms.h: recruitment sees u(t − δ)). Extension: delay.s, s. Planted: δ = 0.07 s · s.
#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {

Mechanism DelayMechanism() {
  Mechanism m;
  m.id = "delay";
  m.description = "an electromechanical delay between stimulation and movement";
  m.reduced_model_form = true;
  m.candidates = [](const sim::ModelParams&, const LibraryContext&) {
    Candidate c;
    c.params.push_back(
        Param("delay.s", "s", 0.0, 0.0, 0.3, 0.02,
              [](double v, sim::ModelParams* p) { p->mechanisms.electromechanical_delay_s = v; }));
    c.probes = {ProbeAt(c.params, 0, 0.02)};
    c.one_sided = {true};
    return std::vector<Candidate>{c};
  };
  m.plant = [](const PlantContext& ctx, sim::ModelParams* truth, sim::SensorSuite*,
               std::vector<NamedValue>* planted) {
    truth->mechanisms.electromechanical_delay_s = 0.07 * ctx.scale;
    planted->push_back({"delay:delay.s", "s", 0.07 * ctx.scale, NAN});
  };
  m.evidence = InputLagEvidence;
  return m;
}

}  // namespace fesim::diagnosis
