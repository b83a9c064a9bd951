// `fesim diagnose MEASURED.csv[,MORE.csv…] --scenario RIG.yaml [--out DIR] [--model full|NAME]
//  [--threads N]` (PRODUCT.md "Diagnosis", issue 7).
#include <cstdio>
#include <functional>
#include <stdexcept>
#include <string>
#include <thread>

#include "apps/cli.h"
#include "apps/commands.h"
#include "base/result_cache.h"
#include "base/source_fingerprint.h"
#include "base/trial.h"
#include "diagnosis/diagnose.h"
#include "diagnosis/reduced_model.h"
#include "diagnosis/report.h"
#include "scenarios/scenario.h"

namespace fesim {

int RunDiagnose(int argc, char** argv, cluster::Cluster& job) {
  const auto args =
      cli::Parse(argc, argv, 2, {"help", "quiet"}, {"scenario", "out", "model", "threads"});
  if (args.Has("help")) {
    std::printf(
        "usage: fesim diagnose MEASURED.csv[,MORE.csv...] --scenario RIG.yaml [--out DIR]\n"
        "                      [--model full|NAME] [--threads N] [--quiet]\n\n"
        "Calibrates the full model (12) of the rig to the measured trials of a person it has "
        "never\n"
        "seen (recruitment, strength, passive stiffness, damping and rest angles, activation "
        "rate,\n"
        "moment arms: the parameters the data identify, with priors; the rest stay nominal and "
        "the\n"
        "report says so), identifies a black-box reference (hammerstein-mimo) on the same data,\n"
        "and shows what the calibrated model gets wrong on held-out data (the last trial, or the\n"
        "last 30 %% of a single trial). Names the cause among the candidate mechanisms (fatigue,\n"
        "potentiation, delay, tremor, crosstalk, moment_arm_posture, force_length_velocity,\n"
        "unequal_muscle_dynamics, passive_stiffness_nonlinear, arm_support, stiction, spasticity,\n"
        "sensor_drift) with tests robust to the calibrated model's coloured misfit, says none, or\n"
        "unexplained with the outputs where the model does not reach the black box, and measures\n"
        "the held-out gain of the extended model.\n"
        "Writes DIR/diagnosis.md, DIR/diagnosis.json, DIR/prediction_<joint>.png,\n"
        "DIR/residuals_<joint>.png and DIR/spectrum_<joint>.png\n"
        "(default DIR: out/diagnose); every stage is cached in DIR/cache as it finishes, so an\n"
        "interrupted run resumes. Trials need u.<channel> inputs and q.<joint> outputs\n"
        "(q.<joint>_deg accepted) of joints that are free in the scenario; a record whose time\n"
        "steps differ by more than 1 %% is resampled to its median step (outputs interpolated,\n"
        "inputs from the nearest row; said in the report); NaN gaps are skipped.\n"
        "--model NAME: diagnose a reduced model instead (hammerstein-mimo, spline-arx,\n"
        "spline-oe: identified on the training part as `fesim identify` does, options from the\n"
        "trial's metadata); it can be extended only by the mechanisms acting on its input or\n"
        "output (fatigue, potentiation, delay, tremor, crosstalk, sensor_drift), the others are\n"
        "listed as not applicable.\n"
        "--threads: simulation threads (default: all cores; 1 per rank under mpirun).\n");
    return 0;
  }
  if (args.positional.size() != 1) {
    throw std::runtime_error("expected one argument MEASURED.csv[,MORE.csv...] (see --help)");
  }
  if (!args.Has("scenario")) throw std::runtime_error("--scenario is required (see --help)");
  const std::string model = args.Get("model", "full");
  if (model != "full") {
    std::string allowed = "full";
    bool known = false;
    for (const auto& m : diagnosis::ReducedModelMethods()) {
      allowed += ", " + m.name;
      known |= m.name == model;
    }
    if (!known) {
      throw std::runtime_error("--model: '" + model + "' is not a model diagnose can calibrate " +
                               "(allowed: " + allowed + ")");
    }
  }
  // On an MPI job, one thread per rank unless asked (the ranks share the cores).
  const int threads = cli::Threads(
      args, job.size() > 1
                ? 1
                : static_cast<int>(std::min<unsigned>(
                      std::max(1u, std::thread::hardware_concurrency()), cli::kMaxThreads)));
  const std::string out = cli::OutPath(args, "out", "out/diagnose");
  const Scenario scenario = LoadScenario(args.Get("scenario"));
  // Resume cache key: the contents of the rig and of every measured file, in order.
  std::string cache_inputs = "rig " + Fnv1a64Hex(ReadFile(args.Get("scenario")));
  std::vector<Trial> trials;
  std::string inputs = "Measured trials:";
  for (const auto& path : cli::SplitList(args.positional[0])) {
    trials.push_back(ReadTrialCsv(path));
    cache_inputs += "\ntrial " + Fnv1a64Hex(FormatTrialCsv(trials.back()));  // not the path
    trials.back().metadata["source"] = path;
    inputs += " `" + path + "`";
  }
  if (trials.empty()) throw std::runtime_error("no measured trial given");
  inputs += "; rig `" + args.Get("scenario") + "`.";
  // Expensive stages are cached under DIR/cache as they finish: a killed run resumes. The key
  // holds the build's identity (base/source_fingerprint.h), so a cache written by other code (a
  // changed candidate range, probe or prior) is not read back.
  ResultCache cache(out + "/cache", BuildIdentity(), "diagnose-cache-5");
  diagnosis::DiagnoseSettings settings;
  settings.model = model;
  diagnosis::DiagnoseExecution execution;
  execution.threads = static_cast<int>(threads);
  execution.cache = &cache;
  execution.cache_inputs = cache_inputs;
  if (job.is_root()) execution.progress = cli::Progress(cli::ProgressFor(args));
  if (job.size() > 1) {
    // An MPI job: every rank runs the diagnosis; the probe simulations and the candidates'
    // screening fits are spread over the ranks, each rank gets every result back, rank 0 writes.
    execution.map = [&job](std::size_t n, const std::function<std::string(std::size_t)>& fn) {
      const std::vector<cluster::ItemOutcome> outcomes = job.MapAll(n, fn);
      std::vector<std::string> texts;
      std::string failed;
      for (std::size_t i = 0; i < outcomes.size(); ++i) {
        if (!outcomes[i].ok) {
          failed += (failed.empty() ? "" : "; ") + std::string("diagnosis item ") +
                    std::to_string(i) + " (rank " + std::to_string(outcomes[i].rank) +
                    "): " + outcomes[i].payload;
        }
        texts.push_back(outcomes[i].payload);
      }
      if (!failed.empty()) throw cluster::CollectiveError(failed);
      return texts;
    };
  }
  const diagnosis::Diagnosis d = diagnosis::Diagnose(scenario.model, trials, settings, execution);
  if (!job.is_root()) return 0;
  MakeDirs(out);
  diagnosis::WriteDiagnosisReport(d, inputs, out);
  std::fprintf(stderr,
               "fesim diagnose: %s (confidence %.2f, held-out gain %.1f %%), report in %s; "
               "%d trial simulations, %d results from the resume cache %s/cache%s\n",
               d.cause.c_str(), d.confidence, 100.0 * d.gain, out.c_str(), d.simulations,
               d.cached_results, out.c_str(),
               job.size() > 1 ? (", " + std::to_string(job.size()) + " MPI ranks").c_str() : "");
  return 0;
}

}  // namespace fesim
