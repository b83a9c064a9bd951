#include "diagnosis/reduced_model.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "diagnosis/mechanisms/library.h"
#include "identification/method.h"
#include "sim/mechanisms.h"

namespace fesim::diagnosis {
namespace {

/// u(t − δ) on the trial's own time grid by linear interpolation; u(t₀) before t₀ + δ.
std::vector<double> Delayed(const std::vector<double>& time, const std::vector<double>& u,
                            double delay_s) {
  std::vector<double> out(u.size());
  std::size_t k = 0;  // time[k] <= t − δ < time[k + 1]
  for (std::size_t i = 0; i < u.size(); ++i) {
    const double t = time[i] - delay_s;
    if (t <= time.front()) {
      out[i] = u.front();
      continue;
    }
    while (k + 1 < time.size() && time[k + 1] <= t) ++k;
    if (k + 1 >= time.size()) {
      out[i] = u.back();
      continue;
    }
    const double w = (t - time[k]) / (time[k + 1] - time[k]);
    out[i] = (1.0 - w) * u[k] + w * u[k + 1];
  }
  return out;
}

/// Centroid of a channel's pads on the array (x along columns, y along rows), m; false when the
/// channel has no pads.
bool PadCentroid(const sim::ModelParams& m, const sim::ChannelParams& ch, double* x, double* y) {
  if (ch.pads.empty() || m.array.cols <= 0) return false;
  double sx = 0.0, sy = 0.0;
  for (int p : ch.pads) {
    const int row = p / m.array.cols, col = p % m.array.cols;  // pad index = row · cols + col
    sx += col * m.array.pitch_m;
    sy += row * m.array.pitch_m;
  }
  *x = sx / static_cast<double>(ch.pads.size());
  *y = sy / static_cast<double>(ch.pads.size());
  return true;
}

}  // namespace

const std::vector<std::string>& ReducedModelMechanisms() {
  static const std::vector<std::string> ids = [] {
    std::vector<std::string> out;
    for (const auto& m : Mechanisms()) {
      if (m.reduced_model_form) out.push_back(m.id);
    }
    return out;
  }();
  return ids;
}

std::vector<identification::MethodEntry> ReducedModelMethods() {
  std::vector<identification::MethodEntry> out;
  for (auto& m : identification::BuiltinMethods()) {
    if (m.fit_simulator) out.push_back(std::move(m));
  }
  return out;
}

double AffineStateStep(double f0, double f1, double x, double h_s) {
  const double alpha = f0 - f1;
  if (!(alpha > 0.0)) return x + h_s * (f0 + (f1 - f0) * x);  // no restoring term: Euler
  const double x_inf = f0 / alpha;
  return x_inf + (x - x_inf) * std::exp(-alpha * h_s);
}

Trial ApplyInputMechanisms(const sim::ModelParams& m, const Trial& trial,
                           const std::vector<std::string>& inputs,
                           const std::map<std::string, double>& u_ref) {
  Trial out = trial;
  const sim::MechanismParams& mech = m.mechanisms;
  const std::size_t n = trial.size();
  if (mech.electromechanical_delay_s > 0.0) {
    for (const auto& c : inputs) {
      out.MutableColumn(c) = Delayed(trial.time, trial.Column(c), mech.electromechanical_delay_s);
    }
  }
  if (mech.crosstalk.fraction > 0.0) {
    // Channel positions, then u_c + c Σ w_cc' u_c' from the (delayed) inputs.
    std::vector<double> px(inputs.size()), py(inputs.size());
    std::vector<char> placed(inputs.size(), 0);
    for (std::size_t a = 0; a < inputs.size(); ++a) {
      for (const auto& ch : m.channels) {
        if ("u." + ch.name == inputs[a]) placed[a] = PadCentroid(m, ch, &px[a], &py[a]) ? 1 : 0;
      }
    }
    const double s2 = 2.0 * mech.crosstalk.spread_m * mech.crosstalk.spread_m;
    std::vector<std::vector<double>> before;
    before.reserve(inputs.size());
    for (const auto& c : inputs) before.push_back(out.Column(c));
    for (std::size_t a = 0; a < inputs.size(); ++a) {
      if (!placed[a]) continue;
      auto& u = out.MutableColumn(inputs[a]);
      for (std::size_t b = 0; b < inputs.size(); ++b) {
        if (b == a || !placed[b]) continue;
        const double d2 = (px[a] - px[b]) * (px[a] - px[b]) + (py[a] - py[b]) * (py[a] - py[b]);
        const double w = mech.crosstalk.fraction * std::exp(-d2 / s2);
        for (std::size_t i = 0; i < n; ++i) u[i] += w * before[b][i];
      }
    }
  }
  const bool fatigue = mech.fatigue.enabled, potentiation = mech.potentiation.enabled;
  if ((fatigue || potentiation) && n > 0) {
    for (const auto& c : inputs) {
      const auto it = u_ref.find(c);
      const double ref = it != u_ref.end() && it->second > 0.0 ? it->second : 1.0;
      auto& u = out.MutableColumn(c);
      double phi = 1.0, p = 0.0;
      std::vector<double> gain(n, 1.0);
      for (std::size_t i = 0; i < n; ++i) {
        gain[i] = (fatigue ? phi : 1.0) * (potentiation ? 1.0 + mech.potentiation.gain * p : 1.0);
        if (i + 1 == n) break;
        // The drive of the interval [t_i, t_{i+1}): stimulation is held between samples.
        const double a = std::clamp(u[i] / ref, 0.0, 1.0), h = trial.time[i + 1] - trial.time[i];
        if (fatigue) {
          phi = AffineStateStep(sim::FitnessDerivative(mech.fatigue, a, 0.0),
                                sim::FitnessDerivative(mech.fatigue, a, 1.0), phi, h);
        }
        if (potentiation) {
          p = AffineStateStep(sim::PotentiationDerivative(mech.potentiation, a, 0.0),
                              sim::PotentiationDerivative(mech.potentiation, a, 1.0), p, h);
        }
      }
      for (std::size_t i = 0; i < n; ++i) u[i] *= gain[i];
    }
  }
  return out;
}

void AddOutputTremor(const sim::ModelParams& m, Trial* outputs) {
  const sim::TremorParams& p = m.mechanisms.tremor;
  if (!p.enabled || p.coordinate < 0 || p.coordinate >= sim::kNumCoordinates) return;
  const std::string col = "q." + sim::CoordinateNames()[p.coordinate];
  if (!outputs->Has(col)) return;
  const double tj = JointTorqueScale(m, p.coordinate);
  auto& q = outputs->MutableColumn(col);
  for (std::size_t i = 0; i < q.size(); ++i) q[i] += sim::TremorTorque(p, outputs->time[i]) / tj;
}

TrialSimulator ReducedSimulator(const identification::FittedSimulator& fitted,
                                const std::map<std::string, double>& u_ref) {
  return [fitted, u_ref](const sim::ModelParams& m, const Trial& trial, double /*tolerance*/) {
    Trial out = fitted.simulate(ApplyInputMechanisms(m, trial, fitted.inputs, u_ref));
    AddOutputTremor(m, &out);
    return out;
  };
}

std::vector<Trial> ReducedTrainingTrials(const DataView& train,
                                         const std::vector<std::string>& channels,
                                         std::map<std::string, double>* u_ref) {
  std::vector<Trial> out;
  u_ref->clear();
  for (std::size_t t = 0; t < train.trials.size(); ++t) {
    const Trial& in = train.trials[t];
    std::size_t end = 0;  // one past the last counted row
    for (std::size_t i = 0; i < in.size(); ++i) {
      if (train.use[t][i]) end = i + 1;
    }
    Trial tr;
    tr.metadata = in.metadata;
    tr.time.assign(in.time.begin(), in.time.begin() + static_cast<std::ptrdiff_t>(end));
    // The record is uniform to within measured.h's 1 % (e.g. a 60 Hz log written to 4 decimals);
    // the identification methods want exact steps: t₀ + k·(mean step), each moved by ≤ 0.5 %
    // of a step.
    if (tr.time.size() > 1) {
      const double t0 = tr.time.front(), dt = (tr.time.back() - t0) / (tr.time.size() - 1.0);
      for (std::size_t i = 0; i < tr.time.size(); ++i)
        tr.time[i] = t0 + dt * static_cast<double>(i);
    }
    for (const auto& ch : channels) {
      const std::string c = "u." + ch;
      if (!in.Has(c)) continue;
      std::vector<double> u(in.Column(c).begin(), in.Column(c).begin() + tr.time.size());
      double& ref = (*u_ref)[c];
      for (double v : u) ref = std::max(ref, v);
      tr.AddColumn(c, std::move(u));
    }
    for (const auto& o : train.outputs) {
      std::vector<double> y(in.Column(o).begin(), in.Column(o).begin() + tr.time.size());
      std::vector<std::size_t> finite;
      for (std::size_t i = 0; i < y.size(); ++i) {
        if (std::isfinite(y[i])) finite.push_back(i);
      }
      if (finite.empty()) {
        throw std::runtime_error("diagnose: " + o + " has no finite sample in the training part");
      }
      std::size_t k = 0;  // finite[k] <= i < finite[k + 1]
      for (std::size_t i = 0; i < y.size(); ++i) {
        if (std::isfinite(y[i])) continue;
        while (k + 1 < finite.size() && finite[k + 1] < i) ++k;
        const std::size_t a = finite[k];
        if (i < a || k + 1 >= finite.size()) {
          y[i] = y[i < a ? finite.front() : finite.back()];
          continue;
        }
        const std::size_t b = finite[k + 1];
        const double w = (tr.time[i] - tr.time[a]) / (tr.time[b] - tr.time[a]);
        y[i] = (1.0 - w) * y[a] + w * y[b];
      }
      tr.AddColumn(o, std::move(y));
    }
    out.push_back(std::move(tr));
  }
  return out;
}

}  // namespace fesim::diagnosis
