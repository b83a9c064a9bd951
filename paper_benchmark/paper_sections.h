// The steps of the elbow-tests, tremor-wrist, shoulder and reaching sections (sections.h);
// internal to paper_benchmark/, declared here for tests/paper_benchmark/paper_sections_test.cc.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "base/trial.h"

namespace fesim::paper_benchmark {

/// Best Fit % of `prediction` against the noiseless `truth`, after removing the constant offset
/// between truth and `measured` (rigs that zero a torque sensor on its rest period, [Le 2010],
/// docs/papers.md, measure relative to that baseline; the truth record is absolute).
double FitAgainstTruth(const Trial& prediction, const Trial& truth, const Trial& measured,
                       const std::string& col);

/// Best Fit for a table cell: a diverging prediction (Best Fit below −100 %) shows as "< −100".
std::string FitCell(double v);

/// The one output column a SISO prediction carries (the first tau.*, else the first q.*).
std::string OutputColumn(const Trial& prediction);

/// The trial with its two u.* columns ordered agonist first, as tremor-arx expects ([Copur 2016]
/// eq. 5: the agonist drives the output positive): the channel whose pulse-width difference
/// correlates positively with the output, both through a moving average of about 1 s (at most a
/// quarter of the record), goes first — the sign of the low-frequency gain, which a zero-lag
/// correlation misses where the joint lags by more than 90°. Other trials are returned unchanged.
Trial AgonistFirst(const Trial& t);

/// One fit of the elbow section ([Le 2010] Tables 1–3): method m, participant p, protocol a;
/// r ≥ 0: identification on repetition r (evaluated on every repetition of protocol a);
/// r < 0: cross-validation fit on all repetitions of a (evaluated on every protocol).
struct ElbowJob {
  int m, p, a, r;
};
/// Every job, method-major, then participant, protocol, and r = −1, 0, …, reps − 1.
std::vector<ElbowJob> ElbowJobs(int methods, int participants, int protocols, int reps);

/// A job's Best Fit values, one per test trial, with the test trial's protocol and repetition;
/// bf_truth: against the truth for cross-validation on another protocol (NaN otherwise).
struct ElbowJobFigures {
  std::vector<double> bf, bf_truth;
  std::vector<int> test_proto, test_rep;
};

/// The Best Fit values behind the elbow tables, gathered from every job in job order (so the
/// means do not depend on which job finished first).
struct ElbowBestFits {
  /// ident[m][a] / valid[m][a]: identification (the fitted trial) and validation (every trial
  /// of protocol a, the fitted one included: paper 002 §6).
  std::vector<std::vector<std::vector<double>>> ident, valid;
  /// cross[m][a][b]: fitted on every trial of a, evaluated on the trials of b.
  std::vector<std::vector<std::vector<std::vector<double>>>> cross;
  /// cross_truth[m][a]: the cross-validation fits on a against the truth of the other protocols.
  std::vector<std::vector<std::vector<double>>> cross_truth;
};
ElbowBestFits GatherElbowBestFits(const std::vector<ElbowJob>& jobs,
                                  const std::vector<ElbowJobFigures>& figures, int methods,
                                  int protocols);

/// [Le 2010] Table 3 under the measure of fesim's finding "the staircase model predicts the other
/// tests best": per test fitted on ("TR", "FRN", "Staircase"), the mean over both algorithms of
/// the mean Best Fit on the other two tests (%; the blank cell of Table 3(a) left out).
std::map<std::string, double> PaperCrossMeanOfOthers();

/// Angle amplitude of the identified tremor, rad: the tremor term d = λ1 cos + λ2 sin at
/// frequency f_hz ([Copur 2016] eq. 10) enters the output as d / A_P (identification/tremor_arx.h),
/// so its amplitude is |λ| / |A_P(e^{jωT})| with A_P(z) = 1 + Σ a_i z^{−i}, ω = 2π f_hz,
/// T = sample_s.
double TremorAngleAmplitude(const std::vector<double>& arx_a, double lambda1, double lambda2,
                            double f_hz, double sample_s);

}  // namespace fesim::paper_benchmark
