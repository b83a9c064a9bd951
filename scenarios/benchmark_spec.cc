#include "scenarios/benchmark_spec.h"

#include <yaml-cpp/yaml.h>

#include <set>
#include <stdexcept>

#include "base/trial.h"
#include "scenarios/yaml_node.h"

namespace fesim {
namespace {

using Node = internal::YamlNode;

std::string Directory(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? "" : path.substr(0, slash + 1);
}

BenchmarkSection LoadSection(const Node& top, const std::string& key, const std::string& dir) {
  const Node n = top.Child(key);
  const bool reaching = key == "reaching";
  const std::string file_key = reaching ? "scenario" : "study";
  const std::string quick_key = reaching ? "quick_scenario" : "quick_study";
  std::set<std::string> keys = {file_key, quick_key, "methods", "options"};
  if (key == "hand_array") {
    keys.insert("full_model");
    keys.insert("quick_full_model");
    keys.insert("independent");
    keys.insert("quick_independent");
  }
  if (reaching) {
    keys.insert("sparse_scenario");
    keys.insert("quick_sparse_scenario");
  }
  n.Keys(keys);
  BenchmarkSection s;
  const auto resolve = [&](const std::string& k) {
    const std::string text = n.Text(k);
    std::string p = !text.empty() && text[0] == '/' ? text : dir + text;
    try {
      ReadFile(p);
    } catch (const std::exception& e) {
      n.FailKey(k, e.what());
    }
    return p;
  };
  s.study_path = resolve(file_key);
  s.quick_study_path = n.Has(quick_key) ? resolve(quick_key) : s.study_path;
  if (reaching && n.Has("sparse_scenario")) {
    s.sparse_path = resolve("sparse_scenario");
    s.quick_sparse_path =
        n.Has("quick_sparse_scenario") ? resolve("quick_sparse_scenario") : s.sparse_path;
  } else if (reaching && n.Has("quick_sparse_scenario")) {
    n.FailKey("quick_sparse_scenario", "needs sparse_scenario");
  }
  const std::vector<std::string>& allowed = BenchmarkSectionMethods().at(key);
  if (n.Has("methods")) {
    for (const auto& m : n.Child("methods").TextList()) {
      bool ok = false;
      for (const auto& a : allowed) ok = ok || a == m;
      if (!ok) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : "|") + a;
        n.FailKey("methods", "'" + m + "' is not one of " + list);
      }
      s.methods.push_back(m);
    }
    if (s.methods.empty()) n.FailKey("methods", "needs at least one method");
  } else {
    s.methods = allowed;
  }
  if (n.Has("options")) {
    const Node o = n.Child("options");
    for (const auto& k : o.MapKeys()) {
      if (k.find('.') == std::string::npos) {
        o.FailKey(k, "expected <method prefix>.<option>, e.g. tremor.eps");
      }
      s.options[k] = o.Text(k);
    }
  }
  return s;
}

FullModelBudget LoadBudget(const Node& h, const std::string& key, FullModelBudget m) {
  const Node f = h.Child(key);
  f.Keys({"keep", "starts", "max_iterations", "relative_tolerance", "integrator_tolerance",
          "fd_relative_step", "broyden", "rank_once"});
  if (f.Has("keep")) m.keep = f.Integer("keep", 1, 39);
  if (f.Has("starts")) m.starts = f.Integer("starts", 1, 100);
  if (f.Has("max_iterations")) m.max_iterations = f.Integer("max_iterations", 1, 1000);
  f.Number("relative_tolerance", 1e-12, 0.1, &m.relative_tolerance);
  f.Number("integrator_tolerance", 1e-8, 1e-2, &m.integrator_tolerance);
  f.Number("fd_relative_step", 1e-8, 0.1, &m.fd_relative_step);
  if (f.Has("broyden")) m.broyden = f.Choice("broyden", {"true", "false"}) == "true";
  if (f.Has("rank_once")) m.rank_once = f.Choice("rank_once", {"true", "false"}) == "true";
  return m;
}

IndependentCohort LoadIndependent(const Node& h, const std::string& key, IndependentCohort c) {
  const Node n = h.Child(key);
  n.Keys({"participants", "seed"});
  if (n.Has("participants")) c.participants = n.Integer("participants", 0, 100);
  if (n.Has("seed")) c.seed = static_cast<std::uint64_t>(n.Integer("seed", 0, 1000000000));
  return c;
}

BenchmarkSpec ParseChecked(const std::string& text, const std::string& path) {
  BenchmarkSpec b;
  b.path = path;
  b.source_text = text;
  YAML::Node root;
  try {
    root = YAML::Load(b.source_text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ":" + std::to_string(e.mark.line + 1) +
                             ": YAML syntax: " + e.msg);
  }
  const Node top(root, "", &b.path);
  top.Keys({"benchmark", "hand_array", "elbow_tests", "tremor_wrist", "shoulder", "reaching",
            "assumptions"});
  b.name = top.Text("benchmark");
  const std::string dir = Directory(path);
  if (top.Has("hand_array")) {
    b.hand_array = LoadSection(top, "hand_array", dir);
    const Node h = top.Child("hand_array");
    if (h.Has("full_model")) b.full_model = LoadBudget(h, "full_model", b.full_model);
    b.quick_full_model = b.full_model;
    if (h.Has("quick_full_model")) {
      b.quick_full_model = LoadBudget(h, "quick_full_model", b.quick_full_model);
    }
    if (h.Has("independent")) b.independent = LoadIndependent(h, "independent", b.independent);
    b.quick_independent = b.independent;
    if (h.Has("quick_independent")) {
      b.quick_independent = LoadIndependent(h, "quick_independent", b.quick_independent);
    }
  }
  if (top.Has("elbow_tests")) b.elbow_tests = LoadSection(top, "elbow_tests", dir);
  if (top.Has("tremor_wrist")) b.tremor_wrist = LoadSection(top, "tremor_wrist", dir);
  if (top.Has("shoulder")) b.shoulder = LoadSection(top, "shoulder", dir);
  if (top.Has("reaching")) b.reaching = LoadSection(top, "reaching", dir);
  if (top.Has("assumptions")) {
    const Node a = top.Child("assumptions");
    a.Keys({"participants"});
    b.assumption_participants = a.Integer("participants", 1, 1000);
    if (!b.hand_array) top.FailKey("assumptions", "needs the hand_array section");
  }
  if (!b.hand_array && !b.elbow_tests && !b.tremor_wrist && !b.shoulder && !b.reaching) {
    top.Fail("needs at least one of hand_array, elbow_tests, tremor_wrist, shoulder, reaching");
  }
  return b;
}

}  // namespace

const std::map<std::string, std::vector<std::string>>& BenchmarkSectionMethods() {
  static const std::map<std::string, std::vector<std::string>> kMethods = {
      {"hand_array", {"full-model", "hammerstein-mimo"}},
      {"elbow_tests", {"spline-arx", "spline-oe"}},
      {"tremor_wrist", {"tremor-arx"}},
      {"shoulder", {"shoulder-model1", "shoulder-model2", "shoulder-ekf"}},
      {"reaching", {"invdyn-parametric", "invdyn-gp", "invdyn-semiparametric"}},
  };
  return kMethods;
}

BenchmarkSpec LoadBenchmarkSpec(const std::string& path) {
  return ParseBenchmarkSpec(ReadFile(path), path);
}

BenchmarkSpec ParseBenchmarkSpec(const std::string& text, const std::string& path) {
  return internal::WithYamlErrorsNamed(path, [&] { return ParseChecked(text, path); });
}

}  // namespace fesim
