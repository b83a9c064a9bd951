// Stage "screen" of `fesim diagnose` (diagnose.h): the score (Lagrange multiplier) test of every
// applicable candidate against "mechanism off" at a model point — the calibrated person, or an
// extended model in the forward selection (extension.h). With r the training residual, D the
// change of the residual along the candidate's probe directions (Candidate::probes; one simulation
// per probe and training trial) and J the Jacobian of the model's own parameters, the test is
// noise_model.h's RobustScoreTest: D projected off J, the statistic weighted by the noise variance
// the coloured residual has along D, S ~ χ²_dof under "off". False alarms over the M applicable
// candidates are controlled by Bonferroni: p_adj = min(1, M p).
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "diagnosis/stages.h"

namespace fesim::diagnosis {

/// A candidate made of output drifts only (sensor_drift): its probes are the model's predictions
/// plus the drifts, without simulating.
bool DriftOnly(const Candidate& c);

/// Whether candidate c's directions are split per training trial: a free phase
/// (Candidate::free_phase_param, tremor) is the trial's own — a person's tremor starts at a
/// random phase in every trial, and one phase for all trials let the probes cancel
/// (docs/diagnosis.md "Robust tests") — and so are drift rates (Candidate::drift_per_trial).
bool PerTrialDirections(const Candidate& c, int trials);

/// Candidate c's one_sided flags for `columns` direction columns (repeated per trial block).
std::vector<bool> OneSidedColumns(const Candidate& c, Eigen::Index columns);

/// Probe directions D_c = r(probe) − r (N × probes; a failed probe's column 0) of the candidates
/// `cands` (library indices) on top of the model (params, x) whose training predictions are
/// `pred` and residual r; all probe simulations in one batch through ctx.Map. Split per trial
/// (PerTrialDirections): N × (probes · trials), column t·probes + p the probe p of trial t alone.
std::map<int, Eigen::MatrixXd> ProbeDirections(
    const StageContext& ctx, const std::vector<Candidate>& library,
    const std::vector<ModelParameter>& params, const Eigen::VectorXd& x,
    const std::vector<Trial>& pred, const Eigen::VectorXd& r, const std::vector<int>& cands);

/// The model point a screen tests against.
struct ModelPoint {
  std::vector<ModelParameter> params;
  Eigen::VectorXd x;
  std::vector<Trial> train_predictions;
  Eigen::VectorXd residual;  ///< training rows.
  Eigen::MatrixXd jacobian;  ///< ∂r/∂x, training rows.
};

/// The tests of a screen, per library index (dof 0: not tested).
struct ScreenStage {
  std::vector<ScoreTest> tests;
};
Json ToJson(const ScreenStage& s);
void FromJson(const Json& j, ScreenStage* s);

/// Directions from an earlier model point (ProbeDirections' result), computed only when needed.
using DirectionsProvider = std::function<const std::map<int, Eigen::MatrixXd>&()>;

/// Robust score tests of every applicable candidate whose id is not in `skip`, cached under
/// `key`. `screen_with` (second round; may be empty): directions from an earlier point — a
/// candidate whose test with them stays insignificant at twice its statistic keeps that test and
/// is not probed here (the directions change little on top of an extension, the residual more);
/// called only when the tests are computed, not when they come from the resume cache.
/// `directions` (may be null) receives the directions probed here.
ScreenStage Screen(const StageContext& ctx, const std::vector<Candidate>& library,
                   const ModelPoint& point, const std::set<std::string>& skip,
                   const std::vector<std::string>& key, const DirectionsProvider& screen_with,
                   std::map<int, Eigen::MatrixXd>* directions);

/// Number of applicable candidates (Bonferroni's M).
int ApplicableCount(const std::vector<Candidate>& library);

/// min(1, M · P(χ²_dof > s)); 1 when dof is 0.
double AdjustedChiSquareP(double s, int dof, int m);

/// Resets `cr` to test `t` alone (no fit figures): statistic, dof, p, p adjusted over the `m`
/// applicable candidates, score and variance inflation; decision "score test not significant" (or
/// "no direction kept" at dof 0); the evidence line's test part is rewritten and its signature
/// part (after the first "; ") kept.
void SetScoreTest(const ScoreTest& t, int m, CandidateResult* cr);

}  // namespace fesim::diagnosis
