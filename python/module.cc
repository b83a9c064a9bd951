// The Python module `fesim` (README "Python"): trials as NumPy arrays with their metadata,
// scenarios simulated, identification methods, diagnoses and rendering — the functions behind the
// subcommands (apps/api.h, diagnosis/diagnose.h), so results and one-line error messages are the
// command line's. C++ exceptions arrive as Python exceptions with the same message
// (std::runtime_error → RuntimeError, std::invalid_argument → ValueError). Long calls release the
// GIL; a `progress` callable is called back with it held.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "apps/api.h"
#include "apps/commands.h"
#include "apps/matfile.h"
#include "base/json.h"
#include "base/result_cache.h"
#include "base/trial.h"
#include "diagnosis/diagnose.h"
#include "diagnosis/report.h"
#include "fesim/version.h"
#include "scenarios/scenario.h"

namespace py = pybind11;

namespace fesim::python {
namespace {

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

py::array_t<double> ToArray(const std::vector<double>& v) {
  return py::array_t<double>(static_cast<py::ssize_t>(v.size()), v.data());
}

std::vector<double> FromArray(const DoubleArray& a, const std::string& what) {
  if (a.ndim() != 1) {
    throw std::invalid_argument(what + ": expected a 1-D array, got " + std::to_string(a.ndim()) +
                                " dimensions");
  }
  return std::vector<double>(a.data(), a.data() + a.size());
}

/// A JSON value as Python objects (dict, list, float, str, bool, None).
py::object ToPython(const Json& j) { return py::module_::import("json").attr("loads")(j.Dump(0)); }

/// A Python progress callable as the C++ callback (GIL taken for the call; nothing when None).
std::function<void(double, const std::string&)> Progress(const py::object& progress) {
  if (progress.is_none()) return nullptr;
  return [progress](double fraction, const std::string& stage) {
    py::gil_scoped_acquire gil;
    progress(fraction, stage);
  };
}

Trial MakeTrial(const DoubleArray& time, const py::dict& columns, const py::dict& metadata) {
  Trial t;
  t.time = FromArray(time, "time");
  for (std::size_t i = 1; i < t.time.size(); ++i) {
    if (!(t.time[i] > t.time[i - 1])) {
      throw std::invalid_argument("time: not strictly increasing at sample " + std::to_string(i));
    }
  }
  for (const auto& item : columns) {
    const std::string name = py::str(item.first);
    t.AddColumn(name, FromArray(item.second.cast<DoubleArray>(), "column " + name));
  }
  for (const auto& item : metadata) {
    t.metadata[py::str(item.first)] = py::str(item.second);
  }
  return t;
}

void WriteTrial(const Trial& t, const std::string& path) {
  const auto dot = path.find_last_of('.');
  const std::string ext = dot == std::string::npos ? "" : path.substr(dot);
  if (ext == ".csv") {
    WriteFileAtomic(path, FormatTrialCsv(t));
  } else if (ext == ".sto") {
    const auto slash = path.find_last_of('/');
    const std::string stem = path.substr(slash == std::string::npos ? 0 : slash + 1);
    WriteFileAtomic(path, FormatTrialSto(t, stem.substr(0, stem.size() - 4)));
  } else if (ext == ".mat") {
    WriteTrialMat(t, path);
  } else {
    throw std::invalid_argument(path + ": unknown trial format '" + ext +
                                "' (allowed: .csv, .sto, .mat)");
  }
}

std::vector<Trial> TrialList(const py::object& trials, const std::string& what) {
  std::vector<Trial> out;
  if (py::isinstance<Trial>(trials)) return {trials.cast<Trial>()};
  for (const auto& item : trials) {
    if (py::isinstance<py::str>(item)) {
      out.push_back(ReadTrialCsv(item.cast<std::string>()));
      out.back().metadata["source"] = item.cast<std::string>();
    } else {
      out.push_back(item.cast<Trial>());
    }
  }
  if (out.empty()) throw std::invalid_argument(what + ": no trial given");
  return out;
}

py::dict Simulate(const std::string& scenario, long seed, const py::object& duration_s,
                  const py::object& tolerance, const py::object& progress) {
  if (seed < 0)
    throw std::invalid_argument("seed: " + std::to_string(seed) + " is outside [0, 2^63)");
  Scenario sc = LoadScenario(scenario);
  sc.trial.seed = static_cast<std::uint64_t>(seed);
  if (!duration_s.is_none()) {
    const double d = duration_s.cast<double>();
    if (!(d >= 0.001 && d <= 3600.0))
      throw std::invalid_argument("duration_s: " + std::to_string(d) +
                                  " is outside [0.001, 3600] s");
    sc.trial.duration_s = d;
  }
  if (!tolerance.is_none()) {
    const double tol = tolerance.cast<double>();
    if (!(tol >= 1e-12 && tol <= 1e-1))
      throw std::invalid_argument("tolerance: " + std::to_string(tol) + " is outside [1e-12, 0.1]");
    sc.trial.integrator.tolerance = tol;
  }
  const auto report = Progress(progress);
  SimulatedTrial r;
  {
    py::gil_scoped_release release;
    r = SimulateScenario(sc, [&](double f) {
      if (report) report(f, "simulating " + sc.name);
    });
  }
  py::dict out;
  out["measured"] = r.measured;
  out["truth"] = r.truth;
  out["stats"] = ToPython(r.stats);
  return out;
}

/// The parameters of a model.yaml (identification/method_support.h YamlParam: `name: {value,
/// unit, ci95}` at any depth) as {"section.name": {"value", "unit", "ci95": [lo, hi] or None}}.
double AsDouble(const YAML::Node& node) {
  // "nan" / "inf" as the model files print them (std::strtod reads them; yaml-cpp wants ".nan").
  return std::strtod(node.as<std::string>().c_str(), nullptr);
}

void CollectParameters(const YAML::Node& node, const std::string& prefix, py::dict* out) {
  if (!node.IsMap()) return;
  if (node["value"] && node["unit"]) {
    py::dict p;
    p["value"] = AsDouble(node["value"]);
    p["unit"] = node["unit"].as<std::string>();
    if (node["ci95"] && node["ci95"].IsSequence() && node["ci95"].size() == 2) {
      p["ci95"] = py::make_tuple(AsDouble(node["ci95"][0]), AsDouble(node["ci95"][1]));
    } else {
      p["ci95"] = py::none();
    }
    (*out)[prefix.c_str()] = p;
    return;
  }
  for (const auto& kv : node) {
    const std::string key = kv.first.as<std::string>();
    CollectParameters(kv.second, prefix.empty() ? key : prefix + "." + key, out);
  }
}

py::dict Identify(const std::string& method_name, const py::object& train_in,
                  const py::object& test_in, const py::object& scenario,
                  const py::object& progress) {
  const auto methods = AllIdentificationMethods();
  const identification::MethodEntry& method = FindIdentificationMethod(methods, method_name);
  std::vector<Trial> train = TrialList(train_in, "train");
  const std::vector<Trial> test =
      test_in.is_none() ? std::vector<Trial>{} : TrialList(test_in, "test");
  if (!scenario.is_none()) {
    const std::string path = scenario.cast<std::string>();
    ReadFile(path);  // fails early with the path when it cannot be read
    for (auto& t : train) t.metadata["scenario_path"] = path;
  }
  const auto report = Progress(progress);
  identification::MethodResult r;
  {
    py::gil_scoped_release release;
    r = method.run(train, test, [&](double f, const std::string& stage) {
      if (report) report(f, stage);
    });
  }
  py::dict out;
  out["model_yaml"] = r.model_yaml;
  py::dict parameters;
  CollectParameters(YAML::Load(r.model_yaml), "", &parameters);
  out["parameters"] = parameters;
  out["predictions"] = r.predictions;
  out["metrics"] = ToPython(r.metrics);
  out["warnings"] = r.warnings;
  py::list discrete;
  for (const auto& d : r.discrete_models) {
    py::dict m;
    m["sample_time_s"] = d.sample_time_s;
    m["inputs"] = d.inputs;
    m["output"] = d.output;
    m["A"] = d.a;
    m["B"] = d.b;
    m["F"] = d.f;
    m["breakpoints_u"] = d.nonlinearity_u;
    m["breakpoints_f"] = d.nonlinearity_f;
    m["output_offset"] = d.output_offset;
    discrete.append(m);
  }
  out["discrete_models"] = discrete;
  return out;
}

/// Per held-out trial: time, measured outputs, the calibrated and the extended model's
/// predictions and their residuals (measured − predicted), rad.
py::list HeldoutSeries(const diagnosis::Diagnosis& d) {
  py::list out;
  for (std::size_t t = 0; t < d.heldout.trials.size(); ++t) {
    const Trial& y = d.heldout.trials[t];
    py::dict trial, measured, baseline, extended, r_base, r_ext;
    trial["time"] = ToArray(y.time);
    for (const auto& o : d.heldout.outputs) {
      const auto& m = y.Column(o);
      measured[o.c_str()] = ToArray(m);
      for (auto [pred, preds, res] : {std::tuple{&baseline, &d.heldout_baseline, &r_base},
                                      std::tuple{&extended, &d.heldout_extended, &r_ext}}) {
        if (t >= preds->size() || !(*preds)[t].Has(o)) continue;
        const auto& p = (*preds)[t].Column(o);
        std::vector<double> r(m.size());
        for (std::size_t i = 0; i < m.size(); ++i) r[i] = m[i] - p[i];
        (*pred)[o.c_str()] = ToArray(p);
        (*res)[o.c_str()] = ToArray(r);
      }
    }
    trial["measured"] = measured;
    trial["baseline"] = baseline;
    trial["extended"] = extended;
    trial["residual_baseline"] = r_base;
    trial["residual_extended"] = r_ext;
    out.append(trial);
  }
  return out;
}

py::dict Diagnose(const py::object& trials_in, const std::string& scenario, int threads,
                  const std::string& model, const py::object& out_dir, const py::object& progress) {
  if (threads < 0 || threads > 256)
    throw std::invalid_argument("threads: " + std::to_string(threads) + " is outside [0, 256]");
  const std::vector<Trial> trials = TrialList(trials_in, "trials");
  const Scenario rig = LoadScenario(scenario);
  diagnosis::DiagnoseSettings settings;
  settings.model = model;
  diagnosis::DiagnoseExecution execution;
  execution.threads =
      threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const auto report = Progress(progress);
  if (report) execution.progress = report;
  diagnosis::Diagnosis d;
  {
    py::gil_scoped_release release;
    d = diagnosis::Diagnose(rig.model, trials, settings, execution);
    if (!out_dir.is_none()) {
      MakeDirs(out_dir.cast<std::string>());
      diagnosis::WriteDiagnosisReport(d, "Measured trials from Python; rig `" + scenario + "`.",
                                      out_dir.cast<std::string>());
    }
  }
  py::dict out = ToPython(diagnosis::DiagnosisJson(d));
  out["heldout"] = HeldoutSeries(d);
  return out;
}

/// `fesim render` on a trial (a path, or a Trial written to a temporary CSV named after it).
void Render(const py::object& trial, const std::string& scenario, const py::object& out,
            const py::object& frames, int width, int height, double fps, const std::string& camera,
            const py::object& compare) {
  // Trial objects go to a private temporary folder (tempfile.mkdtemp: no name race), removed after.
  std::string temp_dir;
  std::vector<std::string> temp_files;
  const auto path_of = [&](const py::object& t) {
    if (py::isinstance<py::str>(t)) return t.cast<std::string>();
    if (temp_dir.empty()) {
      temp_dir = py::module_::import("tempfile").attr("mkdtemp")().cast<std::string>();
    }
    const std::string path = temp_dir + "/trial" + std::to_string(temp_files.size() + 1) + ".csv";
    WriteFileAtomic(path, FormatTrialCsv(t.cast<Trial>()));
    temp_files.push_back(path);
    return path;
  };
  const auto clean_up = [&] {
    for (const auto& f : temp_files) std::remove(f.c_str());
    if (!temp_dir.empty()) std::remove(temp_dir.c_str());
  };
  std::vector<std::string> args = {"fesim",
                                   "render",
                                   path_of(trial),
                                   "--scenario",
                                   scenario,
                                   "--width",
                                   std::to_string(width),
                                   "--height",
                                   std::to_string(height),
                                   "--fps",
                                   std::to_string(fps),
                                   "--camera",
                                   camera,
                                   "--quiet"};
  if (!out.is_none()) args.insert(args.end(), {"--out", out.cast<std::string>()});
  if (!frames.is_none()) args.insert(args.end(), {"--frames", frames.cast<std::string>()});
  if (!compare.is_none()) args.insert(args.end(), {"--compare", path_of(compare)});
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  try {
    py::gil_scoped_release release;
    RunRender(static_cast<int>(argv.size()), argv.data());
  } catch (...) {
    clean_up();
    throw;
  }
  clean_up();
}

void DefineTrial(py::module_& m) {
  py::class_<Trial>(m, "Trial",
                    "A trial: sample times (s) and named columns (u.<channel> µs, q.<joint> rad, "
                    "…) with key: value metadata, as NumPy arrays.")
      .def(py::init(&MakeTrial), py::arg("time"), py::arg("columns") = py::dict(),
           py::arg("metadata") = py::dict())
      .def_property_readonly("time", [](const Trial& t) { return ToArray(t.time); })
      .def_property_readonly("names", [](const Trial& t) { return t.names; })
      .def_property(
          "metadata", [](const Trial& t) { return t.metadata; },
          [](Trial& t, const std::map<std::string, std::string>& md) { t.metadata = md; })
      .def("__getitem__",
           [](const Trial& t, const std::string& name) {
             if (!t.Has(name)) throw py::key_error("no column '" + name + "'");
             return ToArray(t.Column(name));
           })
      .def("__contains__", [](const Trial& t, const std::string& name) { return t.Has(name); })
      .def("__len__", [](const Trial& t) { return t.size(); })
      .def("add_column",
           [](Trial& t, const std::string& name, const DoubleArray& values) {
             t.AddColumn(name, FromArray(values, "column " + name));
           })
      .def("columns_with_prefix", &Trial::NamesWithPrefix, py::arg("prefix"))
      .def("to_dict",
           [](const Trial& t) {
             py::dict d;
             d["time"] = ToArray(t.time);
             for (std::size_t k = 0; k < t.names.size(); ++k)
               d[t.names[k].c_str()] = ToArray(t.columns[k]);
             return d;
           })
      .def("__repr__", [](const Trial& t) {
        return "<fesim.Trial " + std::to_string(t.size()) + " samples, " +
               std::to_string(t.names.size()) + " columns>";
      });
}

}  // namespace
}  // namespace fesim::python

