#include "scenarios/study.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <random>
#include <stdexcept>

#include "base/trial.h"
#include "scenarios/yaml_node.h"
#include "sim/default_model.h"
#include "sim/sensors.h"

namespace fesim {
namespace {

using internal::Fmt;
using Node = internal::YamlNode;

/// Standard normal draws from a 64-bit Mersenne Twister by Box–Muller (portable, see sensors.h).
class Normal {
 public:
  explicit Normal(std::uint64_t seed) : noise_(seed) {}
  double Draw(const Distribution& d) {
    if (d.sd <= 0.0) return d.mean;
    for (int attempt = 0; attempt < 1000; ++attempt) {
      const double x = d.mean + noise_.Sample(d.sd);
      if (x >= d.min && x <= d.max) return x;
    }
    return std::fmin(std::fmax(d.mean, d.min), d.max);
  }
  double Draw(double sd) { return noise_.Sample(sd); }

 private:
  sim::GaussianNoise noise_;
};

Distribution LoadDistribution(const Node& n, const std::string& key, Distribution d, double lo,
                              double hi) {
  if (!n.Has(key)) return d;
  const Node c = n.Child(key);
  c.Keys({"mean", "sd", "min", "max"});
  c.Number("mean", lo, hi, &d.mean);
  c.Number("sd", 0, hi - lo, &d.sd);
  c.Number("min", lo, hi, &d.min);
  c.Number("max", lo, hi, &d.max);
  if (!(d.min <= d.mean && d.mean <= d.max)) c.Fail("needs min <= mean <= max");
  return d;
}

std::string Directory(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? "" : path.substr(0, slash + 1);
}

}  // namespace

std::vector<Participant> DrawCohort(const CohortParams& c) {
  std::vector<Participant> out;
  for (int k = 0; k < c.size; ++k) {
    Normal rng(sim::DeriveSeed(c.seed, static_cast<std::uint64_t>(k)));
    Participant p;
    p.index = k;
    p.height_m = rng.Draw(c.height_m);
    p.mass_kg = rng.Draw(c.mass_kg);
    p.strength_scale = rng.Draw(c.strength_scale);
    p.recruitment_threshold_scale = rng.Draw(c.recruitment_threshold_scale);
    p.omega_scale = rng.Draw(c.omega_scale);
    p.stiffness_scale = rng.Draw(c.stiffness_scale);
    const Distribution offset{0.0, c.electrode_offset_sd_m, -c.electrode_offset_max_m,
                              c.electrode_offset_max_m};
    p.electrode_offset_along_m = rng.Draw(offset);
    p.electrode_offset_around_m = rng.Draw(offset);
    out.push_back(p);
  }
  return out;
}

void ApplyParticipant(const Participant& p, sim::ModelParams* m) {
  for (auto& mu : m->muscles) {
    mu.hill.max_isometric_force_n *= p.strength_scale;
    // Recruitment thresholds u_db ∝ 1/β ([Hand Hammerstein] eq. 39): a higher threshold is a
    // smaller β.
    mu.recruitment.beta_per_us /= p.recruitment_threshold_scale;
    mu.activation_omega_rad_s *= p.omega_scale;
  }
  for (auto& c : m->coordinates) c.passive.stiffness_nm_per_rad *= p.stiffness_scale;
  m->array.origin.along_m += p.electrode_offset_along_m;
  m->array.origin.around_m += p.electrode_offset_around_m;
  sim::CalibrateReferenceLengths(m);
}

bool IsStudy(const std::string& text) {
  try {
    const YAML::Node n = YAML::Load(text);
    return n.IsMap() && n["study"];
  } catch (const YAML::Exception&) {
    return false;
  }
}

namespace {

Study LoadStudyChecked(const std::string& path, std::uint64_t noise_seed) {
  Study st;
  st.path = path;
  st.source_text = ReadFile(path);
  YAML::Node root;
  try {
    root = YAML::Load(st.source_text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ":" + std::to_string(e.mark.line + 1) +
                             ": YAML syntax: " + e.msg);
  }
  const Node top(root, "", &st.path);
  top.Keys({"study", "scenario", "repetitions", "cohort", "protocols"});
  st.name = top.FileStem("study");
  const std::string scenario_text = top.Text("scenario");
  const std::string base_path =
      scenario_text[0] == '/' ? scenario_text : Directory(path) + scenario_text;
  st.scenario_path = base_path;
  std::string base_text;
  try {
    base_text = ReadFile(base_path);
  } catch (const std::exception& e) {
    top.FailKey("scenario", e.what());
  }
  int repetitions = top.Has("repetitions") ? top.Integer("repetitions", 1, 100) : 1;
  CohortParams& c = st.cohort;
  if (top.Has("cohort")) {
    const Node n = top.Child("cohort");
    n.Keys({"size", "seed", "height_m", "mass_kg", "strength_scale", "recruitment_threshold_scale",
            "omega_scale", "stiffness_scale", "electrode_offset_m"});
    if (n.Has("size")) c.size = n.Integer("size", 1, 1000);
    if (n.Has("seed")) c.seed = static_cast<std::uint64_t>(n.Integer("seed", 0, 1 << 30));
    c.height_m = LoadDistribution(n, "height_m", c.height_m, 1.2, 2.2);
    c.mass_kg = LoadDistribution(n, "mass_kg", c.mass_kg, 30, 150);
    c.strength_scale = LoadDistribution(n, "strength_scale", c.strength_scale, 0.1, 10);
    c.recruitment_threshold_scale =
        LoadDistribution(n, "recruitment_threshold_scale", c.recruitment_threshold_scale, 0.1, 10);
    c.omega_scale = LoadDistribution(n, "omega_scale", c.omega_scale, 0.1, 10);
    c.stiffness_scale = LoadDistribution(n, "stiffness_scale", c.stiffness_scale, 0.1, 10);
    if (n.Has("electrode_offset_m")) {
      const Node e = n.Child("electrode_offset_m");
      e.Keys({"sd", "max"});
      e.Number("sd", 0, 0.1, &c.electrode_offset_sd_m);
      e.Number("max", 0, 0.1, &c.electrode_offset_max_m);
    }
  }
  st.participants = DrawCohort(c);

  const Node protocols = top.Child("protocols");
  struct Protocol {
    std::string name;
    YAML::Node stimulation;
  };
  std::vector<Protocol> list;
  for (std::size_t i = 0; i < protocols.Size(); ++i) {
    const Node p = protocols.Item(i);
    p.Keys({"name", "stimulation"});
    p.Child("stimulation");
    list.push_back({p.FileStem("name"), root["protocols"][i]["stimulation"]});
    for (std::size_t j = 0; j < i; ++j) {
      if (list[j].name == list[i].name)
        p.FailKey("name", "duplicate protocol '" + list[i].name + "'");
    }
  }
  if (list.empty()) top.FailKey("protocols", "needs at least one protocol");

  for (const Participant& part : st.participants) {
    for (std::size_t pi = 0; pi < list.size(); ++pi) {
      for (int r = 0; r < repetitions; ++r) {
        YAML::Node doc = YAML::Load(base_text);
        doc["participant"]["height_m"] = part.height_m;
        doc["participant"]["mass_kg"] = part.mass_kg;
        YAML::Node stim = YAML::Clone(list[pi].stimulation);
        if (stim.IsMap() && stim["protocol"] && stim["protocol"].IsMap()) {
          YAML::Node proto = stim["protocol"];
          const int seed = proto["seed"] ? proto["seed"].as<int>(1) : 1;
          proto["seed"] = seed + r;
          if (proto["name"] && proto["name"].as<std::string>("") == "step_grid" &&
              !proto["order"]) {
            proto["order"] = r % 2 == 0 ? "first_fastest" : "last_fastest";
          }
        }
        doc["stimulation"] = stim;
        StudyItem item;
        item.participant = part.index;
        item.protocol = list[pi].name;
        item.repetition = r;
        try {
          item.scenario = ParseScenario(YAML::Dump(doc), base_path);
        } catch (const std::exception& e) {
          throw std::runtime_error(path + ": protocols[" + std::to_string(pi) + "] (" +
                                   list[pi].name + "): " + e.what());
        }
        item.scenario.name = st.name;
        ApplyParticipant(part, &item.scenario.model);
        item.noise_seed = sim::DeriveSeed(
            noise_seed, (static_cast<std::uint64_t>(part.index) * 1000 + pi) * 1000 + r);
        item.file_stem = "p" + std::to_string(part.index + 1) + "/" + list[pi].name + "_r" +
                         std::to_string(r + 1);
        st.items.push_back(std::move(item));
      }
    }
  }
  return st;
}

}  // namespace

Study LoadStudy(const std::string& path, std::uint64_t noise_seed) {
  return internal::WithYamlErrorsNamed(path, [&] { return LoadStudyChecked(path, noise_seed); });
}

}  // namespace fesim
