#include "diagnosis/planted.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "scenarios/protocols.h"
#include "scenarios/study.h"
#include "sim/sensors.h"
#include "sim/trial_runner.h"
#include "sim/upper_limb_model.h"

namespace fesim::diagnosis {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// Pseudo-random steps; step times are sample times k / rate_hz of the record (SampleTimes)
/// so that the logged u.* columns are the applied input (a step between two samples would reach
/// the model up to one period early, a timing error outside the candidate library).
sim::StimulationSchedule RandomSteps(const sim::ModelParams& m, const std::vector<int>& idx,
                                     double duration_s, double rate_hz, double max_us,
                                     std::mt19937_64* rng) {
  std::uniform_int_distribution<int> level(0, 5);
  std::uniform_real_distribution<double> hold(1.0, 3.0);
  sim::StimulationSchedule s;
  long k = 0;  // step time in samples
  for (double t = 0.0; t < duration_s; t = static_cast<double>(k) / rate_hz) {
    std::vector<double> u(m.channels.size(), 0.0);
    double total = 0.0;  // Σu ≤ max_us
    for (int c : idx) {
      u[c] = std::min(max_us / 6.0 * level(*rng), max_us - total);
      total += u[c];
    }
    s.times.push_back(t);
    s.values.push_back(u);
    k += std::max(1L, std::lround(hold(*rng) * rate_hz));
  }
  return s;
}

sim::StimulationSchedule Grid(const sim::ModelParams& m, const std::vector<std::string>& channels,
                              double max_us, int order) {
  protocols::StepGridParams g;
  g.channels = channels;
  g.u_max_us = max_us;
  g.spacing_us = max_us / 6.0;
  g.step_duration_s = 2.0;
  g.order = order % 2 ? protocols::GridOrder::kLastChannelFastest
                      : protocols::GridOrder::kFirstChannelFastest;
  const protocols::StimulationProgram prog = protocols::StepGrid(g);
  sim::StimulationSchedule s;
  for (std::size_t k = 0; k < prog.times_s.size(); ++k) {
    std::vector<double> u(m.channels.size(), 0.0);
    for (std::size_t c = 0; c < prog.channels.size(); ++c) {
      for (std::size_t j = 0; j < m.channels.size(); ++j) {
        if (m.channels[j].name == prog.channels[c]) u[j] = prog.values_us[k][c];
      }
    }
    s.times.push_back(prog.times_s[k]);
    s.values.push_back(u);
  }
  return s;
}

/// Sets the candidate parameter `name` of `id` (at the wrist for joint-level ones) through the
/// library's own setter, so planted and fitted parameters mean the same thing.
void SetViaLibrary(const std::string& id, const std::string& name, double value,
                   const LibraryContext& ctx, sim::ModelParams* m,
                   std::vector<NamedValue>* planted) {
  const sim::ModelParams nominal = *m;
  for (const auto& c : CandidateLibrary(nominal, ctx)) {
    if (c.id != id || (!c.joint.empty() && c.joint != "wrist_flexion")) continue;
    for (const auto& p : c.params) {
      if (p.name == name) {
        p.set(value, m);
        planted->push_back({c.label + ":" + name, p.unit, value, NAN});
        return;
      }
    }
  }
  throw std::invalid_argument("planted data: no parameter " + id + ":" + name);
}

}  // namespace

