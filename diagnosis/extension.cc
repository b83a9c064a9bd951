#include "diagnosis/extension.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numeric>
#include <set>

#include "base/parallel.h"
#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {
namespace {

/// One extension fit as cached: the fit, whether every parameter was free, its raw training
/// residual, its held-out predictions (null: the extended model cannot simulate them) and the
/// held-out predictions of the same fit with its last candidate switched off (the ablation of
/// Judgement::own_gain; null: no candidate, or not simulable).
struct FitStage {
  FitResult fit;
  bool all_free = false;
  Eigen::VectorXd train_residual;
  bool heldout_ok = false;
  std::vector<Trial> heldout_predictions;
  bool without_last_ok = false;
  std::vector<Trial> heldout_without_last;
};

Json ToJson(const FitStage& s) {
  Json j = Json::Object();
  j.Set("fit", diagnosis::ToJson(s.fit)).Set("all_free", s.all_free);
  j.Set("train_residual", diagnosis::ToJson(s.train_residual));
  j.Set("heldout_predictions", s.heldout_ok ? diagnosis::ToJson(s.heldout_predictions) : Json());
  j.Set("heldout_without_last",
        s.without_last_ok ? diagnosis::ToJson(s.heldout_without_last) : Json());
  return j;
}

void FromJson(const Json& j, FitStage* s) {
  diagnosis::FromJson(Member(j, "fit"), &s->fit);
  s->all_free = Member(j, "all_free").AsBool();
  diagnosis::FromJson(Member(j, "train_residual"), &s->train_residual);
  const Json& h = Member(j, "heldout_predictions");
  s->heldout_ok = !h.IsNull();
  if (s->heldout_ok) diagnosis::FromJson(h, &s->heldout_predictions);
  const Json* w = j.Find("heldout_without_last");  // absent in caches of older builds
  s->without_last_ok = w != nullptr && !w->IsNull();
  if (s->without_last_ok) diagnosis::FromJson(*w, &s->heldout_without_last);
}

/// A fitted extension with its held-out figures.
struct Fitted {
  std::vector<int> cands;
  FitStage stage;
  double heldout_nrmse = INFINITY;
  Eigen::VectorXd heldout_residual;
  double heldout_nrmse_without_last = NAN;        ///< FitStage::heldout_without_last's.
  Eigen::VectorXd heldout_residual_without_last;  ///< and its residual (empty: not measured).
};

/// The tests of one fit against the model it extends.
struct Judgement {
  double lr = 0.0, lr_p_adj = 1.0, gain = -INFINITY, z = 0.0, z_p_adj = 1.0;
  /// The candidate's own part of the held-out gain: the fit with the candidate switched off
  /// (its parameters removed, the person and earlier mechanisms as fitted) against the fit, over
  /// the reference's NRMSE. A fit whose gain comes from the person moving while the mechanism
  /// stays near "off" (a tremor of 0.6 mN·m gaining 12 % on a foreign spasticity) has a small
  /// own gain. NaN: not measured (then not a condition).
  double own_gain = NAN;
  /// Diebold–Mariano statistic of the own part (the fit against the fit with the candidate
  /// switched off) and its p adjusted as z_p_adj's.
  double own_z = 0.0, own_z_p_adj = 1.0;
  std::string collapsed;
  std::string at_bound;  ///< a parameter at a bound of its plausible range ("": none).
  /// The person parameters of the candidate's joint at a bound of their range in the model it
  /// extends (JointParametersAtBound; "": none).
  std::string person_at_bound;
  std::string normal;  ///< WithinNormalVariation's text ("": beyond it, or no band).
  /// Mechanism::shape_contradiction on the residual of the model it extends ("": none).
  std::string shape;
  bool passes = false;
};

class Extender {
 public:
  Extender(const StageContext& ctx, const std::vector<Candidate>& library,
           const CalibrationStage& cal, const std::vector<ModelParameter>& person,
           bool reference_gap, std::vector<CandidateResult>* results)
      : ctx_(ctx),
        lib_(library),
        cal_(cal),
        person_(person),
        reference_gap_(reference_gap),
        results_(results) {
    m_ = ApplicableCount(library);
    ns_ = static_cast<int>(person.size());
    base_.cands = {};
    base_.stage.fit = cal.fit;
    base_.stage.all_free = true;
    base_.stage.train_residual = StackResiduals(ctx.data.train, cal.train_predictions);
    base_.stage.heldout_ok = true;
    base_.stage.heldout_predictions = cal.heldout_predictions;
    Complete(&base_);
    on_top_reference_.assign(library.size(), NAN);
  }

  ExtensionOutcome Run(const ScreenStage& screen, std::map<int, Eigen::MatrixXd> directions);

 private:
  std::vector<ModelParameter> ParamsOf(const std::vector<int>& cands) const {
    std::vector<ModelParameter> p = person_;
    for (int c : cands) p = Join(p, lib_[c].params);
    return p;
  }
  void Complete(Fitted* f) const {
    if (!f->stage.heldout_ok) return;
    f->heldout_nrmse = ViewNrmse(ctx_.data.heldout, f->stage.heldout_predictions);
    f->heldout_residual = StackResiduals(ctx_.data.heldout, f->stage.heldout_predictions);
    if (f->stage.without_last_ok) {
      f->heldout_nrmse_without_last = ViewNrmse(ctx_.data.heldout, f->stage.heldout_without_last);
      f->heldout_residual_without_last =
          StackResiduals(ctx_.data.heldout, f->stage.heldout_without_last);
    }
  }
  /// The tests of fit `f` (candidate c's parameters at `offset` of its x) against `ref`.
  Judgement Judge(const Fitted& f, const Fitted& ref, int c, Eigen::Index offset) const;
  /// Judge with c's parameters last.
  Judgement JudgeLast(const Fitted& f, const Fitted& ref, int c) const {
    return Judge(f, ref, c,
                 f.stage.fit.x.size() - static_cast<Eigen::Index>(lib_[c].params.size()));
  }
  Fitted FitExtension(const std::vector<int>& cands, const Eigen::VectorXd& x0, int iterations,
                      double fd_step = 0.0);
  /// `from_test_step`: x0's last candidate block is a start from a score test's step, which is
  /// backtracked towards "off" while it costs more than the model it extends.
  FitStage FitStageOf(const std::vector<int>& cands, const Eigen::VectorXd& x0, int iterations,
                      double fd_step, bool from_test_step = false);
  /// Σr² of the model `cands` extend: the control for one candidate, the extended model for a
  /// candidate on top of the accepted ones.
  double ReferenceCost(const std::vector<int>& cands) const {
    return cands.size() > 1 && current_.stage.train_residual.size()
               ? current_.stage.train_residual.squaredNorm()
               : base_.stage.train_residual.squaredNorm();
  }
  /// Probes the directions (at the calibration) of those of `cands` not known yet, in one batch;
  /// the first screen's are handed in.
  void EnsureDirections(const std::vector<int>& cands);
  Eigen::VectorXd LowestProfileStart(int c);
  /// The extended model's prediction of the held-out trials; a candidate's free phase
  /// (Candidate::free_phase_param) is chosen per held-out trial: with the response linear in
  /// (cos φ, sin φ) of the phase offset, three simulations per trial (offsets 0, π/2, π) give
  /// ŷ(φ) = c + a cos φ + b sin φ, φ* = atan2(⟨r_c, b⟩, ⟨r_c, a⟩) with r_c = y − c, and a fourth
  /// the prediction at φ*. Per-trial drifts (Candidate::drift_per_trial) are those of the
  /// held-out recording: AddHeldoutDrift.
  std::vector<Trial> HeldoutPrediction(const std::vector<int>& cands,
                                       const std::vector<ModelParameter>& params,
                                       const Eigen::VectorXd& x, const FitOptions& fo, int* sims);
  /// `cands` by decreasing score statistic in `tests`, the strongest joint per id, at most
  /// `limit` of them.
  std::vector<int> StrongestPerId(std::vector<int> cands, const ScreenStage& tests,
                                  int limit) const;
  /// One group per candidate of `reps`: it, then — when its mechanism chooses its joint by the
  /// fit (Candidate::joint_by_fit) — the other joints of its id in `significant`, in that order.
  std::vector<std::vector<int>> JointGroups(const std::vector<int>& reps,
                                            const std::vector<int>& significant) const;
  /// Of fits[first, first + n), the index of the lowest training Σr²: the joint chosen by the fit.
  static std::size_t LowestCost(const std::vector<Fitted>& fits, std::size_t first, std::size_t n);
  /// Records the fit of a joint that the fit did not choose (JointGroups): its figures, and a
  /// decision naming the chosen candidate `chosen` and its training Σr².
  void RecordNotChosen(int c, const Fitted& f, const Judgement& j, int chosen, double chosen_cost);
  /// Makes `control` (the person alone refitted from where candidate c's fit ended) the
  /// control when it beats it on training Σr² and on held-out NRMSE (extension.h, Control).
  /// `route` says how that person was reached, for baseline_note.
  void AdoptBetterControl(const Fitted& control, int c, const std::string& route);
  /// The fit of `fits` whose person, with its candidate switched off, predicts the held-out
  /// trial best, when that beats the control by clear_heldout_gain: the person alone is refitted
  /// from there and offered to AdoptBetterControl (extension.h, Control).
  void AdoptRemovedPerson(const std::vector<Fitted>& fits);
  /// The screening fits of `members` (extension.h, Screening), side by side; `controls`: per
  /// member the person refitted from a better profile start (empty Fitted: none), already
  /// offered to AdoptBetterControl.
  std::vector<Fitted> FitScreened(const std::vector<int>& members, const ScreenStage& screen,
                                  std::vector<Fitted>* controls);
  void ScreenRound(const ScreenStage& screen);
  /// The score tests repeated at an adopted control (AdoptBetterControl): the first screen's
  /// tests were at the calibration; every candidate's figures restart from these.
  ScreenStage RescreenAtControl();
  /// `point`'s training predictions and residual Jacobian at its params and x (cached under
  /// `key` + "point").
  void CompletePoint(std::vector<std::string> key, ModelPoint* point);
  bool OnTopRound();
  void BackwardStep();
  void FinalRefit();
  void Record(int c, const Fitted& f, const Judgement& j);

