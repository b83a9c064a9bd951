#include "foreign/simulate.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <string>

#include "foreign/check.h"
#include "foreign/random.h"

namespace fesim::foreign {
namespace {

constexpr const char* kSource = "fesim foreign simulator";

std::string EffectsLabel(const std::vector<PlantedEffect>& effects) {
  if (effects.empty()) return "none";
  std::ostringstream s;
  s.precision(17);
  for (std::size_t i = 0; i < effects.size(); ++i) {
    s << (i ? "," : "") << effects[i].id << ':' << effects[i].scale;
  }
  return s.str();
}

/// The columns shared by measured and truth: time and the program's pulse widths.
fesim::Trial StimulationColumns(const protocols::StimulationProgram& program,
                                const StimulationSchedule& undelayed,
                                const std::vector<double>& times, int decimals) {
  fesim::Trial t;
  for (double ti : times) t.time.push_back(RoundTime(ti, decimals));
  for (int c = 0; c < kNumChannels; ++c) {
    std::vector<double> u;
    u.reserve(times.size());
    for (double ti : times) u.push_back(undelayed.At(ti)[c]);
    t.AddColumn(std::string("u.") + kChannelNames[c], std::move(u));
  }
  return t;
}

}  // namespace

fesim::Trial SimulateTruth(const Person& person, const std::vector<PlantedEffect>& effects,
                           const protocols::StimulationProgram& program, const SensorSpec& sensor,
                           std::uint64_t seed, const IntegrationSpec& integration) {
  ValidateSensorSpec(sensor);
  const StimulationSchedule undelayed = MakeSchedule(program, 0.0);
  const Plant plant = MakePlant(person, effects, program.duration_s, seed);
  const StimulationSchedule schedule = MakeSchedule(program, plant.stimulation_delay_s);
  const std::vector<double> times = SampleTimes(sensor, program.duration_s);
  const Eigen::VectorXd x0 = RestState(plant, PassiveEquilibrium(plant));
  const std::vector<Eigen::VectorXd> states =
      IntegratePlant(plant, schedule, x0, times, integration);

  fesim::Trial truth = StimulationColumns(program, undelayed, times, sensor.time_decimals);
  std::array<std::vector<double>, kNumJoints> reading, body;
  for (std::size_t i = 0; i < times.size(); ++i) {
    Eigen::Vector3d offset = Eigen::Vector3d::Zero();
    for (const auto& e : plant.effects) offset += e->ReadingOffset(times[i]);
    for (int j = 0; j < kNumJoints; ++j) {
      body[j].push_back(states[i][kStateQ + j]);
      reading[j].push_back(states[i][kStateQ + j] + offset[j]);
    }
  }
  for (int j = 0; j < kNumJoints; ++j) {
    truth.AddColumn(std::string("q.") + kJointNames[j], std::move(reading[j]));
  }
  for (int j = 0; j < kNumJoints; ++j) {
    truth.AddColumn(std::string("qbody.") + kJointNames[j], std::move(body[j]));
  }
  for (int m = 0; m < kNumMuscles; ++m) {
    std::vector<double> a;
    a.reserve(times.size());
    for (const Eigen::VectorXd& x : states) a.push_back(x[kStateActivation + m]);
    truth.AddColumn(std::string("a.") + kMuscleNames[m], std::move(a));
  }
  truth.metadata["source"] = kSource;
  truth.metadata["kind"] = "truth";
  truth.metadata["person_seed"] = std::to_string(person.seed);
  truth.metadata["trial_seed"] = std::to_string(seed);
  truth.metadata["effects"] = EffectsLabel(effects);
  return truth;
}

ForeignTrial SimulateTrial(const Person& person, const std::vector<PlantedEffect>& effects,
                           const protocols::StimulationProgram& program, const SensorSpec& sensor,
                           std::uint64_t seed, const IntegrationSpec& integration) {
  ForeignTrial out;
  out.truth = SimulateTruth(person, effects, program, sensor, seed, integration);
  const fesim::Trial& truth = out.truth;
  fesim::Trial& measured = out.measured;
  measured.time = truth.time;
  for (int c = 0; c < kNumChannels; ++c) {
    const std::string name = std::string("u.") + kChannelNames[c];
    measured.AddColumn(name, truth.Column(name));
  }
  std::mt19937_64 rng(DeriveSeed(seed, "sensor"));
  const std::vector<bool> lost =
      DropoutMask(truth.size(), sensor.dropout_probability, sensor.dropout_mean_samples, rng);
  for (int j = 0; j < kNumJoints; ++j) {
    const std::string name = std::string("q.") + kJointNames[j];
    std::vector<double> q = truth.Column(name);
    for (std::size_t i = 0; i < q.size(); ++i) {
      const double noisy = NoisyReading(q[i], sensor.noise_std_rad, rng);  // drawn even if lost
      q[i] = lost[i] ? std::numeric_limits<double>::quiet_NaN() : noisy;
    }
    measured.AddColumn(name, std::move(q));
  }
  measured.metadata = truth.metadata;
  measured.metadata["kind"] = "measured";
  return out;
}

namespace {

double RmsDifference(const fesim::Trial& a, const fesim::Trial& b) {
  double sum = 0.0;
  std::size_t n = 0;
  for (int j = 0; j < kNumJoints; ++j) {
    const std::string name = std::string("q.") + kJointNames[j];
    const auto& x = a.Column(name);
    const auto& y = b.Column(name);
    for (std::size_t i = 0; i < x.size(); ++i) sum += (x[i] - y[i]) * (x[i] - y[i]);
    n += x.size();
  }
  return std::sqrt(sum / static_cast<double>(std::max<std::size_t>(n, 1)));
}

}  // namespace

double EffectRms(const Person& person, const std::vector<PlantedEffect>& effects,
                 const protocols::StimulationProgram& program, const SensorSpec& sensor,
                 std::uint64_t seed) {
  const fesim::Trial with = SimulateTruth(person, effects, program, sensor, seed);
  const fesim::Trial without = SimulateTruth(person, {}, program, sensor, seed);
  return RmsDifference(with, without);
}

PlantedEffect ScaleToFloor(const Person& person, const PlantedEffect& effect,
                           const protocols::StimulationProgram& program, const SensorSpec& sensor,
                           double floor_ratio, std::uint64_t seed, int max_rounds,
                           double* rms_rad) {
  CheckAbove(floor_ratio, 0.0, 100.0, "floor_ratio");
  CheckRange(max_rounds, 1, 50, "max_rounds");
  const double floor = floor_ratio * sensor.noise_std_rad;
  const fesim::Trial without = SimulateTruth(person, {}, program, sensor, seed);
  PlantedEffect e = effect;
  double rms = 0.0;
  for (int round = 0; round < max_rounds; ++round) {
    rms = RmsDifference(SimulateTruth(person, {e}, program, sensor, seed), without);
    if (rms >= floor || round + 1 == max_rounds) break;
    const double factor = rms > 0.0 ? std::clamp(1.2 * floor / rms, 1.25, 4.0) : 4.0;
    e.scale *= factor;
  }
  if (rms_rad != nullptr) *rms_rad = rms;
  return e;
}

}  // namespace fesim::foreign
