// sensor_drift: a drifting offset of the angle sensor (sim/sensors.h plants drift · t).
// Extension: drift.<output>, rad/s, one per output (value · t added to the simulated output,
// ModelParameter::kOutputDrift). Planted: 0.0005 s rad/s on every angle channel.
#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {

Mechanism SensorDriftMechanism() {
  Mechanism m;
  m.id = "sensor_drift";
  m.description = "a drifting sensor offset";
  m.reduced_model_form = true;
  m.candidates = [](const sim::ModelParams&, const LibraryContext& ctx) {
    Candidate c;
    for (const auto& o : ctx.outputs) {
      ModelParameter p = Param("drift." + o, "rad/s", 0.0, -0.05, 0.05, 1e-3, nullptr);
      p.target = ModelParameter::Target::kOutputDrift;
      p.column = o;
      c.params.push_back(p);
    }
    for (std::size_t k = 0; k < c.params.size(); ++k) {
      c.probes.push_back(ProbeAt(c.params, static_cast<int>(k), 1e-3));
      c.one_sided.push_back(false);
    }
    return std::vector<Candidate>{c};
  };
  m.plant = [](const PlantContext& ctx, sim::ModelParams*, sim::SensorSuite* sensors,
               std::vector<NamedValue>* planted) {
    sensors->angles.offset_drift_per_s = 0.0005 * ctx.scale;
    for (const auto& o : ctx.library.outputs) {
      planted->push_back({"sensor_drift:drift." + o, "rad/s", 0.0005 * ctx.scale, NAN});
    }
  };
  m.evidence = [](const OutputSignature& s) {
    return Fmt("corr(residual, time) %.2f, corr(residual, cumulative stimulation) %.2f",
               s.corr_time, s.corr_cumulative_stimulation);
  };
  return m;
}

}  // namespace fesim::diagnosis