  const StageContext& ctx_;
  const std::vector<Candidate>& lib_;
  const CalibrationStage& cal_;
  const std::vector<ModelParameter>& person_;
  const bool reference_gap_;  ///< the calibrated model misses the black box somewhere.
  std::vector<CandidateResult>* results_;
  int m_ = 0, ns_ = 0;
  Fitted base_, current_;
  std::vector<Fitted> round1_;
  std::vector<int> accepted_;
  std::set<std::string> dropped_;
  std::map<int, double> accept_p_, accept_gain_;
  std::string baseline_note_;  ///< ExtensionOutcome::baseline_note.
  std::string adoptions_;      ///< the controls adopted (AdoptBetterControl), in words.
  std::vector<double> on_top_reference_;
  /// End point of a fit run here: its residual and predictions, and its Jacobian's columns with
  /// the parameter (index into ParamsOf) of each.
  struct EndPoint {
    FitStart start;
    std::vector<int> columns;
  };
  /// What is known at `point_key` (PointKey) for a fit whose free parameters are `free_order`:
  /// residual and predictions, and the Jacobian when every free column is known.
  FitStart KnownEnd(const std::string& point_key, const std::vector<int>& free_order);
  // A fit from the end point of an earlier one starts without simulating it again.
  std::map<std::string, EndPoint> ends_;
  std::mutex ends_mutex_;
  std::map<int, Eigen::MatrixXd> directions_;  ///< the first screen's probe directions.
  std::mutex directions_mutex_;
};

/// Halvings of an extension's start towards its "off" values at most (FitStageOf).
constexpr int kStartHalvings = 3;
constexpr double kPi = 3.14159265358979323846;

/// Each held-out trial's own drift of every output (Candidate::drift_per_trial): the rate that
/// fits the residual of `predictions` over the first half of the trial's counted samples (least
/// squares on t, the drift starting at 0 with the recording), added to the whole trial. A
/// recording's drift rates can only come from the recording itself; its second half is then a
/// prediction, so that slow misfit a free trend would absorb over the whole trial does not count
/// as a held-out gain.
void AddHeldoutDrift(const DataView& held, std::vector<Trial>* predictions) {
  for (std::size_t t = 0; t < held.trials.size(); ++t) {
    const Trial& measured = held.trials[t];
    Trial& predicted = (*predictions)[t];
    std::vector<std::size_t> counted;
    for (std::size_t i = 0; i < measured.time.size(); ++i) {
      if (held.use[t][i]) counted.push_back(i);
    }
    if (counted.size() < 2) continue;
    const double half_time = measured.time[counted[counted.size() / 2]];
    for (const auto& name : held.outputs) {
      const auto& y = measured.Column(name);
      auto& y_hat = predicted.MutableColumn(name);
      double num = 0.0, den = 0.0;
      for (const std::size_t i : counted) {
        const double ti = measured.time[i];
        if (ti > half_time) break;
        if (!std::isfinite(y[i])) continue;
        num += (y[i] - y_hat[i]) * ti;
        den += ti * ti;
      }
      if (den <= 0.0) continue;
      const double rate = num / den;
      for (std::size_t i = 0; i < y_hat.size(); ++i) y_hat[i] += rate * predicted.time[i];
    }
  }
}

/// The residual a candidate's output terms are to explain, per training trial and output: the
/// residual r1 of its fit with its own output terms (ModelParameter::kOutputDrift, value · t at
/// `params`' values from x(offset)) added back — what the person fitted beside the candidate
/// leaves for it. The control's residual would show the candidate's signature after the control's
/// person absorbed part of it: a calibration that reaches a sensor's drift through stimulation-
/// locked parameters leaves steps at the stimulation changes (Signature shape in
/// docs/diagnosis.md).
std::vector<ResidualSeries> OwnShareResidual(const DataView& train, const Eigen::VectorXd& r1,
                                             const std::vector<ModelParameter>& params,
                                             const Eigen::VectorXd& x, Eigen::Index offset) {
  std::vector<ResidualSeries> out = UnstackResiduals(train, r1);
  for (std::size_t k = 0; k < params.size(); ++k) {
    const ModelParameter& p = params[k];
    if (p.target != ModelParameter::Target::kOutputDrift) continue;
    const double rate = x(offset + static_cast<Eigen::Index>(k));
    for (ResidualSeries& s : out) {
      if (s.output != p.column || !AppliesToTrial(p, s.trial)) continue;
      for (std::size_t i = 0; i < s.r.size(); ++i) s.r[i] += rate * s.time_s[i];
    }
  }
  return out;
}

std::string PointKey(const std::vector<int>& cands, const Eigen::VectorXd& x) {
  std::string key;
  for (int c : cands) key += std::to_string(c) + ";";
  return VectorKey(key, x);
}

Judgement Extender::Judge(const Fitted& f, const Fitted& ref, int c, Eigen::Index offset) const {
  Judgement j;
  const int p = static_cast<int>(lib_[c].params.size());
  j.collapsed = CollapsedParameter(lib_[c].params, f.stage.fit.x, offset);
  j.at_bound = ParameterAtRangeBound(lib_[c].params, f.stage.fit.x, offset);
  const Mechanism& mechanism = FindMechanism(lib_[c].id);
  if (mechanism.mimics_joint_person) {
    j.person_at_bound = JointParametersAtBound(person_, ref.stage.fit.x, lib_[c].joint);
  }
  j.normal = WithinNormalVariation(lib_[c].params, f.stage.fit.x, offset, f.stage.fit.ci95);
  const Eigen::VectorXd& r0 = ref.stage.train_residual;
  const Eigen::VectorXd& r1 = f.stage.train_residual;
  if (r1.size() == r0.size()) {
    j.lr = RobustLikelihoodRatio(ctx_.train_rows, r0, r1);
    j.lr_p_adj = AdjustedChiSquareP(j.lr, p, m_);
  }
  if (std::isfinite(f.heldout_nrmse) && std::isfinite(ref.heldout_nrmse)) {
    j.gain = (ref.heldout_nrmse - f.heldout_nrmse) / ref.heldout_nrmse;
    j.z = DieboldMariano(ctx_.heldout_rows, ref.heldout_residual, f.heldout_residual);
    // Bonferroni over the fits a round can run (the score test already controls the library).
    j.z_p_adj = std::min(1.0, ctx_.settings.max_screened * NormalSurvival(j.z));
    const bool last = !f.cands.empty() && f.cands.back() == c &&
                      offset == f.stage.fit.x.size() - static_cast<Eigen::Index>(p);
    if (last && std::isfinite(f.heldout_nrmse_without_last)) {
      j.own_gain = (f.heldout_nrmse_without_last - f.heldout_nrmse) / ref.heldout_nrmse;
      j.own_z =
          DieboldMariano(ctx_.heldout_rows, f.heldout_residual_without_last, f.heldout_residual);
      j.own_z_p_adj = std::min(1.0, ctx_.settings.max_screened * NormalSurvival(j.own_z));
    }
  }
  if (mechanism.shape_contradiction && r1.size() > 0) {
    j.shape = mechanism.shape_contradiction(
        OwnShareResidual(ctx_.data.train, r1, lib_[c].params, f.stage.fit.x, offset));
  }
  const double alpha = ctx_.settings.alpha;
  j.passes = j.collapsed.empty() && j.at_bound.empty() && j.person_at_bound.empty() &&
             j.normal.empty() && j.shape.empty() && j.lr_p_adj < alpha &&
             OwnGainAccepted(j.own_gain, j.own_z_p_adj, ctx_.settings) &&
             HeldoutGainAccepted(j.gain, j.z_p_adj, ctx_.settings);
  return j;
}

void Extender::EnsureDirections(const std::vector<int>& cands) {
  const std::lock_guard<std::mutex> lock(directions_mutex_);
  std::vector<int> missing;
  for (int c : cands) {
    if (!directions_.count(c)) missing.push_back(c);
  }
  if (missing.empty()) return;
  for (auto& [c, d] : ProbeDirections(ctx_, lib_, person_, cal_.fit.x, cal_.train_predictions,
                                      base_.stage.train_residual, missing)) {
    directions_[c] = std::move(d);
  }
}

FitStart Extender::KnownEnd(const std::string& point_key, const std::vector<int>& free_order) {
  const std::lock_guard<std::mutex> lock(ends_mutex_);
  const auto it = ends_.find(point_key);
  if (it == ends_.end()) return {};
  FitStart start = it->second.start;
  const std::vector<int>& known = it->second.columns;
  start.jacobian.resize(0, 0);
  if (known.empty()) return start;
  Eigen::MatrixXd j(it->second.start.jacobian.rows(), static_cast<Eigen::Index>(free_order.size()));
  for (std::size_t i = 0; i < free_order.size(); ++i) {
    const auto k = std::find(known.begin(), known.end(), free_order[i]);
    if (k == known.end()) return start;
    j.col(static_cast<Eigen::Index>(i)) = it->second.start.jacobian.col(k - known.begin());
  }
  start.jacobian = std::move(j);
  return start;
}

FitStage Extender::FitStageOf(const std::vector<int>& cands, const Eigen::VectorXd& x0,
                              int iterations, double fd_step, bool from_test_step) {
  const std::vector<ModelParameter> params = ParamsOf(cands);
  // Every person parameter is fitted with the candidates, which the key states ("person=all")
  // for caches whose fits freed fewer.
  std::vector<std::string> key = {"extension", "person=all"};
  for (int c : cands) key.push_back(std::to_string(c) + ":" + lib_[c].label);
  key.push_back(VectorKey("x0", x0));
  key.push_back("iterations=" + std::to_string(iterations));
  if (from_test_step) key.emplace_back("backtracked start");
  FitOptions fo = ctx_.fit;
  fo.prior_sigma = cal_.prior_sigma_rad;
  if (fd_step > 0.0) {
    fo.fd_step = fd_step;
    key.push_back("fd_step=" + ExactNumberText(fd_step));
  }
  return ctx_.cache.Get<FitStage>(key, [&] {
    // All person parameters are fitted with the candidates' (docs/diagnosis.md, Extension and
    // acceptance).
    std::vector<int> columns(params.size());
    std::iota(columns.begin(), columns.end(), 0);
    Eigen::VectorXd x_start = x0;  // may be backtracked below
    FitStart start = KnownEnd(PointKey(cands, x0), columns);
    if (fd_step > 0.0) start.jacobian.resize(0, 0);  // a known Jacobian is at the default step
    int sims = 0;
    if (start.residual.size() == 0 && from_test_step) {
      // Backtracking on the start: a Gauss–Newton step from the tests can overshoot into a basin
      // worse than the model without the mechanism, where LM then stays (a foreign
      // force_length_velocity ended 33 % worse on held-out data). Halve the mechanism's step
      // from its "off" values while the start costs more than the model it extends.
      const double reference = ReferenceCost(cands);
      Eigen::VectorXd off = x_start;
      const auto n_mech = static_cast<Eigen::Index>(lib_[cands.back()].params.size());
      const Eigen::Index first_mech = x_start.size() - n_mech;
      for (Eigen::Index k = 0; k < n_mech; ++k) off(first_mech + k) = params[first_mech + k].start;
      for (int halving = 0; halving <= kStartHalvings; ++halving) {
        std::vector<Trial> pred;
        try {
          pred = Predict(ctx_.rig, params, x_start, ctx_.data.train, fo);
        } catch (const std::runtime_error&) {
          pred.clear();
        }
        sims += static_cast<int>(ctx_.data.train.trials.size());
        if (!pred.empty()) {
          start.residual = StackResiduals(ctx_.data.train, pred);
          start.predictions = pred;
          if (start.residual.squaredNorm() <= reference) break;
        }
        if (halving == kStartHalvings) break;
        x_start.tail(n_mech) = 0.5 * (x_start.tail(n_mech) + off.tail(n_mech));
        start = FitStart();
      }
    }
    const FitResult fit = FitParameters(ctx_.rig, params, x_start, ctx_.data.train, fo, 0,
                                        iterations, nullptr, &start);
    sims += fit.simulations;
    FitStage s;
    s.fit = fit;
    s.all_free = true;
    s.train_residual = fit.residual;
    if (s.train_residual.size() != ctx_.data.train.Count()) {
      s.train_residual =
          StackResiduals(ctx_.data.train, Predict(ctx_.rig, params, fit.x, ctx_.data.train, fo));
      sims += static_cast<int>(ctx_.data.train.trials.size());
    }
    if (fd_step <= 0.0 && fit.residual.size() > 0) {
      EndPoint end;
      end.start.residual = fit.residual;
      end.start.predictions = fit.predictions;
      if (fit.jacobian_x.size() == fit.x.size() && fit.jacobian_x == fit.x) {
        end.start.jacobian = fit.jacobian;
        end.columns = columns;
      }
      const std::lock_guard<std::mutex> lock(ends_mutex_);
      ends_[PointKey(cands, fit.x)] = std::move(end);
    }
    try {
      s.heldout_predictions = HeldoutPrediction(cands, params, fit.x, fo, &sims);
      s.heldout_ok = true;
    } catch (const std::runtime_error&) {
      // The extended model cannot simulate the held-out data (e.g. driven past a joint's
      // range): it predicts nothing there and is not accepted.
    }
    if (s.heldout_ok && !cands.empty()) {
      // The ablation: the last candidate's block (the tail of x, ParamsOf's order) removed.
      const std::vector<int> rest(cands.begin(), cands.end() - 1);
      const auto n_last = static_cast<Eigen::Index>(lib_[cands.back()].params.size());
      try {
        s.heldout_without_last =
            HeldoutPrediction(rest, ParamsOf(rest), fit.x.head(fit.x.size() - n_last), fo, &sims);
        s.without_last_ok = true;
      } catch (const std::runtime_error&) {
        // not simulable without it: no ablation figure, no condition
      }
    }
    *ctx_.simulations += sims;
    return s;
  });
}

Fitted Extender::FitExtension(const std::vector<int>& cands, const Eigen::VectorXd& x0,
                              int iterations, double fd_step) {
  Fitted f;
  f.cands = cands;
  f.stage = FitStageOf(cands, x0, iterations, fd_step);
  Complete(&f);
  return f;
}

std::vector<Trial> Extender::HeldoutPrediction(const std::vector<int>& cands,
                                               const std::vector<ModelParameter>& params,
                                               const Eigen::VectorXd& x, const FitOptions& fo,
                                               int* sims) {
  const DataView& held = ctx_.data.heldout;
  // Per candidate with a free phase, the indices into x of its phase (every trial's copy,
  // Candidate::phase_per_trial): all start from the first training trial's and move together.
  std::vector<std::vector<Eigen::Index>> phases;
  Eigen::VectorXd x_held = x;
  Eigen::Index at = ns_;
  bool drift_per_trial = false;
  for (int c : cands) {
    const Candidate& cand = lib_[c];
    if (cand.drift_per_trial) {  // the training recordings' rates are not the held-out's
      drift_per_trial = true;
      x_held.segment(at, static_cast<Eigen::Index>(cand.params.size())).setZero();
    }
    if (cand.free_phase_param >= 0) {
      std::vector<Eigen::Index> ks = {at + cand.free_phase_param};
      for (int k : cand.phase_per_trial) {
        if (k != cand.free_phase_param) ks.push_back(at + k);
      }
      for (const Eigen::Index k : ks) x_held(k) = x(ks[0]);
      phases.push_back(ks);
    }
    at += static_cast<Eigen::Index>(cand.params.size());
  }
  *sims += static_cast<int>(held.trials.size());
  std::vector<Trial> out = Predict(ctx_.rig, params, x_held, held, fo);
  const auto shifted = [&](const std::vector<Eigen::Index>& ks, double offset) {
    Eigen::VectorXd xo = x_held;
    for (const Eigen::Index k : ks) xo(k) += offset;
    return xo;
  };
  for (const std::vector<Eigen::Index>& ks : phases) {
    for (std::size_t t = 0; t < held.trials.size(); ++t) {
      DataView one;
      one.trials = {held.trials[t]};
      one.use = {held.use[t]};
      one.outputs = held.outputs;
      if (t < held.initial_q.size()) one.initial_q = {held.initial_q[t]};
      std::vector<Eigen::VectorXd> r;  // y − ŷ at offsets 0, π/2, π
      for (const double offset : {0.0, 0.5 * kPi, kPi}) {
        r.push_back(
            StackResiduals(one, Predict(ctx_.rig, params, shifted(ks, offset), one, fo, 1)));
        ++*sims;
      }
      // ŷ(φ) = c + a cos φ + b sin φ: c = (ŷ₀ + ŷ_π)/2, a = (ŷ₀ − ŷ_π)/2, b = ŷ_{π/2} − c; in
      // residuals r(φ) = y − ŷ(φ).
      const Eigen::VectorXd rc = 0.5 * (r[0] + r[2]);
      const Eigen::VectorXd a = 0.5 * (r[2] - r[0]), b = rc - r[1];
      out[t] =
          Predict(ctx_.rig, params, shifted(ks, std::atan2(rc.dot(b), rc.dot(a))), one, fo, 1)[0];
      ++*sims;
    }
  }
  if (drift_per_trial) AddHeldoutDrift(held, &out);
  return out;
}

void Extender::Record(int c, const Fitted& f, const Judgement& j) {
  CandidateResult& cr = (*results_)[c];
  cr.fitted = true;
  cr.not_judged = false;  // RecordNotChosen sets it after
  cr.lr_statistic = j.lr;
  cr.lr_p_adjusted = j.lr_p_adj;
  cr.heldout_nrmse = f.heldout_nrmse;
  cr.heldout_gain = j.gain;
  cr.heldout_z = j.z;
  cr.heldout_p_adjusted = j.z_p_adj;
  cr.heldout_own_gain = j.own_gain;
  cr.heldout_own_z = std::isfinite(j.own_gain) ? j.own_z : NAN;
  cr.person_at_bound = j.person_at_bound;
  cr.collapsed = j.collapsed;
  cr.shape = j.shape;
  cr.parameters.clear();
  for (std::size_t p = 0; p < lib_[c].params.size(); ++p) {
    const auto k = static_cast<Eigen::Index>(ns_ + p);
    cr.parameters.push_back(
        {lib_[c].params[p].name, lib_[c].params[p].unit, f.stage.fit.x(k), f.stage.fit.ci95(k)});
  }
  if (!j.collapsed.empty()) {
    cr.decision = j.collapsed + " fitted at its bound, where the mechanism is a person parameter";
  } else if (!j.at_bound.empty()) {
    cr.decision = j.at_bound +
                  " ended at a bound of its plausible range: the fit stands in for a "
                  "misfit of the model, not for the mechanism";
  } else if (!j.person_at_bound.empty()) {
    cr.decision = "the person's " + j.person_at_bound +
                  " ended at a bound of its range: the person lies outside the model's range at " +
                  lib_[c].joint + ", for which a mechanism there may stand in";
  } else if (!j.normal.empty()) {
    cr.decision = j.normal + ": a normal person's variation, not the mechanism";
  } else if (!j.shape.empty()) {
    cr.decision = j.shape;
  } else if (!(j.lr_p_adj < ctx_.settings.alpha)) {
    cr.decision = "its fit does not pass the robust training test";
  } else if (!(j.gain > 0.0)) {
    cr.decision = "no held-out gain";
  } else if (!OwnGainAccepted(j.own_gain, j.own_z_p_adj, ctx_.settings)) {
    cr.decision =
        Fmt("its own part of the held-out gain is %.1f %% (below %.0f %%, Diebold–Mariano z "
            "%.1f not significant): switched off, the fitted model predicts about as well — the "
            "gain comes from the person's refit",
            100.0 * j.own_gain, 100.0 * ctx_.settings.min_heldout_gain, j.own_z);
  } else if (!j.passes) {
    cr.decision = "held-out gain below " +
                  Fmt("%.0f %%", 100.0 * ctx_.settings.clear_heldout_gain) +
                  " and not significant (Diebold–Mariano)";
  } else {
    cr.decision = "passes";
  }
}

Eigen::VectorXd Extender::LowestProfileStart(int c) {
  // With the candidate held at each profile start, the person fitted from the calibration and
  // from the nominal values (side by side); when the starts differ in one parameter and the
  // lowest Σr² is an inner one, two more profile points at the vertex of the parabola through it
  // and its neighbours (ParabolaVertex). Returns person ⊕ candidate values of the lowest Σr²
  // (empty when none simulates).
  constexpr int kVertexRounds = 2;
  const Candidate& cand = lib_[c];
  const auto nc = static_cast<Eigen::Index>(cand.params.size());
  std::vector<ModelParameter> held_first = cand.params;
  held_first.insert(held_first.end(), person_.begin(), person_.end());
  const std::vector<Eigen::VectorXd> person_starts = {cal_.fit.x, Starts(person_)};
  Eigen::Index varied = -1;
  int n_varied = 0;
  for (Eigen::Index k = 0; k < nc; ++k) {
    const bool differs =
        std::any_of(cand.profile_starts.begin(), cand.profile_starts.end(),
                    [&](const Eigen::VectorXd& p) { return p(k) != cand.profile_starts[0](k); });
    if (differs) {
      varied = k;
      ++n_varied;
    }
  }
  if (n_varied != 1) varied = -1;
  FitOptions fo = ctx_.fit;
  fo.prior_sigma = cal_.prior_sigma_rad;
  const std::vector<std::string> key = {"profile_start", std::to_string(c) + ":" + cand.label,
                                        VectorKey("person", cal_.fit.x)};
  const Json j = ctx_.cache.GetJson(key, [&] {
    int sims = 0;
    using Point = std::pair<double, Eigen::VectorXd>;
    const auto lowest_of = [&](const std::vector<Eigen::VectorXd>& x0s, std::size_t group) {
      std::vector<FitResult> fits(x0s.size());
      std::vector<char> ok(fits.size(), 0);
      ParallelFor(fits.size(), fo.threads, [&](std::size_t k) {
        try {
          fits[k] = FitParameters(ctx_.rig, held_first, x0s[k], ctx_.data.train, fo,
                                  static_cast<int>(nc), ctx_.settings.person.iterations);
          ok[k] = 1;
        } catch (const std::runtime_error&) {
          // not simulable with the candidate there: not a start
        }
      });
      std::vector<Point> best(fits.size() / group, Point{INFINITY, Eigen::VectorXd()});
      for (std::size_t k = 0; k < fits.size(); ++k) {
        if (!ok[k]) continue;
        sims += fits[k].simulations;
        if (fits[k].cost < best[k / group].first) best[k / group] = {fits[k].cost, fits[k].x};
      }
      return best;
    };
    std::vector<Eigen::VectorXd> x0s;
    for (const auto& p : cand.profile_starts) {
      for (const auto& s : person_starts) x0s.push_back(Concat(p, s));
    }
    std::vector<Point> profile = lowest_of(x0s, person_starts.size());
    for (int round = 0; round < kVertexRounds && varied >= 0; ++round) {
      std::vector<Point> done;
      for (const auto& pt : profile) {
        if (std::isfinite(pt.first)) done.push_back(pt);
      }
      std::sort(done.begin(), done.end(),
                [&](const auto& a, const auto& b) { return a.second(varied) < b.second(varied); });
      std::size_t m = 0;
      for (std::size_t k = 0; k < done.size(); ++k) {
        if (done[k].first < done[m].first) m = k;
      }
      if (m == 0 || m + 1 >= done.size()) break;
      const auto &p0 = done[m - 1], &p1 = done[m], &p2 = done[m + 1];
      const double v = ParabolaVertex(p0.second(varied), p0.first, p1.second(varied), p1.first,
                                      p2.second(varied), p2.first);
      if (!(v > p0.second(varied) && v < p2.second(varied))) break;
      std::vector<Eigen::VectorXd> at_vertex = {p0.second, p1.second, p2.second};
      for (auto& x : at_vertex) x(varied) = v;
      profile.push_back(lowest_of(at_vertex, at_vertex.size())[0]);
    }
    Eigen::VectorXd best;
    double best_cost = INFINITY;
    for (const auto& pt : profile) {
      if (pt.first < best_cost) {
        best_cost = pt.first;
        best = Concat(pt.second.tail(pt.second.size() - nc), pt.second.head(nc));
      }
    }
    *ctx_.simulations += sims;
    Json r = Json::Object();
    r.Set("x", best.size() ? diagnosis::ToJson(best) : Json());
    return r;
  });
  Eigen::VectorXd x;
  if (!Member(j, "x").IsNull()) diagnosis::FromJson(Member(j, "x"), &x);
  return x;
}

std::vector<int> Extender::StrongestPerId(std::vector<int> cands, const ScreenStage& tests,
                                          int limit) const {
  std::stable_sort(cands.begin(), cands.end(), [&](int a, int b) {
    return tests.tests[a].statistic > tests.tests[b].statistic;
  });
  std::vector<int> out;
  std::set<std::string> seen;
  for (int c : cands) {
    if (static_cast<int>(out.size()) < limit && seen.insert(lib_[c].id).second) out.push_back(c);
  }
  return out;
}

std::vector<std::vector<int>> Extender::JointGroups(const std::vector<int>& reps,
                                                    const std::vector<int>& significant) const {
  std::vector<std::vector<int>> groups;
  for (int r : reps) {
    groups.push_back({r});
    if (!lib_[r].joint_by_fit) continue;
    for (int c : significant) {
      if (c != r && lib_[c].id == lib_[r].id) groups.back().push_back(c);
    }
  }
  return groups;
}

std::size_t Extender::LowestCost(const std::vector<Fitted>& fits, std::size_t first,
                                 std::size_t n) {
  std::size_t best = first;
  for (std::size_t k = first + 1; k < first + n; ++k) {
    if (fits[k].stage.fit.cost < fits[best].stage.fit.cost) best = k;
  }
  return best;
}

void Extender::RecordNotChosen(int c, const Fitted& f, const Judgement& j, int chosen,
                               double chosen_cost) {
  Record(c, f, j);
  (*results_)[c].not_judged = true;
  (*results_)[c].decision =
      "not judged: the fit at " + lib_[chosen].joint +
      Fmt(" has the lower training sum of squares (%.4g against %.4g here; the joint is chosen "
          "by the fit)",
          chosen_cost, f.stage.fit.cost);
}

void Extender::AdoptBetterControl(const Fitted& control, int c, const std::string& route) {
  if (!control.stage.heldout_ok ||
      !(control.stage.train_residual.squaredNorm() < base_.stage.train_residual.squaredNorm()) ||
      !(control.heldout_nrmse < base_.heldout_nrmse)) {
    return;
  }
  const std::string found = "the person refitted alone from where " + lib_[c].label + "'s " +
                            route + Fmt(" ended (%.3f)", control.heldout_nrmse);
  adoptions_ += adoptions_.empty()
                    ? Fmt("the person calibration stopped in a poorer minimum (held-out NRMSE "
                          "%.3f) than ",
                          base_.heldout_nrmse) +
                          found
                    : ", and that person in a poorer one than " + found;
  baseline_note_ =
      adoptions_ + "; that person is the calibrated model the candidates are judged against";
  base_ = control;
}

void Extender::AdoptRemovedPerson(const std::vector<Fitted>& fits) {
  const Fitted* best = nullptr;
  for (const Fitted& f : fits) {
    if (std::isfinite(f.heldout_nrmse_without_last) &&
        f.heldout_nrmse_without_last <
            (1.0 - ctx_.settings.clear_heldout_gain) * base_.heldout_nrmse &&
        (best == nullptr || f.heldout_nrmse_without_last < best->heldout_nrmse_without_last)) {
      best = &f;
    }
  }
  if (best == nullptr) return;
  Fitted control;
  control.stage = FitStageOf({}, best->stage.fit.x.head(ns_), ctx_.settings.screen_iterations, 0.0);
  Complete(&control);
  AdoptBetterControl(control, best->cands.back(), "fit with it switched off");
}

std::vector<Fitted> Extender::FitScreened(const std::vector<int>& members,
                                          const ScreenStage& screen,
                                          std::vector<Fitted>* controls) {
  const std::function<std::string(std::size_t)> item = [&](std::size_t k) {
    const int c = members[k];
    const Eigen::VectorXd x0 =
        Concat(base_.stage.fit.x, lib_[c].start_from_step(screen.tests[c].theta));
    FitStage s = FitStageOf({c}, x0, ctx_.settings.screen_iterations, 0.0, true);
    Json control;  // null: judged against the calibrated person
    if (reference_gap_ && !lib_[c].profile_starts.empty()) {
      const Eigen::VectorXd x = LowestProfileStart(c);
      if (x.size()) {
        FitStage alt = FitStageOf({c}, x, ctx_.settings.screen_iterations, 0.0);
        if (alt.fit.cost < s.fit.cost) {
          // A profile start may lead the person to a better minimum than the calibration's: the
          // person alone refitted from where the candidate's fit ended (extension.h, Control).
          control =
              ToJson(FitStageOf({}, alt.fit.x.head(ns_), ctx_.settings.screen_iterations, 0.0));
          s = std::move(alt);
        }
      }
    }
    Json r = Json::Object();
    r.Set("fit", ToJson(s)).Set("control", control);
    return r.Dump(0);
  };
  const std::vector<std::string> texts = ctx_.Map(members.size(), item);
  std::vector<Fitted> fits(members.size());
  controls->assign(members.size(), Fitted());
  for (std::size_t k = 0; k < members.size(); ++k) {
    const Json item_json = Json::Parse(texts[k], "screening fit");
    fits[k].cands = {members[k]};
    FromJson(Member(item_json, "fit"), &fits[k].stage);
    Complete(&fits[k]);
    if (!Member(item_json, "control").IsNull()) {
      FromJson(Member(item_json, "control"), &(*controls)[k].stage);
      Complete(&(*controls)[k]);
      AdoptBetterControl((*controls)[k], members[k], "profile-start fit");
    }
  }
  return fits;
}

void Extender::ScreenRound(const ScreenStage& screen) {
  const double alpha = ctx_.settings.alpha;
  std::vector<int> order;
  for (std::size_t c = 0; c < lib_.size(); ++c) {
    const bool profiled = reference_gap_ && !lib_[c].profile_starts.empty();
    if (lib_[c].applicable && ((*results_)[c].p_adjusted < alpha || profiled))
      order.push_back(static_cast<int>(c));
  }
  const std::vector<int> significant = order;
  order = StrongestPerId(order, screen, ctx_.settings.max_screened);
  const auto rep_of = [&](int c) {  // the fitted candidate of c's id, or order.end()
    return std::find_if(order.begin(), order.end(),
                        [&](int o) { return lib_[o].id == lib_[c].id; });
  };
  for (int c : significant) {  // why a candidate to be screened is not fitted
    if (std::find(order.begin(), order.end(), c) != order.end()) continue;
    const auto same_id = rep_of(c);
    if (same_id != order.end() && lib_[c].joint_by_fit) continue;  // fitted with its group
    (*results_)[c].decision =
        same_id != order.end()
            ? "not fitted: " + lib_[*same_id].label +
                  " has the larger score statistic (one joint per mechanism is fitted)"
            : Fmt("not fitted: beyond the %.0f strongest mechanisms", ctx_.settings.max_screened);
  }
  int best = -1;
  std::vector<int> reps;
  for (std::size_t first = 0; first < order.size() && best < 0; first += reps.size()) {
    reps.assign(order.begin() + static_cast<std::ptrdiff_t>(first),
                order.begin() + static_cast<std::ptrdiff_t>(std::min(
                                    order.size(), first + std::max(1, ctx_.settings.max_fitted))));
    ctx_.Report(0.4 + 0.35 * first / order.size(),
                "fitting " + std::to_string(reps.size()) + " extensions");
    const std::vector<std::vector<int>> groups = JointGroups(reps, significant);
    std::vector<int> members;
    for (const auto& g : groups) members.insert(members.end(), g.begin(), g.end());
    std::vector<Fitted> controls;
    std::vector<Fitted> fits = FitScreened(members, screen, &controls);
    AdoptRemovedPerson(fits);
    std::size_t at = 0;
    for (const auto& g : groups) {
      const std::size_t chosen = LowestCost(fits, at, g.size());
      const double chosen_cost = fits[chosen].stage.fit.cost;
      for (std::size_t k = at; k < at + g.size(); ++k) {
        const int c = members[k];
        // A profiled fit must beat both the control and its own refitted person (extension.h).
        Judgement j = JudgeLast(fits[k], base_, c);
        if (controls[k].stage.train_residual.size()) {
          const Judgement own = JudgeLast(fits[k], controls[k], c);
          if (!own.passes || own.gain < j.gain) j = own;
        }
        if (k != chosen) {
          RecordNotChosen(c, fits[k], j, members[chosen], chosen_cost);
        } else {
          Record(c, fits[k], j);
        }
        round1_.push_back(std::move(fits[k]));
        if (k == chosen && j.passes &&
            (best < 0 || j.gain > (*results_)[round1_[best].cands[0]].heldout_gain)) {
          best = static_cast<int>(round1_.size()) - 1;
        }
      }
      at += g.size();
    }
  }
  if (best < 0) return;
  const int c1 = round1_[best].cands[0];
  for (int c : significant) {
    const auto same_id = rep_of(c);
    const bool grouped = std::find(order.begin(), order.end(), c) != order.end() ||
                         (same_id != order.end() && lib_[c].joint_by_fit);
    if (grouped && !(*results_)[c].fitted) {
      (*results_)[c].decision = "not fitted: " + lib_[c1].label +
                                " passed in an earlier batch of larger score statistics";
    }
  }
  accepted_.push_back(c1);
  (*results_)[c1].accepted = true;
  accept_p_[c1] = (*results_)[c1].lr_p_adjusted;
  accept_gain_[c1] = (*results_)[c1].heldout_gain;
  // Its polished screening fit; refitted when LM stopped on the iteration limit.
  if (round1_[best].stage.all_free && round1_[best].stage.fit.converged) {
    current_ = round1_[best];
  } else {
    ctx_.Report(0.78, "refitting " + lib_[c1].label + " with the person parameters");
    current_ = FitExtension({c1}, round1_[best].stage.fit.x, ctx_.settings.refit_iterations);
  }
}

void Extender::CompletePoint(std::vector<std::string> key, ModelPoint* point) {
  key.emplace_back("point");
  const Json j = ctx_.cache.GetJson(key, [&] {
    int sims = 0;
    const std::vector<Trial> pred =
        Predict(ctx_.rig, point->params, point->x, ctx_.data.train, ctx_.fit);
    sims += static_cast<int>(ctx_.data.train.trials.size());
    const Eigen::MatrixXd jac = ResidualJacobian(ctx_.rig, point->params, point->x, point->residual,
                                                 ctx_.data.train, ctx_.fit, &sims);
    *ctx_.simulations += sims;
    Json r = Json::Object();
    r.Set("train_predictions", diagnosis::ToJson(pred)).Set("jacobian", diagnosis::ToJson(jac));
    return r;
  });
  diagnosis::FromJson(Member(j, "train_predictions"), &point->train_predictions);
  diagnosis::FromJson(Member(j, "jacobian"), &point->jacobian);
}

ScreenStage Extender::RescreenAtControl() {
  ModelPoint point;
  point.params = person_;
  point.x = base_.stage.fit.x;
  point.residual = base_.stage.train_residual;
  const std::vector<std::string> key = {"rescreen", VectorKey("x", point.x)};
  CompletePoint(key, &point);
  ctx_.Report(0.6, "score tests at the adopted control");
  std::vector<std::string> test_key = key;
  test_key.emplace_back("score_tests");
  std::map<int, Eigen::MatrixXd> directions;
  const ScreenStage tests = Screen(ctx_, lib_, point, {}, test_key, nullptr, &directions);
  {
    const std::lock_guard<std::mutex> lock(directions_mutex_);
    for (auto& [c, d] : directions) directions_[c] = std::move(d);
  }
  const int m = ApplicableCount(lib_);
  for (std::size_t c = 0; c < lib_.size(); ++c) {
    if (lib_[c].applicable) SetScoreTest(tests.tests[c], m, &(*results_)[c]);
  }
  round1_.clear();
  return tests;
}

bool Extender::OnTopRound() {
  std::set<std::string> ids;
  std::vector<std::string> key = {"on_top"};
  for (int c : accepted_) {
    ids.insert(lib_[c].id);
    key.push_back(std::to_string(c) + ":" + lib_[c].label);
  }
  for (const auto& id : dropped_) {
    ids.insert(id);
    key.push_back("dropped:" + id);
  }
  key.push_back(VectorKey("x", current_.stage.fit.x));
  ModelPoint point;
  point.params = ParamsOf(accepted_);
  point.x = current_.stage.fit.x;
  point.residual = current_.stage.train_residual;
  CompletePoint(key, &point);
  // The first screen's directions, for every applicable candidate (probed only when these tests
  // are computed and the first screen came from the resume cache).
  const DirectionsProvider first_screen = [this]() -> const std::map<int, Eigen::MatrixXd>& {
    std::vector<int> applicable;
    for (std::size_t c = 0; c < lib_.size(); ++c) {
      if (lib_[c].applicable) applicable.push_back(static_cast<int>(c));
    }
    EnsureDirections(applicable);
    return directions_;
  };
  ctx_.Report(0.8, "score tests on top of the extended model");
  std::vector<std::string> test_key = key;
  test_key.emplace_back("score_tests");
  const ScreenStage tests = Screen(ctx_, lib_, point, ids, test_key, first_screen, nullptr);
  std::vector<int> order;
  for (std::size_t c = 0; c < lib_.size(); ++c) {
    if (!lib_[c].applicable || ids.count(lib_[c].id) || tests.tests[c].dof == 0) continue;
    (*results_)[c].score_on_accepted = tests.tests[c].statistic;
    if (AdjustedChiSquareP(tests.tests[c].statistic, tests.tests[c].dof, m_) <
        ctx_.settings.alpha) {
      order.push_back(static_cast<int>(c));
    }
  }
  const std::vector<int> significant = order;
  order = StrongestPerId(order, tests, ctx_.settings.max_fitted);
  if (order.empty()) return false;
  const std::vector<std::vector<int>> groups = JointGroups(order, significant);
  std::vector<int> members;
  for (const auto& g : groups) members.insert(members.end(), g.begin(), g.end());
  // Start: a candidate's own first-round fit when it passed its training test there, else the
  // Gauss–Newton step of its test on top of the extended model.
  const auto start_on_top = [&](int c) {
    for (const auto& f : round1_) {
      if (f.cands[0] == c && (*results_)[c].lr_p_adjusted < ctx_.settings.alpha) {
        return Concat(current_.stage.fit.x, f.stage.fit.x.tail(lib_[c].params.size()));
      }
    }
    return Concat(current_.stage.fit.x, lib_[c].start_from_step(tests.tests[c].theta));
  };
  const std::function<std::string(std::size_t)> item = [&](std::size_t k) {
    std::vector<int> cands = accepted_;
    cands.push_back(members[k]);
    return ToJson(FitStageOf(cands, start_on_top(members[k]), ctx_.settings.screen_iterations, 0.0,
                             true))
        .Dump(0);
  };
  ctx_.Report(0.85, "fitting " + std::to_string(members.size()) + " extensions on top");
  const std::vector<std::string> texts = ctx_.Map(members.size(), item);
  std::vector<Fitted> on_top(members.size());
  for (std::size_t k = 0; k < members.size(); ++k) {
    on_top[k].cands = accepted_;
    on_top[k].cands.push_back(members[k]);
    FromJson(Json::Parse(texts[k], "fit on top"), &on_top[k].stage);
    Complete(&on_top[k]);
  }
  int pick = -1;
  double pick_gain = 0.0;
  Judgement pick_j;
  std::size_t at = 0;
  for (const auto& g : groups) {  // each group's joint chosen by the fit (JointGroups) is judged
    const std::size_t k = LowestCost(on_top, at, g.size());
    at += g.size();
    const int c = members[k];
    const Judgement j = JudgeLast(on_top[k], current_, c);
    (*results_)[c].heldout_gain_on_accepted = j.gain;
    on_top_reference_[c] = current_.heldout_nrmse;
    if (j.passes && (pick < 0 || j.gain > pick_gain)) {
      pick = static_cast<int>(k);
      pick_gain = j.gain;
      pick_j = j;
    }
  }
  if (pick < 0) return false;
  const int c = members[pick];
  accepted_.push_back(c);
  (*results_)[c].accepted = true;
  (*results_)[c].not_judged = false;  // judged here, whatever the first round chose
  (*results_)[c].decision = "passes on top of " + lib_[accepted_[0]].label;
  accept_p_[c] = pick_j.lr_p_adj;
  accept_gain_[c] = pick_gain;
  current_ = on_top[pick];
  BackwardStep();
  return true;
}

void Extender::BackwardStep() {
  // An earlier mechanism that no longer passes on top of the others (the new one explains what
  // it stood in for) is dropped for good.
  for (std::size_t a = 0; a + 1 < accepted_.size(); ++a) {
    const int old = accepted_[a];
    std::vector<int> rest;
    Eigen::VectorXd x_rest(current_.stage.fit.x.size() -
                           static_cast<Eigen::Index>(lib_[old].params.size()));
    Eigen::Index at = 0, to = 0;
    for (Eigen::Index k = 0; k < ns_; ++k) x_rest(to++) = current_.stage.fit.x(at++);
    for (int c2 : accepted_) {
      const auto np = static_cast<Eigen::Index>(lib_[c2].params.size());
      if (c2 != old) {
        rest.push_back(c2);
        x_rest.segment(to, np) = current_.stage.fit.x.segment(at, np);
        to += np;
      }
      at += np;
    }
    ctx_.Report(0.9, "testing " + lib_[old].label + " on top of the others");
    Fitted without;
    bool have = false;
    if (rest.size() == 1 && (*results_)[rest[0]].lr_p_adjusted < ctx_.settings.alpha) {
      for (const auto& f : round1_) {
        if (f.cands[0] == rest[0] && f.stage.all_free) {
          without = f;
          have = true;
        }
      }
    }
    if (!have) without = FitExtension(rest, x_rest, ctx_.settings.refit_iterations);
    Eigen::Index offset = ns_;  // `old`'s block in the extended model's x
    for (std::size_t i = 0; i < a; ++i) {
      offset += static_cast<Eigen::Index>(lib_[accepted_[i]].params.size());
    }
    const Judgement j = Judge(current_, without, old, offset);
    (*results_)[old].heldout_gain_on_accepted = j.gain;
    on_top_reference_[old] = without.heldout_nrmse;
    if (!std::isfinite(without.heldout_nrmse) || j.passes) continue;
    (*results_)[old].accepted = false;
    (*results_)[old].decision = "dropped: no longer passes on top of the later mechanisms";
    dropped_.insert(lib_[old].id);
    accepted_ = rest;
    current_ = without;
    break;  // one drop per step
  }
}

void Extender::FinalRefit() {
  std::set<double> steps;
  std::vector<Eigen::VectorXd> starts = {current_.stage.fit.x};
  std::vector<Eigen::VectorXd> scan;
  auto at = static_cast<Eigen::Index>(ns_);
  std::vector<std::string> key = {"refit_scan"};
  for (int c : accepted_) {
    const Candidate& cand = lib_[c];
    key.push_back(std::to_string(c) + ":" + cand.label);
    steps.insert(cand.refit_fd_steps.begin(), cand.refit_fd_steps.end());
    if (cand.refit_scan_param >= 0) {
      const auto k = at + cand.refit_scan_param;
      const ModelParameter& par = cand.params[static_cast<std::size_t>(cand.refit_scan_param)];
      for (const double factor : cand.refit_scan_factors) {
        Eigen::VectorXd x = current_.stage.fit.x;
        x(k) = std::clamp(x(k) * factor, par.lower, par.upper);
        scan.push_back(x);
      }
    }
    at += static_cast<Eigen::Index>(cand.params.size());
  }
  if (!scan.empty()) {
    key.push_back(VectorKey("x", current_.stage.fit.x));
    const std::vector<ModelParameter> params = ParamsOf(accepted_);
    const Json costs = ctx_.cache.GetJson(key, [&] {
      Json j = Json::Array();
      for (const auto& x : scan) {
        double cost = INFINITY;
        try {
          cost = StackResiduals(ctx_.data.train,
                                Predict(ctx_.rig, params, x, ctx_.data.train, ctx_.fit))
                     .squaredNorm();
        } catch (const std::runtime_error&) {
          // not simulable there: not a start
        }
        *ctx_.simulations += static_cast<int>(ctx_.data.train.trials.size());
        j.Push(std::isfinite(cost) ? Json(cost) : Json());
      }
      return j;
    });
    std::size_t lowest = scan.size();
    double lowest_cost = INFINITY;
    for (std::size_t k = 0; k < scan.size(); ++k) {
      const Json& v = costs.Items()[k];
      if (!v.IsNull() && v.AsNumber() < lowest_cost) {
        lowest = k;
        lowest_cost = v.AsNumber();
      }
    }
    if (lowest < scan.size()) starts.push_back(scan[lowest]);
  }
  for (std::size_t s = 0; s < starts.size(); ++s) {
    for (const double h : steps) {
      ctx_.Report(0.93, "refitting the extended model at difference step " + ExactNumberText(h));
      Fitted f = FitExtension(accepted_, starts[s], ctx_.settings.refit_iterations, h);
      if (f.stage.fit.cost < current_.stage.fit.cost) current_ = std::move(f);
    }
    if (s > 0) {  // a scanned start: also at the default step
      Fitted f = FitExtension(accepted_, starts[s], ctx_.settings.refit_iterations);
      if (f.stage.fit.cost < current_.stage.fit.cost) current_ = std::move(f);
    }
  }
}

ExtensionOutcome Extender::Run(const ScreenStage& screen,
                               std::map<int, Eigen::MatrixXd> directions) {
  directions_ = std::move(directions);
  ExtensionOutcome out;
  if (!cal_.fit.converged) {
    // The control every candidate is judged against: the person alone, refitted as many LM steps
    // as a candidate's fit gets, so that no candidate is credited with the calibration's own
    // progress.
    ctx_.Report(0.38, "refitting the person (the candidates' control)");
    base_ = FitExtension({}, cal_.fit.x, ctx_.settings.screen_iterations);
    out.baseline_refit = true;
  }
  ScreenRound(screen);
  if (accepted_.empty() && !baseline_note_.empty()) {
    // A better person than the calibration's was adopted as the control: the tests that chose
    // the fitted candidates were at the calibration's residual, so they are run again at the
    // control's, once (extension.h, Control).
    ScreenRound(RescreenAtControl());
  }
  if (!baseline_note_.empty()) {
    out.baseline_refit = true;
    out.baseline_note = baseline_note_;
  } else if (out.baseline_refit) {
    out.baseline_note =
        "the person calibration stopped at its LM iteration limit; the person "
        "refitted " +
        std::to_string(ctx_.settings.screen_iterations) +
        " more steps is the calibrated model the candidates are judged against";
  }
  out.baseline_fit = base_.stage.fit;
  out.baseline_heldout_predictions = base_.stage.heldout_predictions;
  out.on_top_reference = on_top_reference_;
  if (accepted_.empty()) return out;
  // Up to max_accepted mechanisms; the controls (Candidate::control) taken on the way do not
  // count, but each round takes one more candidate, so the rounds stay bounded.
  const auto mechanisms_accepted = [&] {
    return std::count_if(accepted_.begin(), accepted_.end(),
                         [&](int c) { return !lib_[c].control; });
  };
  while (mechanisms_accepted() < ctx_.settings.max_accepted &&
         static_cast<int>(accepted_.size()) < ctx_.settings.max_accepted + 1 && OnTopRound()) {
  }
  // The cause: the first accepted mechanism; its figures from its first-round fit when it was
  // accepted there, else from its acceptance on top of the candidates before it.
  const auto first =
      std::find_if(accepted_.begin(), accepted_.end(), [&](int c) { return !lib_[c].control; });
  if (first != accepted_.end()) {
    const int c = *first;
    const CandidateResult& cause = (*results_)[c];
    const bool screened = c == accepted_[0] && cause.fitted &&
                          cause.lr_p_adjusted < ctx_.settings.alpha && cause.accepted;
    out.cause = c;
    out.cause_lr_p = screened ? cause.lr_p_adjusted : accept_p_[c];
    out.cause_gain = screened ? cause.heldout_gain : accept_gain_[c];
  }
  FinalRefit();
  out.accepted = accepted_;
  out.params = ParamsOf(accepted_);
  out.fit = current_.stage.fit;
  out.heldout_predictions = current_.stage.heldout_predictions;
  out.heldout_nrmse = current_.heldout_nrmse;
  out.on_top_reference = on_top_reference_;
  return out;
}

}  // namespace

bool HeldoutGainAccepted(double gain, double dm_p_adjusted, const DiagnoseSettings& settings) {
  return (gain > 0.0 && dm_p_adjusted < settings.alpha) || gain > settings.clear_heldout_gain;
}

bool OwnGainAccepted(double own_gain, double dm_p_adjusted, const DiagnoseSettings& settings) {
  if (std::isnan(own_gain)) return true;
  return (own_gain > 0.0 && dm_p_adjusted < settings.alpha) || own_gain > settings.min_heldout_gain;
}

ExtensionOutcome Extend(const StageContext& ctx, const std::vector<Candidate>& library,
                        const CalibrationStage& calibration,
                        const std::vector<ModelParameter>& person, const ScreenStage& screen,
                        std::map<int, Eigen::MatrixXd> baseline_directions, bool reference_gap,
                        std::vector<CandidateResult>* results) {
  Extender e(ctx, library, calibration, person, reference_gap, results);
  return e.Run(screen, std::move(baseline_directions));
}

}  // namespace fesim::diagnosis
