#include "sim/integrator.h"

#include <cvodes/cvodes.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "muscles/activation.h"

namespace fesim::sim {

std::vector<double> StimulationSchedule::At(double t, int channels) const {
  const auto it = std::upper_bound(times.begin(), times.end(), t);
  // Not `return {channels, 0.0};`: braces pick the initializer_list constructor (2 elements).
  // NOLINTNEXTLINE(modernize-return-braced-init-list): see above.
  if (it == times.begin()) return std::vector<double>(channels, 0.0);
  return values[static_cast<std::size_t>(it - times.begin()) - 1];
}

namespace {

constexpr long kMaxSteps = 1000000;
// Report times or breakpoints closer than this to the current time (s) are treated as reached:
// the state cannot change measurably over 1e-9 s, and CVODES rejects such intervals.
constexpr double kMinInterval = 1e-9;

/// Breakpoints (stimulation changes) strictly after t0.
std::vector<double> Breakpoints(const StimulationSchedule& schedule, double t0) {
  std::vector<double> b;
  for (double t : schedule.times) {
    if (t > t0) b.push_back(t);
  }
  return b;
}

/// Ends every integration failure message, whichever the integrator.
constexpr const char* kFailureHint =
    ". Hint: check stimulation, stiffness and range limits, or tighten integrator.tolerance";

/// A multi-line library message joined on one line.
std::string OneLine(std::string s) {
  for (char& c : s) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

std::string DescribeState(const UpperLimbModel& model, const SimTK::State& s) {
  // Name the coordinate furthest outside its range: the usual culprit of a blow-up.
  const auto q = model.GetQs(s);
  int worst = 0;
  double excess = -INFINITY;
  for (int i = 0; i < kNumCoordinates; ++i) {
    const auto& p = model.params().coordinates[i].passive;
    const double e = std::max(p.min_angle_rad - q[i], q[i] - p.max_angle_rad);
    if (!std::isfinite(q[i])) {
      worst = i;
      excess = INFINITY;
      break;
    }
    if (e > excess) {
      excess = e;
      worst = i;
    }
  }
  return "coordinate " + CoordinateNames()[worst] + " at " + std::to_string(q[worst]) +
         " rad (range " + std::to_string(model.params().coordinates[worst].passive.min_angle_rad) +
         ".." + std::to_string(model.params().coordinates[worst].passive.max_angle_rad) + ")";
}

/// CVODES integrates y = the Simbody state Y without the muscle activation states: between
/// breakpoints the stimulation, hence w, is constant and eq. (6) is solved in closed form
/// (muscles::ActivationFreeResponse), exactly and at no cost to the implicit solver. The q and u
/// of locked coordinates are left out too: they are constant (zero derivative, zero local error),
/// yet each costs one right-hand side per difference-quotient Jacobian column (the hand rig locks
/// 5 of 10 coordinates: 20 → 10 components). Because CVODES' error norm is a root mean square
/// over the components, the tolerance is scaled by √(n_with_locked / n) so that every error and
/// Newton test sees the same norm as with the locked components included.
struct CvodesContext {
  const UpperLimbModel* model;
  SimTK::State* state;
  bool prescribe;
  long rhs = 0;
  double tolerance_scale = 1.0;              // √(components with locked ones / without)
  std::vector<int> y_index;                  // Y index of each CVODES component
  int activation_index = 0;                  // Y index of muscle 0's a
  std::vector<double> omega;                 // Ω_j, rad/s
  std::vector<double> w;                     // recruited fraction in the current interval
  std::vector<muscles::ActivationState> a0;  // activation state at the interval start
  double t0 = 0.0;                           // interval start, s

  CvodesContext(const UpperLimbModel* m, SimTK::State* s, bool p)
      : model(m), state(s), prescribe(p) {
    const int ny = s->getNY();
    const int nm = m->num_muscles();
    activation_index = m->ActivationYIndex(*s);
    const std::vector<int> locked = m->LockedYIndices(*s);
    std::vector<int> all;
    for (int i = 0; i < ny; ++i) {
      if (i >= activation_index && i < activation_index + 2 * nm) continue;
      all.push_back(i);
      if (!std::binary_search(locked.begin(), locked.end(), i)) y_index.push_back(i);
    }
    if (y_index.empty()) {
      y_index = all;  // everything locked: CVODES needs at least one component
    } else {
      tolerance_scale = std::sqrt(static_cast<double>(all.size()) / y_index.size());
    }
    for (const auto& mu : m->params().muscles) omega.push_back(mu.activation_omega_rad_s);
  }
  /// Records the activation state and input at the start of an interval.
  void BeginInterval(double t) {
    t0 = t;
    w = model->RecruitedFractions(*state);
    const SimTK::Vector& Y = state->getY();
    a0.resize(omega.size());
    for (std::size_t j = 0; j < omega.size(); ++j) {
      a0[j] = {Y[activation_index + 2 * static_cast<int>(j)],
               Y[activation_index + 2 * static_cast<int>(j) + 1]};
    }
  }
};

void LoadState(CvodesContext* c, double t, const double* y,
               SimTK::Stage stage = SimTK::Stage::Acceleration) {
  SimTK::Vector& Y = c->state->updY();
  for (std::size_t i = 0; i < c->y_index.size(); ++i) Y[c->y_index[i]] = y[i];
  for (std::size_t j = 0; j < c->omega.size(); ++j) {
    const auto a = muscles::ActivationFreeResponse(c->omega[j], c->w[j], c->a0[j], t - c->t0);
    Y[c->activation_index + 2 * static_cast<int>(j)] = a.a;
    Y[c->activation_index + 2 * static_cast<int>(j) + 1] = a.a_dot;
  }
  c->state->setTime(t);
  if (c->prescribe) c->model->system().prescribe(*c->state);
  c->model->system().realize(*c->state, stage);
}

int Rhs(sunrealtype t, N_Vector y, N_Vector ydot, void* user) {
  auto* c = static_cast<CvodesContext*>(user);
  ++c->rhs;
  try {
    LoadState(c, t, N_VGetArrayPointer(y));
  } catch (const std::exception&) {
    return 1;  // recoverable: CVODES retries with a smaller step
  }
  const SimTK::Vector& yd = c->state->getYDot();
  double* out = N_VGetArrayPointer(ydot);
  for (std::size_t i = 0; i < c->y_index.size(); ++i) {
    out[i] = yd[c->y_index[i]];
    if (!std::isfinite(out[i])) return 1;
  }
  return 0;
}

/// Owns the SUNDIALS objects (RAII).
class Cvodes {
 public:
  Cvodes(int n, double tol, bool adams, CvodesContext* ctx) {
    if (SUNContext_Create(nullptr, &sunctx_) != 0) throw std::runtime_error("SUNContext_Create");
    y_ = N_VNew_Serial(n, sunctx_);
    mem_ = CVodeCreate(adams ? CV_ADAMS : CV_BDF, sunctx_);
    a_ = SUNDenseMatrix(n, n, sunctx_);
    ls_ = SUNLinSol_Dense(y_, a_, sunctx_);
    tol_ = tol;
    ctx_ = ctx;
  }
  ~Cvodes() {
    if (mem_ != nullptr) CVodeFree(&mem_);
    if (ls_ != nullptr) SUNLinSolFree(ls_);
    if (a_ != nullptr) SUNMatDestroy(a_);
    if (y_ != nullptr) N_VDestroy(y_);
    if (sunctx_ != nullptr) SUNContext_Free(&sunctx_);
  }
  Cvodes(const Cvodes&) = delete;
  Cvodes& operator=(const Cvodes&) = delete;

  /// Starts, or continues after a stimulation breakpoint. Only the closed-form activation
  /// changes its input there; a and ȧ, hence the right-hand side of q, u (and of any other z), are
  /// continuous, so CVODES continues with its history (step stopped exactly at the breakpoint by
  /// CVodeSetStopTime) instead of restarting at first order.
  void Start(double t0) {
    ctx_->BeginInterval(t0);
    if (initialised_) return;
    const SimTK::Vector& y0 = ctx_->state->getY();
    double* y = N_VGetArrayPointer(y_);
    for (std::size_t i = 0; i < ctx_->y_index.size(); ++i) y[i] = y0[ctx_->y_index[i]];
    if (!initialised_) {
      Check(CVodeInit(mem_, Rhs, t0, y_), "CVodeInit", t0);
      Check(CVodeSStolerances(mem_, tol_, tol_), "CVodeSStolerances", t0);
      Check(CVodeSetUserData(mem_, ctx_), "CVodeSetUserData", t0);
      Check(CVodeSetLinearSolver(mem_, ls_, a_), "CVodeSetLinearSolver", t0);
      Check(CVodeSetMaxNumSteps(mem_, kMaxSteps), "CVodeSetMaxNumSteps", t0);
      initialised_ = true;
    }
  }
  /// Advances to exactly t_out (≤ stop) and leaves the solution in the context's state,
  /// realised to Stage::Time.
  void AdvanceTo(double t_out, double stop) {
    Check(CVodeSetStopTime(mem_, stop), "CVodeSetStopTime", t_out);
    double t_reached = 0.0;
    const int flag = CVode(mem_, t_out, y_, &t_reached, CV_NORMAL);
    if (flag < 0) {
      LoadState(ctx_, t_reached, N_VGetArrayPointer(y_));
      throw std::runtime_error("integration failed at t = " + std::to_string(t_reached) +
                               " s (CVODES " + CVodeGetReturnFlagName(flag) + "); " +
                               DescribeState(*ctx_->model, *ctx_->state) + kFailureHint);
    }
    // Only Stage::Time here: Drive realises the stage its observer asked for right after, so an
    // observer that reads q alone (the full-model fit) does not pay for kinematics at every
    // report time (≈ 1/3 of a 140 s, 40 Hz hand-rig simulation).
    LoadState(ctx_, t_out, N_VGetArrayPointer(y_), SimTK::Stage::Time);
  }
  void AddStats(IntegrationStats* s) const {
    if (!initialised_) return;
    long v = 0;
    CVodeGetNumSteps(mem_, &v);
    s->steps += v;
    CVodeGetNumJacEvals(mem_, &v);
    s->jacobian_evaluations += v;
  }

 private:
  void Check(int flag, const char* what, double t) {
    if (flag < 0) {
      throw std::runtime_error(std::string(what) + " failed at t = " + std::to_string(t) + " s");
    }
  }
  SUNContext sunctx_ = nullptr;
  N_Vector y_ = nullptr;
  void* mem_ = nullptr;
  SUNMatrix a_ = nullptr;
  SUNLinearSolver ls_ = nullptr;
  double tol_ = 1e-6;
  bool initialised_ = false;
  CvodesContext* ctx_ = nullptr;
};

bool HasPrescribed(const ModelParams& p) {
  return std::any_of(p.coordinates.begin(), p.coordinates.end(), [](const CoordinateParams& c) {
    return c.mode == CoordinateMode::kPrescribed;
  });
}

/// Walks the report times: advance(t, stop) integrates to t without passing the next
/// breakpoint `stop`; at each breakpoint the stimulation changes and restart(t) reinitialises
/// the integrator; observer sees each report time. Shared by both integrators.
template <typename Advance, typename Restart>
void Drive(const UpperLimbModel& model, const StimulationSchedule& schedule,
           const std::vector<double>& report_times, SimTK::State* state, const Observer& observer,
           SimTK::Stage observe_stage, Advance advance, Restart restart, IntegrationStats* stats) {
  const int nc = model.num_channels();
  const double t0 = state->getTime();
  model.SetStimulation(*state, schedule.At(t0, nc));
  const std::vector<double> breaks = Breakpoints(schedule, t0);
  std::size_t next_break = 0;
  restart(t0);
  const double kInf = std::numeric_limits<double>::infinity();
  for (double t_r : report_times) {
    if (t_r < state->getTime() - 1e-12) throw std::invalid_argument("report times not sorted");
    while (next_break < breaks.size() && breaks[next_break] <= t_r) {
      const double tb = breaks[next_break];
      if (tb > state->getTime() + kMinInterval) advance(tb, tb);
      model.SetStimulation(*state, schedule.At(tb, nc));
      restart(tb);
      ++stats->breakpoints;
      ++next_break;
    }
    const double stop = next_break < breaks.size() ? breaks[next_break] : kInf;
    if (t_r > state->getTime() + kMinInterval) advance(t_r, stop);
    model.system().realize(*state, observe_stage);
    observer(*state);
  }
}

}  // namespace

IntegrationStats IntegrateTrial(const UpperLimbModel& model, const IntegratorParams& params,
                                const StimulationSchedule& schedule,
                                const std::vector<double>& report_times, SimTK::State* state,
                                const Observer& observer, SimTK::Stage observe_stage) {
  IntegrationStats stats;
  if (params.method != IntegratorParams::Method::kSimbodyRkMerson) {
    CvodesContext ctx(&model, state, HasPrescribed(model.params()));
    Cvodes cv(static_cast<int>(ctx.y_index.size()), params.tolerance * ctx.tolerance_scale,
              params.method == IntegratorParams::Method::kCvodesAdams, &ctx);
    Drive(
        model, schedule, report_times, state, observer, observe_stage,
        [&](double t, double stop) { cv.AdvanceTo(t, stop); },
        [&](double t) {
          state->setTime(t);
          cv.Start(t);
        },
        &stats);
    cv.AddStats(&stats);
    stats.rhs_evaluations = ctx.rhs;
    return stats;
  }
  // Simbody's Runge–Kutta–Merson, restarted at each breakpoint like CVODES.
  std::unique_ptr<SimTK::RungeKuttaMersonIntegrator> integ;
  // Simbody's exception text (multi-line, no coordinate) becomes one line with the time, the
  // coordinate furthest out of range at the last accepted step and the hint of the CVODES path.
  const auto failure = [&](const std::exception& e, const SimTK::State& at) {
    if (&at != state) *state = at;
    return std::runtime_error("integration failed at t = " + std::to_string(at.getTime()) +
                              " s (Simbody RKM: " + OneLine(e.what()) + "); " +
                              DescribeState(model, *state) + kFailureHint +
                              " (or integrator.method cvodes for a stiff rig)");
  };
  Drive(
      model, schedule, report_times, state, observer, observe_stage,
      [&](double t, double stop) {
        try {
          while (integ->getTime() < t) integ->stepTo(t, stop);
        } catch (const std::exception& e) {
          throw failure(e, integ->getState());
        }
        *state = integ->getState();
        if (std::abs(state->getTime() - t) > 1e-9) {
          throw std::runtime_error(
              "Simbody integrator stopped at t = " + std::to_string(state->getTime()) +
              " s before " + std::to_string(t) + " s");
        }
      },
      [&](double t) {
        if (integ) stats.steps += integ->getNumStepsTaken();
        state->setTime(t);
        integ = std::make_unique<SimTK::RungeKuttaMersonIntegrator>(model.system());
        integ->setAccuracy(params.tolerance);
        integ->setReturnEveryInternalStep(false);
        try {
          integ->initialize(*state);
        } catch (const std::exception& e) {
          throw failure(e, *state);
        }
      },
      &stats);
  if (integ) stats.steps += integ->getNumStepsTaken();
  return stats;
}

}  // namespace fesim::sim
