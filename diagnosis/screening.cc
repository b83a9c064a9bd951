#include "diagnosis/screening.h"

#include <algorithm>
#include <cmath>

#include "diagnosis/mechanisms/library.h"
#include "diagnosis/signatures.h"

namespace fesim::diagnosis {
namespace {

Json TestJson(const ScoreTest& t) {
  Json j = Json::Object();
  j.Set("statistic", t.statistic).Set("dof", t.dof).Set("theta", ToJson(t.theta));
  j.Set("variance_inflation", t.variance_inflation);
  return j;
}

}  // namespace

bool DriftOnly(const Candidate& c) {
  return std::all_of(c.params.begin(), c.params.end(), [](const ModelParameter& p) {
    return p.target == ModelParameter::Target::kOutputDrift;
  });
}

bool PerTrialDirections(const Candidate& c, int trials) {
  return (c.free_phase_param >= 0 || c.drift_per_trial) && trials > 1;
}

std::vector<bool> OneSidedColumns(const Candidate& c, Eigen::Index columns) {
  std::vector<bool> out;
  for (Eigen::Index k = 0; k < columns; ++k) {
    out.push_back(c.one_sided[static_cast<std::size_t>(k) % c.one_sided.size()]);
  }
  return out;
}

int ApplicableCount(const std::vector<Candidate>& library) {
  return static_cast<int>(std::count_if(library.begin(), library.end(),
                                        [](const Candidate& c) { return c.applicable; }));
}

double AdjustedChiSquareP(double s, int dof, int m) {
  if (dof < 1) return 1.0;
  return std::min(1.0, m * ChiSquareSurvival(s, dof));
}

void SetScoreTest(const ScoreTest& t, int m, CandidateResult* cr) {
  CandidateResult fresh;
  fresh.id = cr->id;
  fresh.joint = cr->joint;
  fresh.label = cr->label;
  fresh.control = cr->control;
  fresh.applicable = cr->applicable;
  fresh.not_applicable_reason = cr->not_applicable_reason;
  if (t.dof > 0) {
    fresh.score_statistic = t.statistic;
    fresh.dof = t.dof;
    fresh.p_value = ChiSquareSurvival(t.statistic, t.dof);
    fresh.p_adjusted = AdjustedChiSquareP(t.statistic, t.dof, m);
    fresh.score = std::max(0.0, -std::log10(std::max(fresh.p_adjusted, 1e-300)));
    fresh.variance_inflation = t.variance_inflation;
  }
  fresh.decision = t.dof > 0 ? "score test not significant" : "no direction kept (one-sided)";
  const std::size_t split = cr->evidence.find("; ");
  fresh.evidence = Fmt("robust score chi2 %.1f (dof %.0f, p_adj %.2g", fresh.score_statistic,
                       fresh.dof, fresh.p_adjusted) +
                   Fmt(", noise variance x%.1f of white)", fresh.variance_inflation) +
                   (split == std::string::npos ? std::string() : cr->evidence.substr(split));
  *cr = std::move(fresh);
}

std::map<int, Eigen::MatrixXd> ProbeDirections(
    const StageContext& ctx, const std::vector<Candidate>& library,
    const std::vector<ModelParameter>& params, const Eigen::VectorXd& x,
    const std::vector<Trial>& pred, const Eigen::VectorXd& r, const std::vector<int>& cands) {
  const DataView& train = ctx.data.train;
  struct Job {
    int cand, probe, trial;
  };
  std::vector<Job> jobs;
  for (int c : cands) {
    for (std::size_t p = 0; p < library[c].probes.size(); ++p) {
      for (std::size_t t = 0; t < train.trials.size(); ++t) {
        jobs.push_back({c, static_cast<int>(p), static_cast<int>(t)});
      }
    }
  }
  std::vector<Trial> sims(jobs.size());
  std::vector<char> ok(jobs.size(), 1);
  std::vector<std::size_t> simulated;
  for (std::size_t j = 0; j < jobs.size(); ++j) {
    const Candidate& c = library[jobs[j].cand];
    if (!DriftOnly(c)) {
      simulated.push_back(j);
      continue;
    }
    sims[j] = pred[jobs[j].trial];
    AddOutputDrift(c.params, c.probes[jobs[j].probe], &sims[j], jobs[j].trial);
  }
  // Each probe's simulation comes back as JSON text ("" = it failed), so that it can run on
  // another MPI rank.
  const std::vector<std::string> texts = ctx.Map(simulated.size(), [&](std::size_t i) {
    const Job& job = jobs[simulated[i]];
    const Candidate& c = library[job.cand];
    DataView one;
    one.trials = {train.trials[job.trial]};
    one.use = {train.use[job.trial]};
    one.outputs = train.outputs;
    if (static_cast<std::size_t>(job.trial) < train.initial_q.size()) {
      one.initial_q = {train.initial_q[job.trial]};
    }
    try {
      const Trial sim = Predict(ctx.rig, Join(params, c.params), Concat(x, c.probes[job.probe]),
                                one, ctx.fit, 1)[0];
      return TrialsToJson({sim}).Dump(0);
    } catch (const std::exception&) {
      return std::string();
    }
  });
  for (std::size_t i = 0; i < simulated.size(); ++i) {
    const std::size_t j = simulated[i];
    ok[j] = texts[i].empty() ? 0 : 1;
    if (ok[j]) sims[j] = TrialsFromJson(Json::Parse(texts[i], "probe"), "probe")[0];
  }
  *ctx.simulations += static_cast<int>(simulated.size());
  std::map<int, Eigen::MatrixXd> directions;
  std::size_t j = 0;
  for (int c : cands) {
    const int np = static_cast<int>(library[c].probes.size());
    const auto nt = static_cast<int>(train.trials.size());
    const int per_trial = PerTrialDirections(library[c], nt) ? nt : 1;
    Eigen::MatrixXd d = Eigen::MatrixXd::Zero(r.size(), np * per_trial);
    for (int p = 0; p < np; ++p) {
      std::vector<Trial> probe_pred;
      bool all_ok = true;
      for (int t = 0; t < nt; ++t, ++j) {
        probe_pred.push_back(sims[j]);
        all_ok = all_ok && ok[j];
      }
      if (!all_ok) continue;
      if (per_trial == 1) {
        d.col(p) = StackResiduals(train, probe_pred) - r;
        continue;
      }
      for (int t = 0; t < nt; ++t) {  // trial t probed, the others at the point's prediction
        std::vector<Trial> only_t = pred;
        only_t[static_cast<std::size_t>(t)] = probe_pred[static_cast<std::size_t>(t)];
        d.col(t * np + p) = StackResiduals(train, only_t) - r;
      }
    }
    directions[c] = std::move(d);
  }
  return directions;
}

Json ToJson(const ScreenStage& s) {
  Json j = Json::Array();
  for (const auto& t : s.tests) j.Push(TestJson(t));
  return j;
}

void FromJson(const Json& j, ScreenStage* s) {
  s->tests.clear();
  for (const auto& e : j.Items()) {
    ScoreTest t;
    t.statistic = Member(e, "statistic").AsNumber();
    t.dof = static_cast<int>(Member(e, "dof").AsNumber());
    FromJson(Member(e, "theta"), &t.theta);
    t.variance_inflation = Member(e, "variance_inflation").AsNumber();
    s->tests.push_back(t);
  }
}

ScreenStage Screen(const StageContext& ctx, const std::vector<Candidate>& library,
                   const ModelPoint& point, const std::set<std::string>& skip,
                   const std::vector<std::string>& key, const DirectionsProvider& screen_with,
                   std::map<int, Eigen::MatrixXd>* directions) {
  const int m = ApplicableCount(library);
  return ctx.cache.Get<ScreenStage>(key, [&] {
    ScreenStage s;
    s.tests.resize(library.size());
    std::vector<int> probed;
    for (std::size_t c = 0; c < library.size(); ++c) {
      if (!library[c].applicable || skip.count(library[c].id)) continue;
      if (screen_with && !DriftOnly(library[c])) {
        const std::map<int, Eigen::MatrixXd>& earlier = screen_with();
        const auto it = earlier.find(static_cast<int>(c));
        if (it != earlier.end()) {
          const ScoreTest t =
              RobustScoreTest(ctx.train_rows, point.residual, it->second, point.jacobian,
                              OneSidedColumns(library[c], it->second.cols()));
          if (AdjustedChiSquareP(2.0 * t.statistic, std::max(1, t.dof), m) >= ctx.settings.alpha) {
            s.tests[c] = t;
            continue;
          }
        }
      }
      probed.push_back(static_cast<int>(c));
    }
    const std::map<int, Eigen::MatrixXd> d = ProbeDirections(
        ctx, library, point.params, point.x, point.train_predictions, point.residual, probed);
    for (const auto& [c, dc] : d) {
      s.tests[c] = RobustScoreTest(ctx.train_rows, point.residual, dc, point.jacobian,
                                   OneSidedColumns(library[c], dc.cols()));
    }
    if (directions != nullptr) *directions = d;
    return s;
  });
}

}  // namespace fesim::diagnosis
