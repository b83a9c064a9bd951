// `fesim diagnose MEASURED.csv[,MORE.csv…] --scenario RIG.yaml [--out DIR] [--model full]
//  [--threads N]` (PRODUCT.md "Diagnosis", issue 7).
#include <cstdio>
#include <stdexcept>
#include <string>
#include <thread>

#include "apps/cli.h"
#include "apps/commands.h"
#include "diagnosis/diagnose.h"
#include "diagnosis/report.h"
#include "scenarios/scenario.h"
#include "scenarios/trial.h"

namespace fesim {

int RunDiagnose(int argc, char** argv) {
  const auto args = cli::Parse(argc, argv, 2, {"help"}, {"scenario", "out", "model", "threads"});
  if (args.Has("help")) {
    std::printf(
        "usage: fesim diagnose MEASURED.csv[,MORE.csv...] --scenario RIG.yaml [--out DIR]\n"
        "                      [--model full] [--threads N]\n\n"
        "Calibrates the full model (12) of the rig to the measured trials (subject parameters),\n"
        "shows what it gets wrong on held-out data (the last trial, or the last 30 %% of a single\n"
        "trial), names the cause among the candidate mechanisms (fatigue, potentiation, delay,\n"
        "tremor, crosstalk, moment_arm_posture, force_length_velocity, unequal_muscle_dynamics,\n"
        "passive_stiffness_nonlinear, arm_support, stiction, spasticity, sensor_drift), or says\n"
        "none / unexplained, and measures the held-out gain of the extended model.\n"
        "Writes DIR/diagnosis.md, DIR/diagnosis.json, DIR/residuals_<joint>.png and\n"
        "DIR/spectrum_<joint>.png\n"
        "(default DIR: out/diagnose). Trials need u.<channel> inputs and q.<joint> outputs\n"
        "(q.<joint>_deg accepted) of joints that are free in the scenario; a record with\n"
        "uneven time steps is resampled to its median step (outputs interpolated, inputs from\n"
        "the nearest row; said in the report); NaN gaps are skipped.\n"
        "--threads: simulation threads (default: all cores).\n");
    return 0;
  }
  if (args.positional.size() != 1) {
    throw std::runtime_error("expected one argument MEASURED.csv[,MORE.csv...] (see --help)");
  }
  if (!args.Has("scenario")) throw std::runtime_error("--scenario is required (see --help)");
  const std::string model = args.Get("model", "full");
  if (model != "full") {
    throw std::runtime_error("--model: '" + model +
                             "' is not available for diagnosis (allowed: full)");
  }
  const long threads = args.GetInt("threads", std::max(1u, std::thread::hardware_concurrency()));
  if (threads < 1 || threads > 256) {
    throw std::runtime_error("--threads: " + std::to_string(threads) + " is outside [1, 256]");
  }
  const Scenario scenario = LoadScenario(args.Get("scenario"));
  std::vector<Trial> trials;
  std::string inputs = "Measured trials:";
  for (const auto& path : cli::SplitList(args.positional[0])) {
    trials.push_back(ReadTrialCsv(path));
    trials.back().metadata["source"] = path;
    inputs += " `" + path + "`";
  }
  if (trials.empty()) throw std::runtime_error("no measured trial given");
  inputs += "; rig `" + args.Get("scenario") + "`.";
  diagnosis::DiagnoseOptions options;
  options.fit.threads = static_cast<int>(threads);
  const diagnosis::Diagnosis d =
      diagnosis::Diagnose(scenario.model, trials, options, cli::ShowProgress);
  const std::string out = args.Get("out", "out/diagnose");
  cli::MakeDirs(out);
  diagnosis::WriteDiagnosisReport(d, inputs, out);
  std::fprintf(stderr,
               "fesim diagnose: %s (confidence %.2f, held-out gain %.1f %%), report in %s\n",
               d.cause.c_str(), d.confidence, 100.0 * d.gain, out.c_str());
  return 0;
}

}  // namespace fesim
