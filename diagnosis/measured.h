// Step 1 of `fesim diagnose` (diagnosis/diagnose.h) on the measured trials: which rows count,
// whether the trials fit the rig, and the training / held-out split. Kept apart from the
// simulation so that it can be fuzzed on its own (fuzz/fuzz_diagnose_input.cc, issue 10).
#pragma once

#include <string>
#include <vector>

#include "diagnosis/extended_model.h"
#include "scenarios/trial.h"
#include "sim/model_params.h"

namespace fesim::diagnosis {

/// Fewest training samples per trial, and fewest samples in a held-out segment.
inline constexpr std::size_t kMinSamples = 50;

struct MeasuredData {
  std::vector<std::string> outputs;   ///< q.<joint> columns (trial 0's order).
  std::vector<std::string> channels;  ///< rig channels some trial stimulates, rig order.
  DataView train, heldout;
  std::string split;  ///< how the data were split, one line.
};

/// Keeps each trial's rows at which some q.* output was sampled (a measured record's time
/// column is the union of its sensors' grids), checks the trials against the rig and splits
/// them (SplitTrials). Throws std::runtime_error with a one-line reason naming the trial's
/// `source` metadata (its file) and column: no q.* output, a joint unknown or not free in the
/// rig, an unknown channel, a NaN input, too few samples, non-uniform sampling, q.* columns that
/// differ across trials, no stimulated channel.
MeasuredData PrepareMeasured(const sim::ModelParams& rig, const std::vector<Trial>& measured,
                             double holdout_fraction);

/// The split of step 1 (exposed for tests): several trials — the last is held out whole; one
/// trial — the first (1 − holdout_fraction) of its time trains, the rest is held out.
void SplitTrials(const std::vector<Trial>& measured, const std::vector<std::string>& outputs,
                 double holdout_fraction, DataView* train, DataView* heldout, std::string* how);

}  // namespace fesim::diagnosis
