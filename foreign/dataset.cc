#include "foreign/dataset.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "foreign/random.h"

namespace fesim::foreign {
namespace {

constexpr double kMaxUs = 300.0;
constexpr double kLevelUs = 50.0;

protocols::StimulationProgram Steps(double duration_s, double rate_hz, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  protocols::StimulationProgram p;
  p.channels = {"ext", "flex"};
  p.duration_s = duration_s;
  long k = 0;  // step time in samples
  for (double t = 0.0; t < duration_s; t = static_cast<double>(k) / rate_hz) {
    double total = 0.0;
    std::vector<double> u(2);
    for (double& v : u) {
      const double level = std::floor(UniformIn(rng, 0.0, 6.0));
      v = std::min(kLevelUs * level, kMaxUs - total);
      total += v;
    }
    p.times_s.push_back(t);
    p.values_us.push_back(u);
    k += std::max(1L, std::lround(UniformIn(rng, 1.0, 3.0) * rate_hz));
  }
  return p;
}

double RmsDifference(const std::vector<fesim::Trial>& a, const std::vector<fesim::Trial>& b) {
  double ss = 0.0;
  long n = 0;
  for (std::size_t t = 0; t < a.size(); ++t) {
    for (const auto& name : a[t].NamesWithPrefix("q.")) {
      const auto& x = a[t].Column(name);
      const auto& y = b[t].Column(name);
      for (std::size_t i = 0; i < x.size(); ++i) {
        ss += (x[i] - y[i]) * (x[i] - y[i]);
        ++n;
      }
    }
  }
  return n ? std::sqrt(ss / static_cast<double>(n)) : 0.0;
}

}  // namespace

protocols::StimulationProgram DatasetProgram(const std::string& name, double duration_s,
                                             std::uint64_t seed) {
  if (name == "steps") return Steps(duration_s, SensorSpec().rate_hz, seed);
  if (name == "grid") {
    protocols::StepGridParams g;
    g.channels = {"ext", "flex"};
    g.u_max_us = kMaxUs;
    g.spacing_us = kLevelUs;
    g.step_duration_s = 2.0;
    g.order = seed % 2 ? protocols::GridOrder::kLastChannelFastest
                       : protocols::GridOrder::kFirstChannelFastest;
    return protocols::StepGrid(g);
  }
  if (name == "multisine") {
    protocols::MultisineParams m;
    m.channels = {"flex", "ext"};
    m.duration_s = duration_s;
    m.seed = seed;
    m.limit.sum_max_us = kMaxUs;
    return protocols::Multisine(m);
  }
  throw std::invalid_argument("foreign data set: unknown protocol '" + name +
                              "' (allowed: steps, grid, multisine)");
}

protocols::StimulationProgram HeldProgram(const fesim::Trial& record) {
  const std::vector<std::string> names = record.NamesWithPrefix("u.");
  if (names.empty() || record.size() < 2) {
    throw std::invalid_argument("foreign: HeldProgram needs u.* columns and >= 2 samples");
  }
  protocols::StimulationProgram program;
  std::vector<const std::vector<double>*> columns;
  for (const auto& n : names) {
    program.channels.push_back(n.substr(2));
    columns.push_back(&record.Column(n));
  }
  for (std::size_t i = 0; i < record.size(); ++i) {
    std::vector<double> values;
    values.reserve(columns.size());
    for (const auto* c : columns) values.push_back((*c)[i]);
    if (i == 0 || values != program.values_us.back()) {
      program.times_s.push_back(record.time[i] - record.time[0]);
      program.values_us.push_back(std::move(values));
    }
  }
  program.duration_s = record.time.back() - record.time[0];
  // A switch at the last sample is never held: the program ends there.
  if (program.times_s.size() > 1 && program.times_s.back() >= program.duration_s) {
    program.times_s.pop_back();
    program.values_us.pop_back();
  }
  return program;
}

Dataset MakeDataset(const DatasetSpec& spec) {
  Dataset out;
  out.person = DrawPerson(spec.spread, spec.person_seed);
  out.noise_rms_rad = spec.sensor.noise_std_rad;
  std::vector<protocols::StimulationProgram> programs;
  for (std::size_t k = 0; k < spec.protocols.size(); ++k) {
    programs.push_back(DatasetProgram(spec.protocols[k], spec.duration_s,
                                      DeriveSeed(spec.seed, "protocol " + std::to_string(k))));
  }
  const auto trial_seed = [&](std::size_t k) {
    return DeriveSeed(spec.seed, "trial " + std::to_string(k));
  };
  out.effects = spec.effects;
  if (spec.floor > 0.0 && !programs.empty()) {
    for (auto& e : out.effects) {
      e = ScaleToFloor(out.person, e, programs[0], spec.sensor, spec.floor, trial_seed(0));
    }
  }
  // The floor over all trials together: raise every scale while the combined effect is below.
  for (int round = 0; round < 6; ++round) {
    std::vector<fesim::Trial> with, without;
    for (std::size_t k = 0; k < programs.size(); ++k) {
      with.push_back(
          SimulateTruth(out.person, out.effects, programs[k], spec.sensor, trial_seed(k)));
      without.push_back(SimulateTruth(out.person, {}, programs[k], spec.sensor, trial_seed(k)));
    }
    out.effect_rms_rad = out.effects.empty() ? 0.0 : RmsDifference(with, without);
    if (out.effects.empty() || spec.floor <= 0.0 ||
        out.effect_rms_rad >= spec.floor * out.noise_rms_rad) {
      break;
    }
    const double grow =
        std::clamp(1.1 * spec.floor * out.noise_rms_rad / out.effect_rms_rad, 1.1, 4.0);
    for (auto& e : out.effects) e.scale *= grow;
  }
  for (std::size_t k = 0; k < programs.size(); ++k) {
    ForeignTrial t =
        SimulateTrial(out.person, out.effects, programs[k], spec.sensor, trial_seed(k));
    t.measured.metadata["protocol"] = spec.protocols[k];
    out.trials.push_back(std::move(t.measured));
    out.truth.push_back(std::move(t.truth));
  }
  return out;
}

}  // namespace fesim::foreign