PlantedDataset MakePlantedDataset(const Scenario& rig, const PlantedSpec& spec) {
  if (spec.trials < 1) throw std::invalid_argument("planted data: trials must be >= 1");
  std::mt19937_64 rng(spec.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  PlantedDataset out;
  Participant person;
  person.stiffness_scale = 0.8 * std::pow(1.25 / 0.8, unit(rng));
  person.strength_scale = 0.8 * std::pow(1.25 / 0.8, unit(rng));
  out.stiffness_scale = person.stiffness_scale;
  out.strength_scale = person.strength_scale;
  sim::ModelParams clean = rig.model;
  ApplyParticipant(person, &clean);
  sim::ModelParams truth = clean;
  sim::SensorSuite sensors = rig.trial.sensors;
  const double s = spec.effect_scale;
  LibraryContext ctx;
  for (int c : sensors.angles.coordinates) ctx.outputs.push_back("q." + sim::CoordinateNames()[c]);
  ctx.channels = spec.channels;
  std::vector<int> channel_index;
  for (const auto& name : spec.channels) {
    for (std::size_t k = 0; k < clean.channels.size(); ++k) {
      if (clean.channels[k].name == name) channel_index.push_back(static_cast<int>(k));
    }
  }
  if (spec.channels.size() != 2 || channel_index.size() != 2) {
    throw std::invalid_argument("planted data: need two channels of the rig (spec.channels)");
  }
  double wander_rad = 0.0;
  const double tremor_f = 5.0 + 3.0 * unit(rng), tremor_phase = 2.0 * kPi * unit(rng);
  for (const auto& id : spec.mechanisms) {
    auto& mech = truth.mechanisms;
    const double tj = JointTorqueScale(truth, sim::kWristFlexion);
    if (id == "fatigue") {
      mech.fatigue.enabled = true;
      mech.fatigue.fatigue_time_s = 5.0 / s;
      out.planted.push_back({"fatigue:fatigue.rate_per_s", "1/s", s / 5.0, NAN});
    } else if (id == "potentiation") {
      mech.potentiation.enabled = true;
      mech.potentiation.gain = 2.0 * s;
      out.planted.push_back({"potentiation:potentiation.gain", "1", 2.0 * s, NAN});
      out.planted.push_back(
          {"potentiation:potentiation.rise_time_s", "s", mech.potentiation.rise_time_s, NAN});
    } else if (id == "delay") {
      mech.electromechanical_delay_s = 0.07 * s;
      out.planted.push_back({"delay:delay.s", "s", 0.07 * s, NAN});
    } else if (id == "tremor") {
      mech.tremor.enabled = true;
      mech.tremor.coordinate = sim::kWristFlexion;
      mech.tremor.amplitude_nm = 0.08 * s;
      mech.tremor.frequency_hz = tremor_f;
      mech.tremor.phase_rad = tremor_phase;
      out.planted.push_back({"tremor@wrist_flexion:tremor.amplitude_nm", "N*m", 0.08 * s, NAN});
      out.planted.push_back({"tremor@wrist_flexion:tremor.frequency_hz", "Hz", tremor_f, NAN});
    } else if (id == "crosstalk") {
      SetViaLibrary(id, "crosstalk.fraction", 0.06 * s, ctx, &truth, &out.planted);
    } else if (id == "moment_arm_posture") {
      SetViaLibrary(id, "momentarm.posture_ratio", 2.0 * s, ctx, &truth, &out.planted);
    } else if (id == "force_length_velocity") {
      SetViaLibrary(id, "hill.vmax_scale", 1.0 / (1.0 + 2.0 * s), ctx, &truth, &out.planted);
    } else if (id == "unequal_muscle_dynamics") {
      SetViaLibrary(id, "omega.ext_flex_ratio", 1.0 + 0.4 * s, ctx, &truth, &out.planted);
    } else if (id == "passive_stiffness_nonlinear") {
      SetViaLibrary(id, "passive.limit_scale", 1.0 + 20.0 * s, ctx, &truth, &out.planted);
      SetViaLibrary(id, "passive.sharpness_per_rad", 5.0, ctx, &truth, &out.planted);
    } else if (id == "stiction") {
      SetViaLibrary(id, "friction.coulomb_nm", 0.04 * s * tj, ctx, &truth, &out.planted);
      SetViaLibrary(id, "friction.static_excess_nm", 0.04 * s * tj, ctx, &truth, &out.planted);
    } else if (id == "spasticity") {
      SetViaLibrary(id, "reflex.gain_nms_per_rad", 0.4 * s * tj, ctx, &truth, &out.planted);
      SetViaLibrary(id, "reflex.threshold_rad_s", 0.5, ctx, &truth, &out.planted);
    } else if (id == "sensor_drift") {
      sensors.angles.offset_drift_per_s = 0.0005 * s;
      for (const auto& o : ctx.outputs) {
        out.planted.push_back({"sensor_drift:drift." + o, "rad/s", 0.0005 * s, NAN});
      }
    } else if (id == "arm_support") {
      SetViaLibrary(id, "support.weight_compensation_n",
                    ForearmSupportCuff(truth).force_n + 0.25 * s * ForearmWeightN(truth), ctx,
                    &truth, &out.planted);
    } else if (id == "outside") {
      wander_rad = 1.5 * s * kPi / 180.0;
    } else {
      throw std::invalid_argument("planted data: unknown mechanism '" + id + "'");
    }
  }
  out.noise_rms_rad = sensors.angles.noise_std;
  const sim::UpperLimbModel truth_model(truth), clean_model(clean);
  double effect_ss = 0.0;
  long effect_n = 0;
  for (int t = 0; t < spec.trials; ++t) {
    sim::TrialRequest req = rig.trial;
    req.name = "planted_" + std::to_string(t);
    req.sensors = sensors;
    req.seed = sim::DeriveSeed(spec.seed, 100 + t);
    req.steady_state_times_s.clear();
    if (spec.protocol == "steps") {
      req.stimulation = RandomSteps(truth, channel_index, spec.duration_s, sensors.angles.rate_hz,
                                    spec.max_us, &rng);
      req.duration_s = spec.duration_s;
    } else if (spec.protocol == "grid") {
      req.stimulation = Grid(truth, spec.channels, spec.max_us, t + static_cast<int>(spec.seed));
      req.duration_s = 56.0;
    } else {
      throw std::invalid_argument("planted data: unknown protocol '" + spec.protocol + "'");
    }
    req.sensors.truth_rate_hz = req.sensors.angles.rate_hz;
    sim::TrialResult with = sim::RunTrial(truth_model, req);
    const sim::TrialResult without = sim::RunTrial(clean_model, req);
    Trial measured = with.measured;
    measured.metadata["planted"] = spec.mechanisms.empty() ? "none" : spec.mechanisms[0];
    for (const auto& o : ctx.outputs) {
      auto& y = measured.MutableColumn(o);
      for (std::size_t i = 0; i < y.size(); ++i) {
        y[i] += wander_rad * std::sin(2.0 * kPi * 0.1 * measured.time[i]);
      }
      // Effect size from the truth records (same grid), plus the sensor-level effects.
      const auto& a = with.truth.Column(o);
      const auto& b = without.truth.Column(o);
      for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) {
        const double ti = with.truth.time[i];
        const double d = a[i] - b[i] + sensors.angles.offset_drift_per_s * ti +
                         wander_rad * std::sin(2.0 * kPi * 0.1 * ti);
        effect_ss += d * d;
        ++effect_n;
      }
    }
    out.trials.push_back(std::move(measured));
  }
  out.effect_rms_rad = effect_n ? std::sqrt(effect_ss / effect_n) : 0.0;
  return out;
}

std::vector<std::string> PlantedProtocols(const std::string& id) {
  if (id == "spasticity") return {"steps"};
  return {"steps", "grid"};
}

PlantedDataset MakePlantedDatasetAtLeast(const Scenario& rig, PlantedSpec* spec, double min_ratio,
                                         double max_scale, int max_regenerations) {
  PlantedDataset data = MakePlantedDataset(rig, *spec);
  for (int k = 0; k < max_regenerations && min_ratio > 0.0; ++k) {
    const double ratio = data.effect_rms_rad / data.noise_rms_rad;
    if (ratio >= min_ratio || spec->effect_scale >= max_scale) break;
    const double grow = ratio > 0.0 ? 1.05 * min_ratio / ratio : 2.0;
    spec->effect_scale = std::min(max_scale, spec->effect_scale * grow);
    data = MakePlantedDataset(rig, *spec);
  }
  return data;
}

}  // namespace fesim::diagnosis
