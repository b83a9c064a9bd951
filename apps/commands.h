// Subcommands of the `fesim` binary. Each returns the exit code and throws std::runtime_error
// with a one-line reason on bad input.
#pragma once

#include <vector>

#include "cluster/cluster.h"
#include "identification/method.h"

namespace fesim {

// `job` is the run's MPI job (issue 9; one rank without mpirun): simulate (study files),
// benchmark and diagnose spread their work items over its ranks, and rank 0 writes the outputs.
int RunSimulate(int argc, char** argv, cluster::Cluster& job);
int RunIdentify(int argc, char** argv);
int RunRender(int argc, char** argv);
int RunExport(int argc, char** argv);
int RunBenchmark(int argc, char** argv, cluster::Cluster& job);
int RunDiagnose(int argc, char** argv, cluster::Cluster& job);

/// Identification methods that live outside identification/'s Eigen-only core (e.g. the
/// full-model fit, which simulates through sim/).
std::vector<identification::MethodEntry> ExtraIdentificationMethods();

}  // namespace fesim
