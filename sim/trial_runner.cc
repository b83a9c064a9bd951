#include "sim/trial_runner.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "sim/sensors.h"

namespace fesim::sim {
namespace {

const double kNaN = std::nan("");

/// Measurement artefacts of one sensor channel (SensorParams): offset drift, tracker dropouts
/// in bursts (a two-state Markov chain whose long-run lost fraction is p and mean burst length
/// L: enter with p / (L (1 − p)), leave with 1 / L) and outliers.
class Artefacts {
 public:
  Artefacts(const SensorParams& p, std::uint64_t seed) : p_(p), rng_(seed), noise_(seed ^ 0xA5A5) {}
  double Apply(double t, double value) {
    value += p_.offset_drift_per_s * t;
    if (p_.dropout_probability > 0.0) {
      const double l = std::max(1.0, p_.dropout_mean_samples);
      const double enter = p_.dropout_probability / (l * (1.0 - p_.dropout_probability));
      in_dropout_ = in_dropout_ ? Uniform() >= 1.0 / l : Uniform() < enter;
      if (in_dropout_) return kNaN;
    }
    if (p_.outlier_probability > 0.0 && Uniform() < p_.outlier_probability) {
      value += noise_.Sample(p_.outlier_std);
    }
    return value;
  }

 private:
  double Uniform() { return (static_cast<double>(rng_() >> 11) + 0.5) / 9007199254740992.0; }
  SensorParams p_;
  std::mt19937_64 rng_;
  GaussianNoise noise_;
  bool in_dropout_ = false;
};

}  // namespace

TrialResult RunTrial(const UpperLimbModel& model, const TrialRequest& req,
                     const std::function<void(double)>& progress) {
  if (!(req.duration_s > 0.0)) throw std::invalid_argument("trial duration must be > 0");
  const SensorSuite& sens = req.sensors;
  const auto& names = CoordinateNames();
  const int nc = model.num_channels();
  const int nm = model.num_muscles();

  const std::vector<double> angle_t = SampleTimes(sens.angles.rate_hz, req.duration_s);
  const std::vector<double> vel_t = SampleTimes(sens.velocities.rate_hz, req.duration_s);
  const std::vector<double> torque_t = SampleTimes(sens.torques.rate_hz, req.duration_s);
  const std::vector<double> truth_t = SampleTimes(sens.truth_rate_hz, req.duration_s);
  std::vector<std::vector<double>> grids = {truth_t};
  if (!sens.angles.coordinates.empty()) grids.push_back(angle_t);
  if (!sens.velocities.coordinates.empty()) grids.push_back(vel_t);
  if (!sens.torques.coordinates.empty()) grids.push_back(torque_t);
  const std::vector<double> report = MergeTimes(grids);
  const std::vector<bool> on_truth = OnGrid(report, truth_t);
  const std::vector<bool> on_angle = OnGrid(report, angle_t);
  const std::vector<bool> on_vel = OnGrid(report, vel_t);
  const std::vector<bool> on_torque = OnGrid(report, torque_t);

  // Truth record and measured record are filled row by row.
  TrialResult result;
  std::vector<double> meas_t;
  std::vector<std::vector<double>> meas_u(nc), meas_q(sens.angles.coordinates.size()),
      meas_qd(sens.velocities.coordinates.size()), meas_tau(sens.torques.coordinates.size());
  std::vector<double> truth_time;
  std::vector<std::vector<double>> tr_u(nc), tr_q(kNumCoordinates), tr_qd(kNumCoordinates),
      tr_a(nm), tr_f(nm), tr_tm(kNumCoordinates), tr_tau(sens.torques.coordinates.size());
  GaussianNoise angle_noise(DeriveSeed(req.seed, 1)), vel_noise(DeriveSeed(req.seed, 2)),
      torque_noise(DeriveSeed(req.seed, 3));
  std::vector<Artefacts> angle_art, vel_art, torque_art;
  std::uint64_t stream = 100;
  for (std::size_t k = 0; k < meas_q.size(); ++k) {
    angle_art.emplace_back(sens.angles, DeriveSeed(req.seed, stream++));
  }
  for (std::size_t k = 0; k < meas_qd.size(); ++k) {
    vel_art.emplace_back(sens.velocities, DeriveSeed(req.seed, stream++));
  }
  for (std::size_t k = 0; k < meas_tau.size(); ++k) {
    torque_art.emplace_back(sens.torques, DeriveSeed(req.seed, stream++));
  }
  // Electromechanical delay: the muscles see the stimulation δ late; the trial records what was
  // commanded (clipped to the stimulator's 0–300 µs, as the model clips it).
  StimulationSchedule effective = req.stimulation;
  for (double& t : effective.times) t += model.params().mechanisms.electromechanical_delay_s;
  const auto commanded = [&](double t) {
    std::vector<double> u = req.stimulation.At(t, nc);
    for (double& x : u) x = std::clamp(x, 0.0, 300.0);
    return u;
  };

  std::size_t row = 0;
  SimTK::State state = model.MakeInitialState();
  const auto observer = [&](const SimTK::State& s) {
    const std::size_t i = row++;
    if (progress && (i % 256 == 0 || i + 1 == report.size())) {
      progress(s.getTime() / req.duration_s);
    }
    const std::vector<double> u = commanded(s.getTime());
    const std::vector<double> q = model.GetQs(s);
    const std::vector<double> qd = model.GetUs(s);
    const bool need_torque = !sens.torques.coordinates.empty() && (on_torque[i] || on_truth[i]);
    const std::vector<double> tau = need_torque ? model.SensorTorques(s) : std::vector<double>();
    if (on_truth[i]) {
      const MuscleSnapshot m = model.ComputeMuscles(s);
      result.fibre_clamped = result.fibre_clamped || m.any_clamped;
      truth_time.push_back(s.getTime());
      for (int k = 0; k < nc; ++k) tr_u[k].push_back(u[k]);
      for (int c = 0; c < kNumCoordinates; ++c) {
        tr_q[c].push_back(q[c]);
        tr_qd[c].push_back(qd[c]);
        tr_tm[c].push_back(m.joint_torque_nm[c]);
      }
      for (int j = 0; j < nm; ++j) {
        tr_a[j].push_back(m.activation[j]);
        tr_f[j].push_back(m.force_n[j]);
      }
      for (std::size_t k = 0; k < sens.torques.coordinates.size(); ++k) {
        tr_tau[k].push_back(tau[sens.torques.coordinates[k]]);
      }
    }
    const bool measured_row = (on_angle[i] && !meas_q.empty()) || (on_vel[i] && !meas_qd.empty()) ||
                              (on_torque[i] && !meas_tau.empty());
    if (!measured_row) return;
    meas_t.push_back(s.getTime());
    for (int k = 0; k < nc; ++k) meas_u[k].push_back(u[k]);
    const double t = s.getTime();
    for (std::size_t k = 0; k < meas_q.size(); ++k) {
      meas_q[k].push_back(on_angle[i]
                              ? angle_art[k].Apply(t, q[sens.angles.coordinates[k]] +
                                                          angle_noise.Sample(sens.angles.noise_std))
                              : kNaN);
    }
    for (std::size_t k = 0; k < meas_qd.size(); ++k) {
      meas_qd[k].push_back(
          on_vel[i] ? vel_art[k].Apply(t, qd[sens.velocities.coordinates[k]] +
                                              vel_noise.Sample(sens.velocities.noise_std))
                    : kNaN);
    }
    for (std::size_t k = 0; k < meas_tau.size(); ++k) {
      meas_tau[k].push_back(
          on_torque[i] ? torque_art[k].Apply(t, tau[sens.torques.coordinates[k]] +
                                                    torque_noise.Sample(sens.torques.noise_std))
                       : kNaN);
    }
  };
  result.stats = IntegrateTrial(
      model, req.integrator, effective, report, &state, observer,
      sens.torques.coordinates.empty() ? SimTK::Stage::Velocity : SimTK::Stage::Acceleration);

  // Baseline-offset removal over the initial rest window, per measured column.
  const auto remove_baseline = [&](const SensorParams& sp,
                                   std::vector<std::vector<double>>* columns) {
    if (sp.baseline_window_s <= 0.0) return;
    for (auto& col : *columns) {
      double sum = 0.0;
      int n = 0;
      for (std::size_t i = 0; i < col.size() && meas_t[i] < sp.baseline_window_s; ++i) {
        if (!std::isnan(col[i])) {
          sum += col[i];
          ++n;
        }
      }
      if (n == 0) continue;
      for (double& x : col) x -= sum / n;
    }
  };
  remove_baseline(sens.angles, &meas_q);
  remove_baseline(sens.velocities, &meas_qd);
  remove_baseline(sens.torques, &meas_tau);

  const auto& params = model.params();
  Trial& m = result.measured;
  m.time = meas_t;
  for (int k = 0; k < nc; ++k) m.AddColumn("u." + params.channels[k].name, meas_u[k]);
  for (std::size_t k = 0; k < meas_q.size(); ++k) {
    m.AddColumn("q." + names[sens.angles.coordinates[k]], meas_q[k]);
  }
  for (std::size_t k = 0; k < meas_qd.size(); ++k) {
    m.AddColumn("qd." + names[sens.velocities.coordinates[k]], meas_qd[k]);
  }
  for (std::size_t k = 0; k < meas_tau.size(); ++k) {
    m.AddColumn("tau." + names[sens.torques.coordinates[k]], meas_tau[k]);
  }
  Trial& t = result.truth;
  t.time = truth_time;
  for (int k = 0; k < nc; ++k) t.AddColumn("u." + params.channels[k].name, tr_u[k]);
  for (int c = 0; c < kNumCoordinates; ++c) t.AddColumn("q." + names[c], tr_q[c]);
  for (int c = 0; c < kNumCoordinates; ++c) t.AddColumn("qd." + names[c], tr_qd[c]);
  for (int j = 0; j < nm; ++j) t.AddColumn("a." + params.muscles[j].name, tr_a[j]);
  for (int j = 0; j < nm; ++j) t.AddColumn("f." + params.muscles[j].name, tr_f[j]);
  for (int c = 0; c < kNumCoordinates; ++c) t.AddColumn("tau_muscle." + names[c], tr_tm[c]);
  for (std::size_t k = 0; k < tr_tau.size(); ++k) {
    t.AddColumn("tau." + names[sens.torques.coordinates[k]], tr_tau[k]);
  }
  for (Trial* trial : {&m, &t}) {
    trial->metadata["trial"] = req.name;
    trial->metadata["seed"] = std::to_string(req.seed);
    trial->metadata["duration_s"] = std::to_string(req.duration_s);
  }
  if (!req.steady_state_times_s.empty()) {
    std::string list;
    for (double x : req.steady_state_times_s) {
      list += (list.empty() ? "" : " ") + std::to_string(x);
    }
    m.metadata["steady_state_times_s"] = list;
    t.metadata["steady_state_times_s"] = list;
  }
  m.metadata["record"] = "measured";
  m.metadata["angle_rate_hz"] = std::to_string(sens.angles.rate_hz);
  m.metadata["velocity_rate_hz"] = std::to_string(sens.velocities.rate_hz);
  m.metadata["torque_rate_hz"] = std::to_string(sens.torques.rate_hz);
  t.metadata["record"] = "truth";
  return result;
}

}  // namespace fesim::sim
