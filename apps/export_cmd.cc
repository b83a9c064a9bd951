// `fesim export TRIAL.csv [--scenario SCENARIO.yaml] [--mat] [--out DIR]`: an existing trial for
// OpenSim (README "OpenSim"; sim/opensim.h) — DIR/<stem>.osim (the scenario's participant) and
// DIR/<stem>.mot (the trial's angles in degrees) — and for MATLAB (README "MATLAB";
// apps/matfile.h) — DIR/<stem>.mat.
#include <cstdio>
#include <stdexcept>
#include <string>

#include "apps/cli.h"
#include "apps/commands.h"
#include "apps/matfile.h"
#include "base/result_cache.h"
#include "base/trial.h"
#include "scenarios/scenario.h"
#include "sim/opensim.h"

namespace fesim {
namespace {

void PrintHelp() {
  std::printf(
      "usage: fesim export TRIAL.csv [--scenario SCENARIO.yaml] [--mat] [--out DIR] [--quiet]\n\n"
      "Writes the trial for OpenSim 4.x (README \"OpenSim\") with --scenario and for MATLAB\n"
      "(README \"MATLAB\") with --mat, atomically:\n"
      "  DIR/<stem>.osim  the scenario's participant: bodies with mass and inertia, one joint per\n"
      "                   coordinate (fesim's names, ranges, locks), the muscles "
      "(Thelen2003Muscle,\n"
      "                   fesim's F_max, l_opt, l_ts; two-point paths for display)\n"
      "  DIR/<stem>.mot   time and every coordinate in degrees (inDegrees=yes); dropouts\n"
      "                   interpolated, coordinates absent from the trial at their initial angle\n"
      "  DIR/<stem>.mat   time and every column as N x 1 doubles (q.wrist_flexion ->\n"
      "                   q_wrist_flexion; `columns` maps the names), `metadata` as a cell\n"
      "Default DIR: the trial's folder. Open the .osim in the OpenSim GUI, then load the .mot.\n");
}

std::string Stem(const std::string& path) {
  const auto slash = path.find_last_of('/');
  std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  const auto dot = name.find_last_of('.');
  return dot == std::string::npos ? name : name.substr(0, dot);
}

}  // namespace

int RunExport(int argc, char** argv) {
  const auto args = cli::Parse(argc, argv, 2, {"help", "quiet", "mat"}, {"scenario", "out"});
  if (args.Has("help")) {
    PrintHelp();
    return 0;
  }
  if (args.positional.size() != 1) {
    throw std::runtime_error("expected one TRIAL.csv argument (see --help)");
  }
  if (!args.Has("scenario") && !args.Has("mat")) {
    throw std::runtime_error(
        "nothing to export: give --scenario SCENARIO.yaml (OpenSim) and/or "
        "--mat (MATLAB)");
  }
  const std::string path = args.positional[0];
  const auto slash = path.find_last_of('/');
  const std::string out =
      cli::OutPath(args, "out", slash == std::string::npos ? "." : path.substr(0, slash));
  const Trial trial = ReadTrialCsv(path);
  const std::string stem = Stem(path);
  if (args.Has("mat")) RequireMatOutput();  // a missing module fails before any file is written
  std::string written;
  if (args.Has("scenario")) {
    const Scenario sc = LoadScenario(args.Get("scenario"));
    MakeDirs(out);
    WriteFileAtomic(out + "/" + stem + ".osim", sim::FormatOsimModel(sc.model, sc.name));
    WriteFileAtomic(out + "/" + stem + ".mot", sim::FormatOsimMotion(trial, sc.model, stem));
    written += stem + ".osim " + stem + ".mot ";
  }
  if (args.Has("mat")) {
    MakeDirs(out);
    WriteTrialMat(trial, out + "/" + stem + ".mat");
    written += stem + ".mat ";
  }
  if (!args.Has("quiet")) {
    std::fprintf(stderr, "fesim export: %swritten to %s\n", written.c_str(), out.c_str());
  }
  return 0;
}

}  // namespace fesim
