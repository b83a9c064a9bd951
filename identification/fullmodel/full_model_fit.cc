#include "identification/fullmodel/full_model_fit.h"

#include <time.h>  // NOLINT(modernize-deprecated-headers): POSIX clock_gettime(), not in <ctime>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <stdexcept>
#include <thread>

#include "base/parallel.h"
#include "identification/levenberg_marquardt.h"
#include "identification/method_support.h"
#include "identification/metrics.h"
#include "scenarios/scenario.h"
#include "sim/default_model.h"
#include "sim/integrator.h"
#include "sim/trial_runner.h"
#include "sim/upper_limb_model.h"
#include "tendons/tendon_network.h"

namespace fesim::identification::fullmodel {
namespace {

using Clock = std::chrono::steady_clock;

/// The fits read only the angles of the trial's joints: locked coordinates are welded
/// (sim::ModelBuildOptions::weld_locked): on the hand rig Simbody realises 5 mobilities, not 10.
constexpr sim::ModelBuildOptions kFitBuild{true};

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

/// CPU time of the whole process (all threads), s.
double ProcessCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// The forearm muscles whose A entries, β and γ are candidates ([Hand Hammerstein] §5.1).
const std::vector<std::string>& ForearmMuscles() {
  static const std::vector<std::string> names = {"ECRL", "ECRB", "ECU", "FCR",
                                                 "FCU",  "EDC",  "FDS", "FDP"};
  return names;
}

/// Residual value for a sample whose simulation failed, rad (makes the cost large so LM rejects
/// the step).
constexpr double kFailedResidualRad = 10.0;
/// Smallest effective stimulation change that starts a new schedule breakpoint, µs.
constexpr double kScheduleChangeUs = 1e-9;

int ChannelIndex(const sim::ModelParams& m, const std::string& name) {
  for (std::size_t k = 0; k < m.channels.size(); ++k) {
    if (m.channels[k].name == name) return static_cast<int>(k);
  }
  return -1;
}

int MuscleIndex(const sim::ModelParams& m, const std::string& name) {
  for (std::size_t j = 0; j < m.muscles.size(); ++j) {
    if (m.muscles[j].name == name) return static_cast<int>(j);
  }
  return -1;
}

std::string ChannelList(const sim::ModelParams& m) {
  std::string s;
  for (const auto& c : m.channels) s += (s.empty() ? "" : ", ") + c.name;
  return s;
}

/// What one simulation of a trial needs, prepared once: the recorded stimulation as a
/// zero-order-hold schedule in the model's channel order (a breakpoint wherever some channel
/// changes), the sample times and the coordinates of the trial's q.<joint> columns.
struct SimPlan {
  sim::StimulationSchedule schedule;  // µs per model channel, as recorded (before the delay)
  std::vector<double> times;          // s, the trial's sample times
  std::vector<int> coords;            // sim::Coordinate of each q.<joint> column, in order

