// Step 1 of `fesim diagnose` (diagnosis/diagnose.h) on the measured trials: which rows count,
// whether the trials fit the rig, and the training / held-out split. Kept apart from the
// simulation so that it can be fuzzed on its own (fuzz/fuzz_diagnose_input.cc, issue 10).
#pragma once

#include <string>
#include <vector>

#include "base/trial.h"
#include "diagnosis/extended_model.h"
#include "sim/model_params.h"

namespace fesim::diagnosis {

/// Fewest training samples per trial, and fewest samples in a held-out segment.
inline constexpr std::size_t kMinSamples = 50;

struct MeasuredData {
  std::vector<std::string> outputs;   ///< q.<joint> columns (trial 0's order).
  std::vector<std::string> channels;  ///< rig channels some trial stimulates, rig order.
  DataView train, heldout;
  std::string split;               ///< how the data were split, one line.
  std::vector<std::string> notes;  ///< pre-processing done (resampling), one line each.
};

/// The initial posture: at most kInitialPostureSamples finite samples within the first
/// kInitialPostureWindowS of the record, their median per output.
inline constexpr std::size_t kInitialPostureSamples = 3;
inline constexpr double kInitialPostureWindowS = 0.1;

/// The measured initial angle of each of `outputs` (rad; NaN when the window has no finite
/// sample): the simulations start the output joints there (DataView::initial_q), so a trial that
/// begins away from the model's rest posture is not read as a transient the model lacks.
std::vector<double> InitialPosture(const Trial& trial, const std::vector<std::string>& outputs);

/// True when the steps of `time` are equal to within 1 % (and positive).
bool IsUniformlySampled(const std::vector<double>& time);

/// A measured record on a uniform grid (for records whose sample steps differ, e.g. a tracker
/// with jittered time stamps or a merged multi-rate log): step = the median of the record's
/// steps, from its first time to its last. Outputs and other measured columns are interpolated
/// linearly between the two bracketing samples when both are finite, else NaN (a dropout stays
/// a gap: nothing is invented across it); u.* inputs take the value of the row nearest in time
/// (stimulation is piecewise constant, so interpolating would invent pulse widths never
/// applied; holding the last row would place every change up to one step late, half a step on
/// average — a delay the diagnosis would then find — while the nearest row places it within
/// ± half a step). Throws std::runtime_error naming `label` and the row when the times are not
/// strictly increasing.
Trial ResampleToUniform(const Trial& trial, const std::string& label);

/// Keeps each trial's rows at which some q.* output was sampled (a measured record's time
/// column is the union of its sensors' grids), checks the trials against the rig and splits
/// them (SplitTrials). Throws std::runtime_error with a one-line reason naming the trial's
/// `source` metadata (its file) and column: no q.* output, a joint unknown or not free in the
/// rig, an unknown channel, a NaN input, too few samples, times that do not increase, q.* columns
/// that differ across trials, no stimulated channel. Trials whose sampling is not uniform are
/// resampled (ResampleToUniform; said in `notes`).
MeasuredData PrepareMeasured(const sim::ModelParams& rig, const std::vector<Trial>& measured,
                             double holdout_fraction, int heldout_trials = 1);

/// The split of step 1 (exposed for tests): several trials — the last `heldout_trials` are held
/// out whole (std::invalid_argument unless 1 ≤ heldout_trials < the number of trials); one
/// trial — the first (1 − holdout_fraction) of its time trains, the rest is held out.
void SplitTrials(const std::vector<Trial>& measured, const std::vector<std::string>& outputs,
                 double holdout_fraction, DataView* train, DataView* heldout, std::string* how,
                 int heldout_trials = 1);

}  // namespace fesim::diagnosis