PYBIND11_MODULE(fesim, m) {
  using namespace fesim;
  using namespace fesim::python;
  m.doc() = "fesim: upper-limb FES simulator, identification bench and diagnosis (README).";
  m.attr("__version__") = FESIM_VERSION;
  DefineTrial(m);
  m.def("read_trial", &ReadTrialCsv, py::arg("path"),
        "Reads a trial CSV (# metadata lines, header with time first; _deg columns → rad).");
  m.def("write_trial", &WriteTrial, py::arg("trial"), py::arg("path"),
        "Writes a trial atomically as .csv, OpenSim .sto or MATLAB .mat (by the extension).");
  m.def("simulate", &Simulate, py::arg("scenario"), py::kw_only(), py::arg("seed") = 1,
        py::arg("duration_s") = py::none(), py::arg("tolerance") = py::none(),
        py::arg("progress") = py::none(),
        "Simulates a scenario file's trial: {'measured': Trial, 'truth': Trial, 'stats': dict}.");
  m.def(
      "methods",
      [] {
        std::vector<std::pair<std::string, std::string>> out;
        for (const auto& e : AllIdentificationMethods()) out.emplace_back(e.name, e.summary);
        return out;
      },
      "The identification methods: (name, summary) pairs.");
  m.def("identify", &Identify, py::arg("method"), py::arg("train"), py::kw_only(),
        py::arg("test") = py::none(), py::arg("scenario") = py::none(),
        py::arg("progress") = py::none(),
        "Fits a method on train (Trials or CSV paths), evaluates on test (or train): "
        "{'parameters', 'model_yaml', 'predictions', 'metrics', 'warnings', "
        "'discrete_models'}.");
  m.def("diagnose", &Diagnose, py::arg("trials"), py::kw_only(), py::arg("scenario"),
        py::arg("threads") = 0, py::arg("model") = "full", py::arg("out") = py::none(),
        py::arg("progress") = py::none(),
        "Diagnoses measured trials on a rig: the diagnosis.json fields (cause, confidence, "
        "reason, person, candidates, reference, …) and 'heldout' (measured, predictions and "
        "residuals per held-out trial); out=DIR also writes diagnosis.md/json and plots.");
  m.def("render", &Render, py::arg("trial"), py::kw_only(), py::arg("scenario"),
        py::arg("out") = py::none(), py::arg("frames") = py::none(), py::arg("width") = 1280,
        py::arg("height") = 720, py::arg("fps") = 30.0, py::arg("camera") = "front",
        py::arg("compare") = py::none(),
        "Renders a trial (Trial or CSV path) off-screen to an MP4 (out=) or PNG frames (frames=).");
}