  bool operator==(const SimPlan& o) const {
    return schedule.times == o.schedule.times && schedule.values == o.schedule.values &&
           times == o.times && coords == o.coords;
  }
};

SimPlan PlanFor(const sim::ModelParams& model, const Trial& trial) {
  const int nc = static_cast<int>(model.channels.size());
  std::vector<int> channel_of_column;
  const auto inputs = trial.NamesWithPrefix("u.");
  for (const auto& name : inputs) {
    const int k = ChannelIndex(model, name.substr(2));
    if (k < 0) {
      throw std::runtime_error("column " + name + ": no such channel in the rig (" +
                               ChannelList(model) + ")");
    }
    channel_of_column.push_back(k);
  }
  SimPlan plan;
  for (const auto& name : trial.NamesWithPrefix("q.")) {
    const int c = sim::CoordinateIndex(name.substr(2));
    if (c < 0) throw std::runtime_error("column " + name + ": unknown joint");
    plan.coords.push_back(c);
  }
  if (trial.size() < 2) throw std::runtime_error("trial needs at least 2 samples");
  if (trial.time.front() < 0.0) throw std::runtime_error("trial time must start at >= 0 s");
  std::vector<double> previous;
  for (std::size_t i = 0; i < trial.size(); ++i) {
    std::vector<double> u(nc, 0.0);
    for (std::size_t c = 0; c < inputs.size(); ++c) {
      u[channel_of_column[c]] = trial.Column(inputs[c])[i];
    }
    bool changed = previous.empty();
    for (int k = 0; k < nc && !changed; ++k) {
      changed = std::abs(u[k] - previous[k]) > kScheduleChangeUs;
    }
    if (!changed) continue;
    plan.schedule.times.push_back(i == 0 ? 0.0 : trial.time[i]);
    plan.schedule.values.push_back(u);
    previous = u;
  }
  plan.times = trial.time;
  return plan;
}

/// Simulated angles q[column][sample] (rad) of `plan` on `model`: the rig's initial state at
/// t = 0, the schedule delayed by the electromechanical delay (as sim::RunTrial does), CVODES with
/// `integrator`'s settings, q read at exactly the sample times from CVODES' own vector
/// (sim::IntegrateTrialVariables: no state write, kinematics or Stage::Time per sample), without
/// RunTrial's sensor and truth records.
std::vector<std::vector<double>> SimulatePlan(const sim::ModelParams& model, const SimPlan& plan,
                                              const sim::IntegratorParams& integrator) {
  const sim::UpperLimbModel limb(model, kFitBuild);
  const sim::StimulationSchedule delayed = sim::MuscleStimulation(model, plan.schedule);
  SimTK::State state = limb.MakeInitialState();
  std::vector<std::vector<double>> q(plan.coords.size());
  for (auto& column : q) column.reserve(plan.times.size());
  sim::IntegrateTrialVariables(
      limb, integrator, delayed, plan.times, &state,
      [&](double, const double* y) {
        for (std::size_t k = 0; k < plan.coords.size(); ++k) {
          q[k].push_back(limb.GetQ(state, y, plan.coords[k]));
        }
      },
      sim::VariablesObserved::kPositionsAndSpeeds);
  return q;
}

/// SimulatePlan at CVODES tolerance `tolerance`, the other settings at their defaults.
std::vector<std::vector<double>> SimulatePlan(const sim::ModelParams& model, const SimPlan& plan,
                                              double tolerance) {
  sim::IntegratorParams integrator;
  integrator.tolerance = tolerance;
  return SimulatePlan(model, plan, integrator);
}

/// Training data in a form the residual needs: per trial, the q columns and where they are
/// valid, and the distinct simulations (trials with the same stimulation, times and joints — e.g.
/// repeats of one step-grid order — share one simulation, which is deterministic).
struct TrainingData {
  std::vector<std::string> joints;                  // q.<joint> names (same in every trial)
  std::vector<std::vector<std::vector<double>>> y;  // [trial][joint][sample]
  long residuals = 0;
  std::vector<SimPlan> plans;  // distinct simulations
  std::vector<int> plan_of;    // [trial] → index in plans
  /// [trial][joint][sample] → the sample's row in the residual vector (FillResiduals' order), or
  /// −1 for a NaN sample.
  std::vector<std::vector<std::vector<long>>> row_of;
};

void CheckTrials(const sim::ModelParams& rig, const std::vector<Trial>& trials,
                 const std::string& what, const std::vector<std::string>& joints) {
  for (std::size_t t = 0; t < trials.size(); ++t) {
    const std::string label = what + " trial " + std::to_string(t);
    const Trial& tr = trials[t];
    RequireSamples(tr, 10, label, "a simulated fit");
    const auto inputs = tr.NamesWithPrefix("u.");
    if (inputs.empty()) throw std::runtime_error(label + ": no u.* input column");
    for (const auto& name : inputs) {
      if (ChannelIndex(rig, name.substr(2)) < 0) {
        throw std::runtime_error(label + ": column " + name + ": no such channel in the rig (" +
                                 ChannelList(rig) + ")");
      }
    }
    RequireColumns(tr, inputs, label);  // NaN / inf in the input are an error
    for (const auto& name : inputs) {
      for (double v : tr.Column(name)) {
        if (v < 0.0 || v > 300.0) {
          throw std::runtime_error(label + ": column " + name + ": pulse width " + Num(v) +
                                   " us outside [0, 300]");
        }
      }
    }
    if (tr.time.front() < 0.0) throw std::runtime_error(label + ": time must start at >= 0 s");
    for (const auto& j : joints) {
      if (!tr.Has(j)) throw std::runtime_error(label + ": missing column " + j);
      int valid = 0;
      for (double v : tr.Column(j)) {
        if (std::isinf(v)) throw std::runtime_error(label + ": column " + j + ": inf value");
        valid += std::isnan(v) ? 0 : 1;
      }
      if (valid < 2) throw std::runtime_error(label + ": column " + j + ": fewer than 2 samples");
    }
  }
}

TrainingData ReadTraining(const sim::ModelParams& rig, const std::vector<Trial>& train) {
  if (train.empty()) throw std::runtime_error("--train: no trials");
  TrainingData d;
  d.joints = train[0].NamesWithPrefix("q.");
  if (d.joints.empty()) throw std::runtime_error("train trial 0: no q.* output column");
  for (const auto& j : d.joints) {
    const int c = sim::CoordinateIndex(j.substr(2));
    if (c < 0) throw std::runtime_error("train trial 0: column " + j + ": unknown joint");
    if (rig.coordinates[c].mode != sim::CoordinateMode::kFree) {
      throw std::runtime_error("train trial 0: column " + j +
                               ": joint is not free in the rig (locked or prescribed)");
    }
  }
  CheckTrials(rig, train, "train", d.joints);
  long row = 0;
  for (const auto& tr : train) {
    std::vector<std::vector<double>> cols;
    for (const auto& j : d.joints) {
      cols.push_back(tr.Column(j));
      for (double v : cols.back()) d.residuals += std::isnan(v) ? 0 : 1;
    }
    d.y.push_back(std::move(cols));
    std::vector<std::vector<long>> rows;
    for (const auto& column : d.y.back()) {
      rows.emplace_back(column.size(), -1);
      for (std::size_t i = 0; i < column.size(); ++i) {
        if (!std::isnan(column[i])) rows.back()[i] = row++;
      }
    }
    d.row_of.push_back(std::move(rows));
    SimPlan plan = PlanFor(rig, tr);
    const auto same = std::find(d.plans.begin(), d.plans.end(), plan);
    d.plan_of.push_back(static_cast<int>(same - d.plans.begin()));
    if (same == d.plans.end()) d.plans.push_back(std::move(plan));
  }
  return d;
}

/// Appends y − ŷ of every training trial to r at k (NaN samples skipped); `sims[plan]` the
/// simulated columns of each distinct plan, or nullptr where its simulation failed.
void FillResiduals(const TrainingData& data,
                   const std::vector<const std::vector<std::vector<double>>*>& sims,
                   Eigen::VectorXd* r) {
  Eigen::Index k = 0;
  for (std::size_t t = 0; t < data.y.size(); ++t) {
    const auto* yh = sims[static_cast<std::size_t>(data.plan_of[t])];
    for (std::size_t j = 0; j < data.joints.size(); ++j) {
      const auto& y = data.y[t][j];
      for (std::size_t i = 0; i < y.size(); ++i) {
        if (std::isnan(y[i])) continue;
        (*r)(k++) = yh ? y[i] - (*yh)[j][i] : kFailedResidualRad;
      }
    }
  }
}

/// Residuals y − ŷ of all training trials for one parameter vector (NaN samples skipped).
/// `threads` workers share the distinct simulations.
Eigen::VectorXd Residuals(const sim::ModelParams& base, const std::vector<FitParameter>& params,
                          const Eigen::VectorXd& x, const TrainingData& data, double tolerance,
                          int threads, bool throw_on_failure) {
  const sim::ModelParams model = ApplyParameters(base, params, x);
  const int np = static_cast<int>(data.plans.size());
  std::vector<std::vector<std::vector<double>>> sims(np);
  std::vector<char> ok(np, 1);
  ParallelFor(np, threads, [&](int t) {
    try {
      sims[t] = SimulatePlan(model, data.plans[t], tolerance);
    } catch (const std::exception&) {
      if (throw_on_failure) throw;
      ok[t] = 0;
    }
  });
  std::vector<const std::vector<std::vector<double>>*> views(np);
  for (int t = 0; t < np; ++t) views[t] = ok[t] ? &sims[t] : nullptr;
  Eigen::VectorXd r(data.residuals);
  FillResiduals(data, views, &r);
  return r;
}

/// Forward-difference Jacobian ∂r/∂x = −∂ŷ/∂x, one model + simulation per (column, distinct
/// simulation), all on `threads` workers. A column whose perturbed simulation fails is zero.
Eigen::MatrixXd ParallelJacobian(const sim::ModelParams& base,
                                 const std::vector<FitParameter>& params, const Eigen::VectorXd& x,
                                 const Eigen::VectorXd& r0, const Eigen::VectorXd& upper,
                                 const TrainingData& data, double tolerance, double rel_step,
                                 int threads, const std::function<void(double)>& progress = {}) {
  const int p = static_cast<int>(x.size());
  const int nt = static_cast<int>(data.plans.size());
  std::vector<double> h(p);
  std::vector<sim::ModelParams> models;
  models.reserve(p);
  for (int c = 0; c < p; ++c) {
    double step = rel_step * std::max(std::abs(x(c)), 1e-3);
    if (x(c) + step > upper(c)) step = -step;  // stay inside the bounds
    h[c] = step;
    Eigen::VectorXd xp = x;
    xp(c) += step;
    models.push_back(ApplyParameters(base, params, xp));
  }
  std::vector<std::vector<std::vector<double>>> sims(static_cast<std::size_t>(p) * nt);
  std::vector<char> ok(sims.size(), 1);
  std::mutex progress_mutex;
  int done = 0;
  ParallelFor(sims.size(), threads, [&](int task) {
    const int c = task / nt, t = task % nt;
    try {
      sims[task] = SimulatePlan(models[c], data.plans[t], tolerance);
    } catch (const std::exception&) {
      ok[task] = 0;
    }
    if (progress) {
      std::lock_guard<std::mutex> lock(progress_mutex);
      progress(static_cast<double>(++done) / (p * nt));
    }
  });
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(r0.size(), p);
  Eigen::VectorXd r(r0.size());
  for (int c = 0; c < p; ++c) {
    bool column_ok = true;
    std::vector<const std::vector<std::vector<double>>*> views(nt);
    for (int t = 0; t < nt; ++t) {
      column_ok = column_ok && ok[c * nt + t];
      views[t] = &sims[c * nt + t];
    }
    if (!column_ok) continue;
    FillResiduals(data, views, &r);
    J.col(c) = (r - r0) / h[c];
  }
  return J;
}

/// ∂q̂/∂x of `plan` on `model` by CVODES forward sensitivities (same set-up as SimulatePlan):
/// `row(i, dq)` at each sample i with dq[coordinate · P + k] (sim::SensitivityObserver).
void PlanSensitivities(const sim::ModelParams& model,
                       const std::vector<sim::ParameterPerturbation>& perturbed,
                       const SimPlan& plan, double tolerance,
                       const std::function<void(std::size_t, const std::vector<double>&)>& row) {
  const sim::UpperLimbModel limb(model, kFitBuild);
  const sim::StimulationSchedule delayed = sim::MuscleStimulation(model, plan.schedule);
  sim::IntegratorParams integrator;
  integrator.tolerance = tolerance;
  integrator.sensitivities_per_step = true;  // 40 Hz reports, fewer steps
  SimTK::State state = limb.MakeInitialState();
  std::size_t i = 0;
  sim::IntegrateTrialSensitivities(
      limb, integrator, delayed, plan.times, perturbed, &state,
      [&](double, const double*, const std::vector<double>& dq) { row(i++, dq); });
}

/// The perturbed models of the sensitivity Jacobian at x: the perturbed models only feed
/// difference quotients of pure functions (recruitment, muscle and joint torques), so their step
/// is small (1e-7 relative) and the Jacobian is exact to the integrator's tolerance.
std::vector<sim::ParameterPerturbation> SensitivityPerturbations(
    const sim::ModelParams& base, const std::vector<FitParameter>& params, const Eigen::VectorXd& x,
    const Eigen::VectorXd& upper) {
  std::vector<sim::ParameterPerturbation> perturbed;
  perturbed.reserve(x.size());
  for (Eigen::Index c = 0; c < x.size(); ++c) {
    const double scale = std::max(std::abs(x(c)), 1e-3);
    double step = 1e-7 * scale;
    if (x(c) + step > upper(c)) step = -step;
    Eigen::VectorXd xp = x;
    xp(c) += step;
    perturbed.push_back({ApplyParameters(base, params, xp), step, scale});
  }
  return perturbed;
}

/// Jacobian ∂r/∂x = −∂ŷ/∂x from forward sensitivities (sim::IntegrateTrialSensitivities): one
/// augmented simulation per distinct simulation, on `threads` workers, instead of one perturbed
/// simulation per (parameter, distinct simulation). Throws std::runtime_error (or
/// std::invalid_argument for a rig it cannot differentiate).
Eigen::MatrixXd SensitivityJacobian(const sim::ModelParams& base,
                                    const std::vector<FitParameter>& params,
                                    const Eigen::VectorXd& x, const Eigen::VectorXd& upper,
                                    const TrainingData& data, double tolerance, int threads) {
  const int p = static_cast<int>(x.size());
  const sim::ModelParams model = ApplyParameters(base, params, x);
  const auto perturbed = SensitivityPerturbations(base, params, x, upper);
  const int nt = static_cast<int>(data.plans.size());
  std::vector<std::vector<std::vector<double>>> dq(nt);
  ParallelFor(nt, threads, [&](int t) {
    const SimPlan& plan = data.plans[t];
    dq[t].resize(plan.times.size());
    PlanSensitivities(model, perturbed, plan, tolerance,
                      [&](std::size_t i, const std::vector<double>& d) {
                        auto& out = dq[t][i];
                        out.resize(plan.coords.size() * p);
                        for (std::size_t j = 0; j < plan.coords.size(); ++j) {
                          std::copy_n(d.begin() + plan.coords[j] * p, p, out.begin() + j * p);
                        }
                      });
  });
  Eigen::MatrixXd J(data.residuals, p);
  for (std::size_t t = 0; t < data.y.size(); ++t) {
    const auto& d = dq[static_cast<std::size_t>(data.plan_of[t])];
    for (std::size_t j = 0; j < data.joints.size(); ++j) {
      const auto& rows = data.row_of[t][j];
      for (std::size_t i = 0; i < rows.size(); ++i) {
        if (rows[i] < 0) continue;
        for (int k = 0; k < p; ++k) J(rows[i], k) = -d[i][j * p + k];
      }
    }
  }
  return J;
}

/// Rows per rank update of SensitivityNormalEquations (≈ 60 KB of 29 parameters: L2-resident).
constexpr int kNormalEquationsBlock = 256;

/// JᵀJ and Jᵀr of SensitivityJacobian's J without forming it: each worker accumulates its
/// distinct simulation's rows (weighted by the training trials that share it) as they come,
/// in blocks of kNormalEquationsBlock rows (a rank-k update of the lower triangle); the parts are
/// summed in plan order, so the result does not depend on `threads`. No J matrix (≈ 12 MB on the
/// hand-array data, first-touched every iteration), no serial assembly and Gram between the
/// parallel simulations (docs/performance.md "Full-model fit local step").
void SensitivityNormalEquations(const sim::ModelParams& base,
                                const std::vector<FitParameter>& params, const Eigen::VectorXd& x,
                                const Eigen::VectorXd& upper, const TrainingData& data,
                                double tolerance, int threads, const Eigen::VectorXd& r,
                                Eigen::MatrixXd* jtj, Eigen::VectorXd* jtr) {
  const int p = static_cast<int>(x.size());
  const sim::ModelParams model = ApplyParameters(base, params, x);
  const auto perturbed = SensitivityPerturbations(base, params, x, upper);
  const int nt = static_cast<int>(data.plans.size());
  std::vector<Eigen::MatrixXd> gram(nt, Eigen::MatrixXd::Zero(p, p));
  std::vector<Eigen::VectorXd> gradient(nt, Eigen::VectorXd::Zero(p));
  ParallelFor(nt, threads, [&](int t) {
    const SimPlan& plan = data.plans[t];
    std::vector<std::size_t> trials;  // the training trials simulated by plan t
    for (std::size_t s = 0; s < data.plan_of.size(); ++s) {
      if (data.plan_of[s] == t) trials.push_back(s);
    }
    Eigen::MatrixXd block(p, kNormalEquationsBlock);  // columns: ∂ŷ/∂x of one residual each
    Eigen::VectorXd residual(kNormalEquationsBlock);
    int filled = 0;
    const auto flush = [&] {
      const auto rows = block.leftCols(filled);
      gram[t].selfadjointView<Eigen::Lower>().rankUpdate(rows);
      gradient[t].noalias() -= rows * residual.head(filled);  // J = −∂ŷ/∂x
      filled = 0;
    };
    // A sample's row of ∂ŷ/∂x is the same in every trial of the plan: it enters once, times
    // √w for the w trials where the sample is valid, with their residuals' sum over √w.
    PlanSensitivities(
        model, perturbed, plan, tolerance, [&](std::size_t i, const std::vector<double>& d) {
          for (std::size_t j = 0; j < plan.coords.size(); ++j) {
            int valid = 0;
            double sum = 0.0;
            for (std::size_t s : trials) {
              const long row = data.row_of[s][j][i];
              if (row < 0) continue;
              ++valid;
              sum += r(row);
            }
            if (valid == 0) continue;
            const double root = valid == 1 ? 1.0 : std::sqrt(static_cast<double>(valid));
            auto column = block.col(filled);
            for (int k = 0; k < p; ++k) column(k) = root * d[plan.coords[j] * p + k];
            residual(filled) = sum / root;
            if (++filled == kNormalEquationsBlock) flush();
          }
        });
    flush();
  });
  *jtj = Eigen::MatrixXd::Zero(p, p);
  *jtr = Eigen::VectorXd::Zero(p);
  for (int t = 0; t < nt; ++t) {
    *jtj += gram[t];
    *jtr += gradient[t];
  }
  *jtj = jtj->selfadjointView<Eigen::Lower>();
}

/// Cost of one augmented (sensitivity) simulation in plain simulations, as the kAuto rule counts
/// it: 361 / 99.6 ms CPU on the hand-array step grid when the rule was set. Now 168 / 110 ms
/// (BM_SensitivityDataSet/29/2/16 against BM_SimulateDataSet/4, docs/performance.md "Full-model
/// fit local step") for the iterations and one 355 ms Jacobian for the intervals per fit; the
/// rule is kept (forward differences for ≤ 3 parameters: at most three simulations per Jacobian,
/// spread over the threads), so fits with few parameters give the same figures as before.
constexpr double kAugmentedSimulationCost = 3.6;

/// Tolerance multiple of the sensitivity Jacobian that gives the confidence intervals' JᵀJ: within
/// 0.2 % (whole Jacobian, relative RMS; worst column 1.5 %) of the exact one on the hand-array
/// step grid (bench/fullmodel_bench.cc BM_SensitivityDataSet/29/3/16), where the iterations'
/// (jacobian_tolerance_factor 100) are within 9 % (worst column 31 %).
constexpr double kConfidenceJacobianToleranceFactor = 10.0;
/// The coarsest integrator tolerance of a sensitivity Jacobian (9 % from the exact one on the
/// hand-array step grid; it is not known to stay useful beyond).
constexpr double kCoarsestJacobianTolerance = 1e-2;

/// Whether `method` means sensitivities for `p` parameters (kAuto: when p perturbed simulations
/// cost more than one augmented one). Deliberately independent of the thread count, so a fit
/// gives the same figures however it is run (one process, any number of MPI ranks).
bool UseSensitivities(JacobianMethod method, int p) {
  if (method != JacobianMethod::kAuto) return method == JacobianMethod::kSensitivities;
  return kAugmentedSimulationCost < p;
}

/// What a Jacobian of the fit's residuals needs besides the point: the fit's options, the model
/// the parameters apply to, the parameters and their upper bounds, the training data, the
/// integrator tolerance of the residuals and the worker threads.
struct JacobianRequest {
  const FullModelFitOptions& options;
  const sim::ModelParams& base;
  const std::vector<FitParameter>& params;
  const Eigen::VectorXd& upper;
  const TrainingData& data;
  double tolerance;
  int threads;
};

/// The integrator tolerance of the sensitivity Jacobians: the residuals' times
/// jacobian_tolerance_factor, never coarser than kCoarsestJacobianTolerance (unless the residuals
/// are).
double JacobianTolerance(const JacobianRequest& req) {
  return std::max(req.tolerance, std::min(req.tolerance * req.options.jacobian_tolerance_factor,
                                          kCoarsestJacobianTolerance));
}

/// The forward-difference Jacobian of the request at x (residuals r0 there); adds its p
/// simulation sets to *evaluations.
Eigen::MatrixXd ForwardDifferenceJacobian(const JacobianRequest& req, const Eigen::VectorXd& x,
                                          const Eigen::VectorXd& r0, int* evaluations,
                                          const std::function<void(double)>& progress) {
  *evaluations += static_cast<int>(x.size());
  return ParallelJacobian(req.base, req.params, x, r0, req.upper, req.data, req.tolerance,
                          req.options.fd_relative_step, req.threads, progress);
}

/// ∂r/∂x at x (residuals r0 there) by `options.jacobian` (UseSensitivities), by forward
/// differences when a sensitivity integration fails or the rig has states sensitivities cannot
/// differentiate (the stretch reflex). Adds the simulation sets it used to *evaluations (1
/// augmented, or one per parameter); `progress` gets the forward differences' fraction done.
Eigen::MatrixXd FitJacobian(const JacobianRequest& req, const Eigen::VectorXd& x,
                            const Eigen::VectorXd& r0, int* evaluations,
                            const std::function<void(double)>& progress) {
  if (UseSensitivities(req.options.jacobian, static_cast<int>(x.size()))) {
    try {
      Eigen::MatrixXd J = SensitivityJacobian(req.base, req.params, x, req.upper, req.data,
                                              JacobianTolerance(req), req.threads);
      ++*evaluations;
      return J;
    } catch (const std::exception&) {
      // Forward differences below; their failed columns are zero.
    }
  }
  return ForwardDifferenceJacobian(req, x, r0, evaluations, progress);
}

/// JᵀJ and Jᵀr of FitJacobian's J at x (residuals r0 there): from SensitivityNormalEquations
/// when sensitivities apply (UseSensitivities), else (or when they fail) from the
/// forward-difference J's column Gram, as the Levenberg–Marquardt iteration forms it.
void FitNormalEquations(const JacobianRequest& req, const Eigen::VectorXd& x,
                        const Eigen::VectorXd& r0, int* evaluations,
                        const std::function<void(double)>& progress, Eigen::MatrixXd* jtj,
                        Eigen::VectorXd* jtr) {
  if (UseSensitivities(req.options.jacobian, static_cast<int>(x.size()))) {
    try {
      SensitivityNormalEquations(req.base, req.params, x, req.upper, req.data,
                                 JacobianTolerance(req), req.threads, r0, jtj, jtr);
      ++*evaluations;
      return;
    } catch (const std::exception&) {
      // Forward differences below.
    }
  }
  const Eigen::MatrixXd J = ForwardDifferenceJacobian(req, x, r0, evaluations, progress);
  *jtj = JacobianGram(J);
  *jtr = J.transpose() * r0;
}

int ResolveThreads(int threads) {
  if (threads > 0) return threads;
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

double ScaleOf(const FitParameter& p) {
  return p.nominal != 0.0 ? std::abs(p.nominal) : 0.5 * (p.upper - p.lower);
}

}  // namespace

sim::ModelParams WithExplicitArrayWeights(const sim::ModelParams& base) {
  sim::ModelParams m = base;
  const muscles::ArrayMatrix a = sim::BuildElectrodeMatrix(base);
  for (std::size_t k = 0; k < m.channels.size(); ++k) {
    auto& ch = m.channels[k];
    if (ch.pads.empty()) continue;
    ch.pads.clear();
    ch.muscle_weights.clear();
    for (std::size_t j = 0; j < m.muscles.size(); ++j) {
      const double w = a(static_cast<int>(j), static_cast<int>(k));
      if (w != 0.0) ch.muscle_weights.emplace_back(m.muscles[j].name, w);
    }
  }
  return m;
}

std::vector<FitParameter> CandidateParameters(const sim::ModelParams& base,
                                              const std::vector<std::string>& channels) {
  std::vector<FitParameter> out;
  const muscles::ArrayMatrix a = sim::BuildElectrodeMatrix(base);
  std::vector<int> forearm;
  for (const auto& name : ForearmMuscles()) {
    const int j = MuscleIndex(base, name);
    if (j >= 0) forearm.push_back(j);
  }
  for (const auto& ch : channels) {
    const int k = ChannelIndex(base, ch);
    if (k < 0) {
      throw std::invalid_argument("channel '" + ch + "' is not in the rig (" + ChannelList(base) +
                                  ")");
    }
    if (base.channels[k].pads.empty()) continue;  // an electrode pair, not the array
    for (int j : forearm) {
      FitParameter p;
      p.name = "A." + ch + "." + base.muscles[j].name;
      p.unit = "1";
      p.kind = FitParameterKind::kArrayWeight;
      p.channel = k;
      p.muscle = j;
      p.nominal = a(j, k);
      p.lower = 0.0;
      p.upper = 1.0;
      out.push_back(p);
    }
  }
  for (int c = 0; c < sim::kNumCoordinates; ++c) {
    const auto& coord = base.coordinates[c];
    if (coord.mode != sim::CoordinateMode::kFree) continue;
    FitParameter p;
    p.name = "k." + sim::CoordinateNames()[c];
    p.unit = "N*m/rad";
    p.kind = FitParameterKind::kJointStiffness;
    p.coordinate = c;
    p.nominal = coord.passive.stiffness_nm_per_rad;
    if (!(p.nominal > 0.0)) continue;  // a joint without a spring stays without one
    p.lower = 0.2 * p.nominal;
    p.upper = 5.0 * p.nominal;
    out.push_back(p);
  }
  for (int j : forearm) {
    const auto& rec = base.muscles[j].recruitment;
    FitParameter b;
    b.name = "beta." + base.muscles[j].name;
    b.unit = "1/us";
    b.kind = FitParameterKind::kRecruitmentBeta;
    b.muscle = j;
    b.nominal = rec.beta_per_us;
    b.lower = 0.3 * b.nominal;
    b.upper = 3.0 * b.nominal;
    out.push_back(b);
    FitParameter g = b;
    g.name = "gamma." + base.muscles[j].name;
    g.unit = "1";
    g.kind = FitParameterKind::kRecruitmentGamma;
    g.nominal = rec.gamma;
    g.lower = 0.2 * g.nominal;
    g.upper = 5.0 * g.nominal;
    out.push_back(g);
  }
  if (base.coordinates[sim::kWristFlexion].mode == sim::CoordinateMode::kFree) {
    for (bool ext : {true, false}) {
      FitParameter p;
      p.name = ext ? "R.wrist_extensor_scale" : "R.wrist_flexor_scale";
      p.unit = "1";
      p.kind = FitParameterKind::kMomentArmScale;
      p.extensors = ext;
      p.nominal = 1.0;
      p.lower = 0.5;
      p.upper = 2.0;
      out.push_back(p);
    }
  }
  return out;
}

sim::ModelParams ApplyParameters(const sim::ModelParams& base,
                                 const std::vector<FitParameter>& parameters,
                                 const Eigen::VectorXd& values) {
  if (static_cast<std::size_t>(values.size()) != parameters.size()) {
    throw std::invalid_argument("ApplyParameters: " + std::to_string(values.size()) +
                                " values for " + std::to_string(parameters.size()) + " parameters");
  }
  sim::ModelParams m = base;
  std::vector<double> rest(sim::kNumCoordinates);
  for (int c = 0; c < sim::kNumCoordinates; ++c) {
    rest[c] = base.coordinates[c].passive.rest_angle_rad;
  }
  for (std::size_t i = 0; i < parameters.size(); ++i) {
    const FitParameter& p = parameters[i];
    const double v = values(static_cast<Eigen::Index>(i));
    switch (p.kind) {
      case FitParameterKind::kArrayWeight: {
        auto& ch = m.channels[p.channel];
        if (!ch.pads.empty()) {
          throw std::invalid_argument("ApplyParameters: channel '" + ch.name +
                                      "' uses pads; call WithExplicitArrayWeights first");
        }
        const std::string& muscle = m.muscles[p.muscle].name;
        bool found = false;
        for (auto& w : ch.muscle_weights) {
          if (w.first == muscle) {
            w.second = v;
            found = true;
          }
        }
        if (!found) ch.muscle_weights.emplace_back(muscle, v);
        break;
      }
      case FitParameterKind::kJointStiffness:
        m.coordinates[p.coordinate].passive.stiffness_nm_per_rad = v;
        break;
      case FitParameterKind::kRecruitmentBeta:
        m.muscles[p.muscle].recruitment.beta_per_us = v;
        break;
      case FitParameterKind::kRecruitmentGamma:
        m.muscles[p.muscle].recruitment.gamma = v;
        break;
      case FitParameterKind::kMomentArmScale:
        for (auto& muscle : m.muscles) {
          bool scaled = false;
          for (auto& cr : muscle.path.crossings) {
            if (cr.joint != sim::kWristFlexion) continue;
            if ((cr.arm.d_m < 0.0) != p.extensors || cr.arm.d_m == 0.0) continue;
            cr.arm.d_m *= v;
            cr.arm.d_tilde_m *= v;
            scaled = true;
          }
          if (!scaled) continue;
          // Keep l_MT at the rest posture (eq. 8: l_MT = l_ref + Σ Δl): move l_ref by the change
          // of the wrist term.
          const sim::MuscleParams* original = nullptr;
          for (const auto& b : base.muscles) {
            if (b.name == muscle.name) original = &b;
          }
          const double before = tendons::MusculotendonLength(original->path, rest);
          const double after = tendons::MusculotendonLength(muscle.path, rest);
          muscle.path.length_at_ref_m += before - after;
        }
        break;
    }
  }
  return m;
}

sim::ModelParams DefaultHandRig() {
  sim::ModelParams m = sim::DefaultModelParams();
  for (int c : {sim::kShoulderElvPlane, sim::kShoulderElevation, sim::kShoulderRotation,
                sim::kElbowFlexion, sim::kProSup}) {
    m.coordinates[c].mode = sim::CoordinateMode::kLocked;
    m.coordinates[c].initial_speed_rad_s = 0.0;
  }
  return m;
}

Trial SimulateLike(const sim::ModelParams& model, const Trial& trial, double integrator_tolerance) {
  sim::IntegratorParams integrator;
  integrator.tolerance = integrator_tolerance;
  return SimulateLike(model, trial, integrator);
}

Trial SimulateLike(const sim::ModelParams& model, const Trial& trial,
                   const sim::IntegratorParams& integrator) {
  const SimPlan plan = PlanFor(model, trial);
  std::vector<std::vector<double>> q = SimulatePlan(model, plan, integrator);
  Trial out;
  out.time = trial.time;
  for (const auto& name : trial.NamesWithPrefix("u.")) out.AddColumn(name, trial.Column(name));
  for (std::size_t k = 0; k < plan.coords.size(); ++k) {
    out.AddColumn("q." + sim::CoordinateNames()[plan.coords[k]], std::move(q[k]));
  }
  return out;
}

SimulationSensitivities SimulateLikeSensitivities(
    const sim::ModelParams& model, const Trial& trial,
    const std::vector<sim::ParameterPerturbation>& perturbed,
    const sim::IntegratorParams& integrator) {
  const SimPlan plan = PlanFor(model, trial);
  const sim::UpperLimbModel limb(model, kFitBuild);
  const sim::StimulationSchedule delayed = sim::MuscleStimulation(model, plan.schedule);
  SimTK::State state = limb.MakeInitialState();
  const std::size_t p = perturbed.size(), nq = plan.coords.size();
  std::vector<std::vector<double>> q(nq);
  SimulationSensitivities out;
  out.dq_dtheta.assign(nq, Eigen::MatrixXd(plan.times.size(), p));
  Eigen::Index row = 0;
  sim::IntegrateTrialSensitivities(limb, integrator, delayed, plan.times, perturbed, &state,
                                   [&](double, const double* y, const std::vector<double>& dq) {
                                     const std::vector<double> qs = limb.GetQs(state, y);
                                     for (std::size_t j = 0; j < nq; ++j) {
                                       q[j].push_back(qs[plan.coords[j]]);
                                       for (std::size_t k = 0; k < p; ++k) {
                                         out.dq_dtheta[j](row, static_cast<Eigen::Index>(k)) =
                                             dq[plan.coords[j] * p + k];
                                       }
                                     }
                                     ++row;
                                   });
  out.trial.time = trial.time;
  for (const auto& name : trial.NamesWithPrefix("u.")) {
    out.trial.AddColumn(name, trial.Column(name));
  }
  for (std::size_t j = 0; j < nq; ++j) {
    out.trial.AddColumn("q." + sim::CoordinateNames()[plan.coords[j]], std::move(q[j]));
  }
  return out;
}

namespace {

void CheckFitOptions(const FullModelFitOptions& options) {
  if (options.keep_parameters < 1) throw std::invalid_argument("keep_parameters must be >= 1");
  if (options.starts < 1) throw std::invalid_argument("starts must be >= 1");
  if (!(options.jacobian_tolerance_factor >= 1.0)) {
    throw std::invalid_argument("jacobian_tolerance_factor must be >= 1");
  }
}

/// The channels some training trial stimulates (a u.* column), in the model's order.
std::vector<std::string> StimulatedChannels(const sim::ModelParams& rig,
                                            const std::vector<Trial>& train) {
  std::set<std::string> stimulated;
  for (const auto& tr : train) {
    for (const auto& name : tr.NamesWithPrefix("u.")) stimulated.insert(name.substr(2));
  }
  std::vector<std::string> channels;
  for (const auto& ch : rig.channels) {
    if (stimulated.count(ch.name)) channels.push_back(ch.name);
  }
  return channels;
}

/// The candidates' sensitivities s_i = ‖∂r/∂x_i‖ · scale_i / √N at the nominal point and their
/// order (most influential first); all zero when not ranked.
struct Ranking {
  std::vector<int> order;
  std::vector<double> s;
};

/// 1. Sensitivity ranking at the nominal point (one forward difference per candidate, parallel).
/// Sets fit->ranking and fit->sensitivity_wall_s.
Ranking RankCandidates(const FullModelFitOptions& options, const sim::ModelParams& base,
                       const TrainingData& data, double tol, int threads,
                       const ProgressFn& progress, FullModelFit* fit) {
  const int nc = static_cast<int>(fit->candidates.size());
  Ranking ranking{std::vector<int>(nc), std::vector<double>(nc)};
  if (progress) progress(0.0, "sensitivity ranking of " + std::to_string(nc) + " parameters");
  const auto t_sens = Clock::now();
  Eigen::VectorXd x_nom(nc), upper_all(nc);
  for (int i = 0; i < nc; ++i) {
    x_nom(i) = fit->candidates[i].nominal;
    upper_all(i) = fit->candidates[i].upper;
  }
  const Eigen::VectorXd r_nom = Residuals(base, fit->candidates, x_nom, data, tol, threads, true);
  const std::string sens_label = "sensitivity ranking of " + std::to_string(nc) + " parameters";
  int ranking_simulations = 0;
  const JacobianRequest request{options, base, fit->candidates, upper_all, data, tol, threads};
  const Eigen::MatrixXd J_nom =
      FitJacobian(request, x_nom, r_nom, &ranking_simulations, [&](double f) {
        if (progress) progress(0.1 * f, sens_label);
      });
  const double sqrt_n = std::sqrt(static_cast<double>(std::max<long>(1, data.residuals)));
  std::vector<int>& order = ranking.order;
  std::vector<double>& s = ranking.s;
  for (int i = 0; i < nc; ++i) {
    order[i] = i;
    s[i] = J_nom.col(i).norm() * ScaleOf(fit->candidates[i]) / sqrt_n;
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return s[a] > s[b]; });
  for (int i : order) fit->ranking.push_back({fit->candidates[i].name, s[i]});
  fit->sensitivity_wall_s = Seconds(t_sens);
  return ranking;
}

/// 2. The kept subset: the named parameters, else the K best ranked with a non-zero sensitivity.
std::vector<int> KeptIndices(const FullModelFitOptions& options,
                             const std::vector<FitParameter>& candidates, const Ranking& ranking) {
  const int nc = static_cast<int>(candidates.size());
  std::vector<int> kept_index;
  if (!options.fit_names.empty()) {
    for (const auto& name : options.fit_names) {
      int found = -1;
      for (int i = 0; i < nc; ++i) {
        if (candidates[i].name == name) found = i;
      }
      if (found < 0) throw std::invalid_argument("full-model: unknown parameter '" + name + "'");
      kept_index.push_back(found);
    }
  } else {
    const int keep = std::min(options.keep_parameters, nc);
    for (int r = 0; r < keep; ++r) {
      if (ranking.s[ranking.order[r]] > 0.0) kept_index.push_back(ranking.order[r]);
    }
    if (kept_index.empty()) {
      throw std::runtime_error(
          "full-model: the outputs do not depend on any candidate parameter "
          "(no stimulation in the data?)");
    }
  }
  return kept_index;
}

/// The Levenberg–Marquardt options of the local runs.
LmOptions LocalRunOptions(const FullModelFitOptions& options) {
  LmOptions lm;
  lm.max_iterations = options.max_iterations;
  lm.relative_tolerance = options.relative_tolerance;
  lm.step_tolerance = 1e-9;
  lm.fd_relative_step = options.fd_relative_step;
  lm.broyden = options.broyden;
  // Plain path only (docs/performance.md "Full-model fit local step"): with secant updates the
  // smaller start damping made `fesim benchmark --quick`'s capped fit cycle through rejected
  // secant steps.
  lm.hold_active_bounds = !options.broyden;  // bounded A, k, β, γ, R: no crawl along a bound
  lm.scale_free_damping = !options.broyden;  // no run of short gradient steps at the start
  // One rejected trial per iteration otherwise (docs/performance.md "Full-model fit local
  // step"): a residual evaluation costs 0.3–0.4 of a sensitivity Jacobian.
  lm.gain_ratio_damping = !options.broyden;
  // The iterations' Jacobians are coarse (jacobian_tolerance_factor): no stop on one poor step.
  lm.stop_needs_predicted_decrease = true;
  return lm;
}

/// 3. Multi-start local optimisation of the kept parameters (request.params) between `lower`
/// and request.upper: start 1 at `nominal`, the others spread around it. Appends every run to
/// fit->runs, sets fit->best_run and returns the best run's result.
LmResult MultiStart(const FullModelFitOptions& options, const JacobianRequest& request,
                    const Eigen::VectorXd& lower, const Eigen::VectorXd& nominal,
                    const ProgressFn& progress, FullModelFit* fit) {
  const int p = static_cast<int>(nominal.size());
  const Eigen::VectorXd& upper = request.upper;
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const ResidualFn residual = [&](const Eigen::VectorXd& x) {
    return Residuals(request.base, request.params, x, request.data, request.tolerance,
                     request.threads, false);
  };
  int current_start = 0, jacobians = 0;
  const auto jacobian_progress = [&] {
    ++jacobians;
    const std::string label = "start " + std::to_string(current_start + 1) + "/" +
                              std::to_string(options.starts) + ", Jacobian " +
                              std::to_string(jacobians);
    return [&, label](double f) {
      if (progress) progress(0.1 + 0.85 * (current_start + f) / options.starts, label);
    };
  };
  const JacobianFn jacobian = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& r,
                                  int* evaluations) {
    return FitJacobian(request, x, r, evaluations, jacobian_progress());
  };
  // With sensitivities (and no secant updates) the iteration takes JᵀJ and Jᵀr accumulated in
  // the simulations' workers (SensitivityNormalEquations) instead of J.
  const NormalEquationsFn normal_equations = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& r,
                                                 Eigen::MatrixXd* jtj, Eigen::VectorXd* jtr,
                                                 int* evaluations) {
    FitNormalEquations(request, x, r, evaluations, jacobian_progress(), jtj, jtr);
  };
  const bool use_normal_equations = !options.broyden && UseSensitivities(options.jacobian, p);
  const LmOptions lm = LocalRunOptions(options);
  double best_cost = std::numeric_limits<double>::infinity();
  LmResult best;
  for (int sidx = 0; sidx < options.starts; ++sidx) {
    current_start = sidx;
    jacobians = 0;
    Eigen::VectorXd x0 = nominal;
    if (sidx > 0) {
      for (int k = 0; k < p; ++k) {
        const double e = unit(rng) * options.start_spread;
        x0(k) = request.params[k].kind == FitParameterKind::kArrayWeight
                    ? nominal(k) + e * std::max(nominal(k), 0.05)
                    : nominal(k) * std::exp(e);
        x0(k) = std::clamp(x0(k), lower(k), upper(k));
      }
    }
    if (progress) {
      progress(0.1 + 0.85 * sidx / options.starts,
               "local optimisation " + std::to_string(sidx + 1) + "/" +
                   std::to_string(options.starts) + " of " + std::to_string(p) + " parameters");
    }
    const auto t_run = Clock::now();
    const double cpu_run = ProcessCpuSeconds();
    LmResult res =
        use_normal_equations
            ? LevenbergMarquardt(residual, x0, lower, upper, lm, {}, {}, normal_equations)
            : LevenbergMarquardt(residual, x0, lower, upper, lm, {}, jacobian);
    LocalRun run;
    run.start = x0;
    run.x = res.x;
    run.cost = res.cost;
    run.iterations = res.iterations;
    run.evaluations = res.evaluations;
    run.wall_s = Seconds(t_run);
    run.cpu_s = ProcessCpuSeconds() - cpu_run;
    run.jacobians = res.jacobian_evaluations;
    run.converged = res.converged;
    run.stop_reason = LmStopReasonName(res.stop_reason);
    run.cost_history = res.cost_history;
    run.evaluations_history = res.evaluations_history;
    fit->runs.push_back(run);
    if (res.cost < best_cost) {
      fit->best_run = fit->runs.size() - 1;
      best_cost = res.cost;
      best = std::move(res);
    }
  }
  return best;
}

