#include "diagnosis/planted.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "diagnosis/mechanisms/mechanism.h"
#include "protocols/protocols.h"
#include "scenarios/study.h"
#include "sim/default_model.h"
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

/// Log-uniform factor in [lo, hi].
double LogUniform(std::mt19937_64* rng, double lo, double hi) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  return lo * std::pow(hi / lo, unit(*rng));
}

double Uniform(std::mt19937_64* rng, double lo, double hi) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  return lo + (hi - lo) * unit(*rng);
}

/// The wide person of planted.h on `m`.
void ApplyWidePerson(std::mt19937_64* rng, sim::ModelParams* m) {
  const double omega = Uniform(rng, 0.7, 1.3);
  for (auto& mu : m->muscles) {
    mu.recruitment.beta_per_us *= LogUniform(rng, 0.5, 2.0);
    mu.recruitment.gamma *= LogUniform(rng, 0.5, 2.0);
    mu.activation_omega_rad_s *= omega;
    mu.hill.max_isometric_force_n *= LogUniform(rng, 1.0 / 1.5, 1.5);
    for (auto& cr : mu.path.crossings) {
      const double f = Uniform(rng, 0.75, 1.25);
      cr.arm.d_m *= f;
      cr.arm.d_tilde_m *= f;
    }
  }
  for (auto& seg : m->segments) {
    const double f = Uniform(rng, 0.8, 1.2);
    seg.mass_kg *= f;
    for (double& i : seg.inertia_about_com_kg_m2) i *= f;
  }
  for (auto& c : m->coordinates) {
    c.passive.stiffness_nm_per_rad *= LogUniform(rng, 0.5, 2.0);
    c.passive.damping_nms_per_rad *= LogUniform(rng, 0.5, 2.0);
    if (c.mode == sim::CoordinateMode::kFree) {
      c.passive.rest_angle_rad += Uniform(rng, -10.0, 10.0) * kPi / 180.0;
      c.initial_rad = c.passive.rest_angle_rad;
    }
  }
  m->array.origin.along_m += Uniform(rng, -0.01, 0.01);
  m->array.origin.around_m += Uniform(rng, -0.01, 0.01);
  // Muscles at their optimal length at the new rest posture (as sim/default_model.h builds them).
  sim::CalibrateReferenceLengths(m);
}

}  // namespace

sim::ModelParams DrawPerson(const sim::ModelParams& rig, PersonSpread spread, std::mt19937_64* rng,
                            double* stiffness_scale, double* strength_scale) {
  sim::ModelParams m = rig;
  Participant person;
  person.stiffness_scale = 0.8 * std::pow(1.25 / 0.8, Uniform(rng, 0.0, 1.0));
  person.strength_scale = 0.8 * std::pow(1.25 / 0.8, Uniform(rng, 0.0, 1.0));
  if (spread == PersonSpread::kNarrow) {
    ApplyParticipant(person, &m);
    *stiffness_scale = person.stiffness_scale;
    *strength_scale = person.strength_scale;
    return m;
  }
  ApplyWidePerson(rng, &m);
  *stiffness_scale = *strength_scale = 1.0;
  return m;
}

PlantedDataset MakePlantedDataset(const Scenario& rig, const PlantedSpec& spec) {
  if (spec.trials < 1) throw std::invalid_argument("planted data: trials must be >= 1");
  std::mt19937_64 rng(spec.seed);
  PlantedDataset out;
  const sim::ModelParams clean =
      DrawPerson(rig.model, spec.person, &rng, &out.stiffness_scale, &out.strength_scale);
  out.person = clean;
  sim::ModelParams truth = clean;
  sim::SensorSuite sensors = rig.trial.sensors;
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
  PlantContext plant{ctx, spec.effect_scale, Uniform(&rng, 5.0, 8.0),
                     Uniform(&rng, 0.0, 2.0 * kPi)};
  for (const auto& id : spec.mechanisms) {
    if (id == "outside") {
      wander_rad = 1.5 * spec.effect_scale * kPi / 180.0;
      continue;
    }
    FindMechanism(id).plant(plant, &truth, &sensors, &out.planted);
  }
  out.noise_rms_rad = sensors.angles.noise_std;
  const sim::UpperLimbModel truth_model(truth), clean_model(clean);
  double effect_ss = 0.0;
  long effect_n = 0;
  for (int t = 0; t < spec.trials; ++t) {
    sim::TrialRequest req = rig.trial;
    // The planted effect's size is the difference of two simulations (with − without): ground
    // truth's tolerance when the rig states none, as before trial generation's default was
    // chosen by accuracy, so that the planted suites' results stay comparable
    // (sim/task_tolerances.h).
    if (!req.integrator.tolerance) req.integrator.tolerance = sim::TaskTolerances::kGroundTruth;
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
    Trial noiseless;  // the outputs without noise, on the measured record's grid
    noiseless.time = with.measured.time;
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
      // The truth record's samples at the measured record's times (the angle sensor's grid, a
      // subset of the measured one, which joins every sensor's grid).
      std::vector<double> z(noiseless.size(), std::numeric_limits<double>::quiet_NaN());
      for (std::size_t i = 0, k = 0; i < a.size(); ++i) {
        const double ti = with.truth.time[i];
        while (k < z.size() && noiseless.time[k] < ti - 1e-9) ++k;
        if (k == z.size() || noiseless.time[k] > ti + 1e-9) continue;
        z[k] = a[i] + sensors.angles.offset_drift_per_s * ti +
               wander_rad * std::sin(2.0 * kPi * 0.1 * ti);
      }
      noiseless.AddColumn(o, std::move(z));
    }
    out.trials.push_back(std::move(measured));
    out.truth.push_back(std::move(noiseless));
  }
  out.effect_rms_rad = effect_n ? std::sqrt(effect_ss / effect_n) : 0.0;
  return out;
}

std::vector<std::string> PlantedProtocols(const std::string& id) {
  if (id == "outside") return {"steps", "grid"};
  return FindMechanism(id).planted_protocols;
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
