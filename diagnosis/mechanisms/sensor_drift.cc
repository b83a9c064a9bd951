// sensor_drift: a drifting offset of the angle sensor (sim/sensors.h plants drift · t).
// Extension: drift.<output>, rad/s, one per output and training trial (value · t added to the
// simulated output, ModelParameter::kOutputDrift; the copies of trial t ≥ 2 are named
// drift.<output>.trial<t>): a sensor zeroed at the start of each recording drifts at that
// recording's own rate and sign (Candidate::drift_per_trial; the independent simulator draws
// them per trial, foreign/effects.h). Planted in fesim's data: 0.0005 s rad/s on every angle
// channel, the same in every trial.
#include <algorithm>

#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {
namespace {

constexpr double kProbeRateRadS = 1e-3;

Candidate DriftCandidate(const LibraryContext& ctx) {
  Candidate c;
  const int trials = std::max(1, ctx.training_trials);
  const auto no = static_cast<Eigen::Index>(ctx.outputs.size());
  for (int t = 0; t < trials; ++t) {
    for (const auto& o : ctx.outputs) {
      const std::string suffix = t == 0 ? "" : ".trial" + std::to_string(t + 1);
      ModelParameter p =
          Param("drift." + o + suffix, "rad/s", 0.0, -0.05, 0.05, kProbeRateRadS, nullptr);
      p.target = ModelParameter::Target::kOutputDrift;
      p.column = o;
      p.trial = trials > 1 ? t : -1;
      c.params.push_back(p);
    }
  }
  // Probe o: output o drifting at the probe rate in every trial (split per trial by the screen,
  // screening.h PerTrialDirections: column t·no + o is trial t's).
  for (Eigen::Index o = 0; o < no; ++o) {
    Eigen::VectorXd probe = Starts(c.params);
    for (int t = 0; t < trials; ++t) probe(t * no + o) = kProbeRateRadS;
    c.probes.push_back(probe);
    c.one_sided.push_back(false);
  }
  c.drift_per_trial = trials > 1 || ctx.heldout_recordings_apart;
  const std::vector<ModelParameter> params = c.params;
  c.start_from_step = [params, no, trials](const Eigen::VectorXd& theta) {
    Eigen::VectorXd x = Starts(params);
    const bool split = theta.size() == no * trials;
    for (int t = 0; t < trials; ++t) {
      for (Eigen::Index o = 0; o < no; ++o) {
        const Eigen::Index k = t * no + o;
        x(k) = std::clamp(kProbeRateRadS * theta(split ? k : o), params[k].lower, params[k].upper);
      }
    }
    return x;
  };
  return c;
}

}  // namespace

Mechanism SensorDriftMechanism() {
  Mechanism m;
  m.id = "sensor_drift";
  m.description = "a drifting sensor offset";
  m.reduced_model_form = true;
  m.candidates = [](const sim::ModelParams&, const LibraryContext& ctx) {
    return std::vector<Candidate>{DriftCandidate(ctx)};
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