/// JᵀJ for the confidence intervals at the minimiser `best`.
/// Participation 1e-3 (FitFullModel): the paper's parameter set has (nearly) unidentifiable
/// pairs — β_j and A_jk enter eq. (3) only as β_j Σ_k A_jk u_k, so for a muscle that one channel
/// alone reaches (the other weights ≈ 0) only their product is determined. With exact
/// (sensitivity) Jacobians that pair spans a null direction (eigenvalue 2e-13 of the largest in
/// FullModelFitTest.MethodEntryFitsPlantedRigAndPredictsHeldOutTrial) whose eigenvector has
/// rounding-level weights (≈ 1e-6) on every other parameter; the pair gets NaN, the rest their
/// intervals. The iterations' sensitivity Jacobians are coarse (jacobian_tolerance_factor); the
/// intervals get one at kConfidenceJacobianToleranceFactor at the minimiser.
Eigen::MatrixXd ConfidenceJtJ(const JacobianRequest& request, const LmResult& best) {
  const FullModelFitOptions& options = request.options;
  const int p = static_cast<int>(request.params.size());
  if (UseSensitivities(options.jacobian, p) &&
      options.jacobian_tolerance_factor > kConfidenceJacobianToleranceFactor) {
    FullModelFitOptions fine = options;
    fine.jacobian_tolerance_factor = kConfidenceJacobianToleranceFactor;
    const JacobianRequest fine_request{fine,           request.base, request.params,
                                       request.upper,  request.data, request.tolerance,
                                       request.threads};
    int evaluations = 0;
    const Eigen::MatrixXd J = FitJacobian(fine_request, best.x, best.residual, &evaluations, {});
    return J.transpose() * J;
  }
  return best.jtj;
}

}  // namespace

