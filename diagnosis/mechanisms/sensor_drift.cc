// sensor_drift: a drifting offset of the angle sensor (sim/sensors.h plants drift · t).
// Extension: drift.<output>, rad/s, one per output and training trial (value · t added to the
// simulated output, ModelParameter::kOutputDrift; the copies of trial t ≥ 2 are named
// drift.<output>.trial<t>): a sensor zeroed at the start of each recording drifts at that
// recording's own rate and sign (Candidate::drift_per_trial; the independent simulator draws
// them per trial, foreign/effects.h). Planted in fesim's data: 0.0005 s rad/s on every angle
// channel, the same in every trial.
#include <algorithm>
#include <cmath>
#include <map>

#include "diagnosis/mechanisms/library.h"
#include "diagnosis/signatures.h"

namespace fesim::diagnosis {
namespace {

constexpr double kProbeRateRadS = 1e-3;
/// A drift is contradicted when a step adds this many times more to a trend than a trend adds to
/// a step, summed over the training recordings (signatures.h TrendOrStep, one step time for all
/// outputs of a recording: a slipping glove moves every reading at once; a pure trend gives ≈ 0,
/// a pure step ≈ ∞; tests/diagnosis/mechanisms/registry_test.cc) ...
constexpr double kStepOverTrend = 2.0;
/// ... and the largest step stands out of what model misfit shapes like a step: it adds at least
/// N·(2σ)²/16 to the trend (σ² = var(Δr)/2 the residual's white variance, N its samples, both
/// averaged over the recording's outputs) — what a step of 2σ in one reading at mid-recording
/// adds (a line explains 3/4 of its variance N/4·h²). A reduced model's misfit on fesim's own
/// grid trials, drift planted, steps by 1.3σ at a stimulation change (0.12 of N·σ²;
/// reduced_model_test); a foreign glove slip (1018) by 5σ (1.7 of N·σ²).
constexpr double kMinStepHeightInNoise = 2.0;

/// A step is searched where at least this share of the recording lies on either side: a model's
/// start-up transient (the simulation starts at the measured posture, not in the data's state)
/// shapes the first seconds of its residual like a step (a reduced model's on fesim's own 56 s
/// trials: a step at 5.8 s, 2.6 × the trend; reduced_model_test).
constexpr double kStepMargin = 0.2;

/// White-noise variance of a residual, var(Δr)/2, rad².
double WhiteVariance(const std::vector<double>& r) {
  double d2 = 0.0;
  int pairs = 0;
  for (std::size_t i = 1; i < r.size(); ++i) {
    if (std::isfinite(r[i]) && std::isfinite(r[i - 1])) {
      d2 += (r[i] - r[i - 1]) * (r[i] - r[i - 1]);
      ++pairs;
    }
  }
  return pairs > 0 ? d2 / (2.0 * pairs) : 0.0;
}

/// "" when the slow part of the residual is a trend (or no offset stands out of the noise); else
/// where it steps instead.
std::string StepNotTrend(const std::vector<ResidualSeries>& residual) {
  double trend = 0.0, step = 0.0, largest = 0.0, largest_in_noise = 0.0;  // N·σ² units
  std::string where;
  std::map<int, std::vector<const ResidualSeries*>> recordings;
  for (const ResidualSeries& s : residual) recordings[s.trial].push_back(&s);
  for (const auto& [trial, outputs] : recordings) {
    std::vector<std::vector<double>> t, r;
    double white = 0.0;
    for (const ResidualSeries* s : outputs) {
      t.push_back(s->time_s);
      r.push_back(s->r);
      white += WhiteVariance(s->r) * static_cast<double>(s->r.size());
    }
    white /= static_cast<double>(outputs.size());
    const TrendShape shape = TrendOrStep(t, r, kStepMargin);
    trend += shape.trend_beyond_step;
    step += shape.step_beyond_trend;
    if (shape.step_beyond_trend > largest) {
      largest = shape.step_beyond_trend;
      largest_in_noise = white > 0.0 ? largest / white : INFINITY;
      where = outputs[shape.step_series]->output +
              Fmt(" steps by %.3f rad at %.1f s", shape.step_rad, shape.step_time_s) +
              (recordings.size() > 1 || trial > 0 ? Fmt(" of trial %.0f", trial + 1.0) : "");
    }
  }
  if (!(step > kStepOverTrend * trend) ||
      !(largest_in_noise >= kMinStepHeightInNoise * kMinStepHeightInNoise / 16.0)) {
    return "";
  }
  return "the offset steps rather than drifts (" + where +
         Fmt("; a step adds %.3g rad² to a trend, a trend %.3g rad² to a step)", step, trend);
}

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
  m.shape_contradiction = StepNotTrend;
  m.evidence = [](const OutputSignature& s) {
    return Fmt("corr(residual, time) %.2f, corr(residual, cumulative stimulation) %.2f",
               s.corr_time, s.corr_cumulative_stimulation);
  };
  return m;
}

}  // namespace fesim::diagnosis
