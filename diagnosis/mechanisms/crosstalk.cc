// crosstalk: stimulation current reaching muscles beyond the intended ones — a second, wider
// Gaussian spread on the electrode array (fraction c, σ_x = 0.03 m; sim/mechanisms.h). Only with
// array channels. Extension: crosstalk.fraction c. Planted: c = 0.06 s (at 0.015 s the effect RMS
// is ≈ the noise RMS, but 95 % of it is absorbed by the person calibration).
#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {

Mechanism CrosstalkMechanism() {
  Mechanism m;
  m.id = "crosstalk";
  m.description = "electrode crosstalk (current reaching other muscles)";
  m.reduced_model_form = true;
  m.candidates = [](const sim::ModelParams& rig, const LibraryContext& ctx) {
    Candidate c;
    bool array = false;
    for (const auto& ch : rig.channels) {
      for (const auto& name : ctx.channels) array |= ch.name == name && !ch.pads.empty();
    }
    if (!array) {
      c.applicable = false;
      c.not_applicable_reason = "no stimulated channel uses the electrode array";
      return std::vector<Candidate>{c};
    }
    c.params.push_back(
        Param("crosstalk.fraction", "1", 0.0, 0.0, 1.0, 0.1,
              [](double v, sim::ModelParams* p) { p->mechanisms.crosstalk.fraction = v; }));
    c.probes = {ProbeAt(c.params, 0, 0.1)};
    c.one_sided = {true};
    return std::vector<Candidate>{c};
  };
  m.plant = [](const PlantContext& ctx, sim::ModelParams* truth, sim::SensorSuite*,
               std::vector<NamedValue>* planted) {
    PlantViaCandidate("crosstalk", "crosstalk.fraction", 0.06 * ctx.scale, ctx.library, truth,
                      planted);
  };
  m.evidence = InputLagEvidence;
  return m;
}

}  // namespace fesim::diagnosis