GaussNewtonQuantities SensitivityGaussNewton(const sim::ModelParams& rig,
                                             const std::vector<Trial>& train,
                                             const std::vector<FitParameter>& params,
                                             const Eigen::VectorXd& x, double tolerance,
                                             double jacobian_tolerance, int threads) {
  const TrainingData data = ReadTraining(rig, train);
  const sim::ModelParams base = WithExplicitArrayWeights(rig);
  Eigen::VectorXd upper(static_cast<Eigen::Index>(params.size()));
  for (std::size_t k = 0; k < params.size(); ++k) upper(k) = params[k].upper;
  GaussNewtonQuantities g;
  g.r = Residuals(base, params, x, data, tolerance, threads, true);
  g.J = SensitivityJacobian(base, params, x, upper, data, jacobian_tolerance, threads);
  SensitivityNormalEquations(base, params, x, upper, data, jacobian_tolerance, threads, g.r, &g.jtj,
                             &g.jtr);
  return g;
}

FullModelFit FitFullModel(const sim::ModelParams& rig, const std::vector<Trial>& train,
                          const FullModelFitOptions& options, const ProgressFn& progress) {
  const auto t_total = Clock::now();
  CheckFitOptions(options);
  const TrainingData data = ReadTraining(rig, train);
  const int threads = ResolveThreads(options.threads);
  const double tol = options.integrator_tolerance;

  FullModelFit fit;
  const sim::ModelParams base = WithExplicitArrayWeights(rig);
  fit.candidates = CandidateParameters(rig, StimulatedChannels(rig, train));
  const int nc = static_cast<int>(fit.candidates.size());
  if (nc == 0) throw std::runtime_error("full-model: the rig offers no candidate parameter");
  fit.residuals = data.residuals;
  fit.distinct_simulations = static_cast<int>(data.plans.size());

  // 1. The ranking, skipped when the caller names the parameters and asks for no ranking.
  Ranking ranking{std::vector<int>(nc), std::vector<double>(nc)};
  if (options.rank || options.fit_names.empty()) {
    ranking = RankCandidates(options, base, data, tol, threads, progress, &fit);
  }

  // 2. The kept subset; parameters not kept are frozen at nominal in the base the local runs use.
  const std::vector<int> kept_index = KeptIndices(options, fit.candidates, ranking);
  const int p = static_cast<int>(kept_index.size());
  for (int i : kept_index) fit.kept.push_back(fit.candidates[i]);
  Eigen::VectorXd lower(p), upper(p), nominal(p);
  for (int k = 0; k < p; ++k) {
    lower(k) = fit.kept[k].lower;
    upper(k) = fit.kept[k].upper;
    nominal(k) = fit.kept[k].nominal;
  }
  if (data.residuals <= p) {
    throw std::runtime_error("train: " + std::to_string(data.residuals) +
                             " output samples, need more than " + std::to_string(p) +
                             " for the kept parameters (too-short data)");
  }

  // 3. Multi-start local optimisation; 4. the intervals at the best run's minimiser.
  const JacobianRequest request{options, base, fit.kept, upper, data, tol, threads};
  const LmResult best = MultiStart(options, request, lower, nominal, progress, &fit);
  fit.values = best.x;
  fit.cost = best.cost;
  fit.ci95_half_width =
      ConfidenceHalfWidths95(ConfidenceJtJ(request, best), best.cost, data.residuals, 1e-3);
  fit.model = ApplyParameters(base, fit.kept, fit.values);
  fit.total_wall_s = Seconds(t_total);
  if (progress) progress(0.95, "done fitting");
  return fit;
}

