// `fesim identify --method NAME --train A.csv[,B.csv…] [--test C.csv] [--out DIR]`
#include <cstdio>
#include <stdexcept>
#include <string>

#include "apps/api.h"
#include "apps/cli.h"
#include "apps/commands.h"
#include "apps/matfile.h"
#include "base/result_cache.h"
#include "base/trial.h"
#include "identification/method.h"

namespace fesim {

namespace {

void PrintHelp(const std::vector<identification::MethodEntry>& methods) {
  std::printf(
      "usage: fesim identify --method NAME --train A.csv[,B.csv...] [--test C.csv[,...]] "
      "[--out DIR] [--scenario S.yaml] [--quiet]\n\nFits an identification method to trial CSVs "
      "and writes "
      "DIR/model.yaml,\nDIR/prediction_<k>.csv and DIR/metrics.json (default DIR: out/identify); a "
      "discrete\n"
      "model (spline-arx, spline-oe) also as DIR/model.mat for MATLAB's idpoly / idnlhw (README).\n"
      "--scenario names the rig the trials come from (used by full-model; without it full-model\n"
      "assumes the default participant on the hand rig of paper 000, arm locked).\n\nmethods:\n");
  for (const auto& m : methods) std::printf("  %-22s %s\n", m.name.c_str(), m.summary.c_str());
}

}  // namespace

int RunIdentify(int argc, char** argv) {
  const auto methods = AllIdentificationMethods();
  const auto args =
      cli::Parse(argc, argv, 2, {"help", "quiet"}, {"method", "train", "test", "out", "scenario"});
  if (args.Has("help")) {
    PrintHelp(methods);
    return 0;
  }
  if (!args.positional.empty())
    throw std::runtime_error("unexpected argument '" + args.positional[0] + "'");
  if (!args.Has("method")) throw std::runtime_error("--method is required (see --help)");
  if (!args.Has("train")) throw std::runtime_error("--train is required (see --help)");
  const identification::MethodEntry* method = nullptr;
  try {
    method = &FindIdentificationMethod(methods, args.Get("method"));
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(std::string("--method: ") + e.what());
  }
  const std::string out = cli::OutPath(args, "out", "out/identify");
  std::vector<Trial> train, test;
  // Each trial keeps its file as `source` metadata, so that data errors found by the methods
  // name it (identification/method_support.h).
  for (const auto& p : cli::SplitList(args.Get("train"))) {
    train.push_back(ReadTrialCsv(p));
    train.back().metadata["source"] = p;
  }
  for (const auto& p : cli::SplitList(args.Get("test"))) {
    test.push_back(ReadTrialCsv(p));
    test.back().metadata["source"] = p;
  }
  if (train.empty()) throw std::runtime_error("--train: no files given");
  if (args.Has("scenario")) {
    const std::string scenario = args.Get("scenario");
    ReadFile(scenario);  // fails early with the path when it cannot be read
    for (auto& t : train) t.metadata["scenario_path"] = scenario;
  }

  const auto result = method->run(train, test, cli::Progress(cli::ProgressFor(args)));

  if (!result.discrete_models.empty()) RequireMatOutput();  // before the first file
  MakeDirs(out);
  WriteFileAtomic(out + "/model.yaml", result.model_yaml);
  for (std::size_t k = 0; k < result.predictions.size(); ++k) {
    WriteFileAtomic(out + "/prediction_" + std::to_string(k) + ".csv",
                    FormatTrialCsv(result.predictions[k]));
  }
  WriteFileAtomic(out + "/metrics.json", result.metrics.Dump());
  // MATLAB (README "MATLAB"): a discrete model as idpoly / idnlhw fields.
  for (std::size_t k = 0; k < result.discrete_models.size(); ++k) {
    WriteDiscreteModelMat(
        result.discrete_models[k],
        out + (k == 0 ? "/model.mat" : "/model_" + std::to_string(k + 1) + ".mat"));
  }
  std::fprintf(stderr, "fesim identify: %s written to %s\n", method->name.c_str(), out.c_str());
  // Issue 10: a fit whose best local optimisation did not converge says so (one line each; the
  // reason is also in metrics.json and model.yaml).
  for (const auto& w : result.warnings) {
    std::fprintf(stderr, "fesim identify: warning: %s\n", w.c_str());
  }
  return 0;
}

}  // namespace fesim
