// Subcommands of the `fesim` binary. Each returns the exit code and throws std::runtime_error
// with a one-line reason on bad input.
#pragma once

#include <vector>

#include "identification/method.h"

namespace fesim {

int RunSimulate(int argc, char** argv);
int RunIdentify(int argc, char** argv);
int RunRender(int argc, char** argv);
int RunBenchmark(int argc, char** argv);
int RunDiagnose(int argc, char** argv);

/// Identification methods that live outside identification/'s Eigen-only core (e.g. the
/// full-model fit, which simulates through sim/).
std::vector<identification::MethodEntry> ExtraIdentificationMethods();

}  // namespace fesim