// ---------------------------------------------------------------------------------------------
// CLI adapter.
namespace {

Json MeanSd(const std::vector<double>& v) {
  Json j = Json::Object();
  double m = 0, s = 0;
  for (double x : v) m += x;
  m /= static_cast<double>(std::max<std::size_t>(1, v.size()));
  for (double x : v) s += (x - m) * (x - m);
  j.Set("mean", m);
  j.Set("std", v.size() > 1 ? std::sqrt(s / static_cast<double>(v.size() - 1)) : 0.0);
  j.Set("count", static_cast<int>(v.size()));
  j.Set("all", v);
  return j;
}

/// Simulated predictions of `trials` with per-joint Best Fit / normalised error.
Json Evaluate(const sim::ModelParams& model, const std::vector<Trial>& trials,
              const std::vector<std::string>& joints, double tol, int threads,
              std::vector<Trial>* predictions) {
  std::vector<Trial> sims(trials.size());
  ParallelFor(static_cast<int>(trials.size()), threads,
              [&](int t) { sims[t] = SimulateLike(model, trials[t], tol); });
  Json fits = Json::Array();
  std::map<std::string, double> ne_sum;
  for (std::size_t t = 0; t < trials.size(); ++t) {
    Json f = Json::Object();
    f.Set("trial", static_cast<int>(t));
    Json js = Json::Object();
    for (const auto& j : joints) {
      const auto& y = trials[t].Column(j);
      const auto& yh = sims[t].Column(j);
      Json jf = Json::Object();
      jf.Set("best_fit_percent", BestFitPercent(y, yh));
      const double ne = NormalisedError(y, yh);
      ne_sum[j] += ne;
      jf.Set("normalised_error", ne);
      jf.Set("rms_rad", Rms(y, yh));
      js.Set(j, jf);
    }
    f.Set("joints", js);
    fits.Push(f);
    sims[t].metadata["source"] = "fesim identify --method full-model";
    if (predictions) predictions->push_back(std::move(sims[t]));
  }
  Json mean = Json::Object();
  for (const auto& j : joints) mean.Set(j, ne_sum[j] / static_cast<double>(trials.size()));
  Json out = Json::Object();
  out.Set("trials", fits);
  out.Set("mean_normalised_error", mean);
  return out;
}

MethodResult RunFullModel(const std::string& default_scenario, const std::vector<Trial>& train,
                          const std::vector<Trial>& test, const ProgressFn& progress) {
  if (train.empty()) throw std::runtime_error("--train: no trials");
  std::string scenario = default_scenario;
  const auto it = train[0].metadata.find("scenario_path");
  if (it != train[0].metadata.end() && !it->second.empty()) scenario = it->second;
  const sim::ModelParams rig = scenario.empty() ? DefaultHandRig() : LoadScenario(scenario).model;
  MetadataOptions md(train[0].metadata, "fullmodel");
  FullModelFitOptions o;
  o.keep_parameters = md.Int("keep", o.keep_parameters, 1, 1000);
  o.starts = md.Int("starts", o.starts, 1, 1000);
  o.seed = static_cast<unsigned>(md.Int("seed", 1, 0, 2147483647));
  o.start_spread = md.Real("spread", o.start_spread, 0.0, 3.0);
  o.max_iterations = md.Int("max_iterations", o.max_iterations, 1, 10000);
  o.relative_tolerance = md.Real("tolerance", o.relative_tolerance, 0.0, 1.0);
  o.integrator_tolerance = md.Real("integrator_tolerance", o.integrator_tolerance, 1e-12, 1e-2);
  o.threads = md.Int("threads", 0, 0, 256);
  o.broyden = md.Int("broyden", o.broyden ? 1 : 0, 0, 1) == 1;
  o.jacobian = static_cast<JacobianMethod>(md.Int("jacobian", 0, 0, 2));
  o.jacobian_tolerance_factor =
      md.Real("jacobian_tolerance_factor", o.jacobian_tolerance_factor, 1.0, 1e4);
  md.RejectUnknown();

  const FullModelFit fit = FitFullModel(rig, train, o, progress);
  const std::vector<std::string> joints = train[0].NamesWithPrefix("q.");
  CheckTrials(rig, test, "test", joints);
  const int threads = ResolveThreads(o.threads);

  std::string y =
      "# fesim identify: full-model (paper 000_0a6c0de9fc69df7c eq. 12, sensitivity ranking + "
      "multi-start local optimisation of section 5.1)\nmethod: full-model\n";
  y +=
      "rig: " + (scenario.empty() ? std::string("default hand rig (arm locked)") : scenario) + "\n";
  y += "outputs: [";
  for (std::size_t i = 0; i < joints.size(); ++i) y += (i ? ", " : "") + joints[i];
  y += "]\n# fitted parameters (95 % intervals from J^T J at the optimum)\nfitted:\n";
  std::set<std::string> kept_names;
  for (std::size_t k = 0; k < fit.kept.size(); ++k) {
    kept_names.insert(fit.kept[k].name);
    y += YamlParam(fit.kept[k].name, fit.values(static_cast<Eigen::Index>(k)), fit.kept[k].unit,
                   fit.ci95_half_width(static_cast<Eigen::Index>(k)), 2);
  }
  y += "# candidates not fitted, held at the rig's nominal values\nfixed:\n";
  for (const auto& c : fit.candidates) {
    if (!kept_names.count(c.name)) y += YamlParam(c.name, c.nominal, c.unit, NAN, 2);
  }
  y += "# normalised output sensitivity S_j at the start point, rad, most influential first\n"
       "sensitivity:\n";
  for (const auto& e : fit.ranking) y += "  " + e.name + ": " + Num(e.sensitivity) + "\n";

  std::vector<Convergence> convergence;
  for (const auto& r : fit.runs) convergence.push_back({r.converged, r.stop_reason, r.iterations});
  y += "# how each local Levenberg-Marquardt run stopped (best_run: the one kept)\n";
  y += ConvergenceYaml("convergence", convergence, fit.best_run, 0);
  MethodResult result;
  result.model_yaml = y;
  const std::string warning =
      NotConvergedWarning("full-model local optimisation", convergence, fit.best_run);
  if (!warning.empty()) result.warnings.push_back(warning);
  if (progress) progress(0.97, "evaluation");
  Json m = Json::Object();
  m.Set("method", "full-model");
  m.Set("prediction", "simulation of the full model from its initial state (not one-step-ahead)");
  m.Set("candidates", static_cast<int>(fit.candidates.size()));
  m.Set("fitted_parameters", static_cast<int>(fit.kept.size()));
  m.Set("residuals", fit.residuals);
  m.Set("cost_rad2", fit.cost);
  std::vector<double> walls, cpus, iters, evals, costs, jacs;
  for (const auto& r : fit.runs) {
    walls.push_back(r.wall_s);
    cpus.push_back(r.cpu_s);
    iters.push_back(r.iterations);
    jacs.push_back(r.jacobians);
    evals.push_back(r.evaluations);
    costs.push_back(r.cost);
  }
  m.Set("local_step_wall_s", MeanSd(walls));
  m.Set("local_step_cpu_s", MeanSd(cpus));
  m.Set("local_step_iterations", iters);
  m.Set("local_step_evaluations", evals);
  m.Set("local_step_jacobians", jacs);
  m.Set("broyden", o.broyden);
  m.Set("distinct_simulations_per_evaluation", fit.distinct_simulations);
  m.Set("local_step_cost_rad2", costs);
  m.Set("convergence", ConvergenceJson(convergence, fit.best_run));
  m.Set("sensitivity_wall_s", fit.sensitivity_wall_s);
  m.Set("total_wall_s", fit.total_wall_s);
  m.Set("threads", threads);
  m.Set("train", Evaluate(fit.model, train, joints, o.integrator_tolerance, threads,
                          test.empty() ? &result.predictions : nullptr));
  if (!test.empty()) {
    m.Set("test",
          Evaluate(fit.model, test, joints, o.integrator_tolerance, threads, &result.predictions));
  }
  result.metrics = m;
  if (progress) progress(1.0, "done");
  return result;
}

}  // namespace

MethodEntry FullModelMethod(const std::string& scenario_path) {
  return {"full-model",
          "full model (12) through the simulator: sensitivity ranking, multi-start LM of the "
          "top 29 (paper 000 5.1); rig from --scenario, else the default hand rig (arm locked)",
          [scenario_path](const std::vector<Trial>& train, const std::vector<Trial>& test,
                          const ProgressFn& progress) {
            return RunFullModel(scenario_path, train, test, progress);
          }};
}

}  // namespace fesim::identification::fullmodel
