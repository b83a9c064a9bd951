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

/// Baseline-offset removal over the initial rest window [0, sp.baseline_window_s) of the
/// measured times `time`: each column less the mean of its valid samples there.
void RemoveBaseline(const SensorParams& sp, const std::vector<double>& time,
                    std::vector<std::vector<double>>* columns) {
  if (sp.baseline_window_s <= 0.0) return;
  for (auto& col : *columns) {
    double sum = 0.0;
    int n = 0;
    for (std::size_t i = 0; i < col.size() && time[i] < sp.baseline_window_s; ++i) {
      if (!std::isnan(col[i])) {
        sum += col[i];
        ++n;
      }
    }
    if (n == 0) continue;
    for (double& x : col) x -= sum / n;
  }
}

/// The columns of the measured record, filled row by row: time, commanded u, and the angle,
/// velocity and torque sensors' columns (NaN where a row is not on the sensor's grid).
struct MeasuredColumns {
  std::vector<double> time;
  std::vector<std::vector<double>> u, q, qd, tau;
};

/// The columns of the noiseless truth record: u, every coordinate's q, q̇ and muscle torque,
/// every muscle's activation and force, the torque sensors' coordinates.
struct TruthColumns {
  std::vector<double> time;
  std::vector<std::vector<double>> u, q, qd, a, f, tau_muscle, tau;
};

/// The measured trial record from its columns (column names from the model and the sensors).
Trial MeasuredRecord(const MeasuredColumns& c, const ModelParams& params, const SensorSuite& sens) {
  const auto& names = CoordinateNames();
  Trial m;
  m.time = c.time;
  for (std::size_t k = 0; k < c.u.size(); ++k) m.AddColumn("u." + params.channels[k].name, c.u[k]);
  for (std::size_t k = 0; k < c.q.size(); ++k) {
    m.AddColumn("q." + names[sens.angles.coordinates[k]], c.q[k]);
  }
  for (std::size_t k = 0; k < c.qd.size(); ++k) {
    m.AddColumn("qd." + names[sens.velocities.coordinates[k]], c.qd[k]);
  }
  for (std::size_t k = 0; k < c.tau.size(); ++k) {
    m.AddColumn("tau." + names[sens.torques.coordinates[k]], c.tau[k]);
  }
  return m;
}

/// The truth trial record from its columns.
Trial TruthRecord(const TruthColumns& c, const ModelParams& params, const SensorSuite& sens) {
  const auto& names = CoordinateNames();
  Trial t;
  t.time = c.time;
  for (std::size_t k = 0; k < c.u.size(); ++k) t.AddColumn("u." + params.channels[k].name, c.u[k]);
  for (int i = 0; i < kNumCoordinates; ++i) t.AddColumn("q." + names[i], c.q[i]);
  for (int i = 0; i < kNumCoordinates; ++i) t.AddColumn("qd." + names[i], c.qd[i]);
  for (std::size_t j = 0; j < c.a.size(); ++j) t.AddColumn("a." + params.muscles[j].name, c.a[j]);
  for (std::size_t j = 0; j < c.f.size(); ++j) t.AddColumn("f." + params.muscles[j].name, c.f[j]);
  for (int i = 0; i < kNumCoordinates; ++i) t.AddColumn("tau_muscle." + names[i], c.tau_muscle[i]);
  for (std::size_t k = 0; k < c.tau.size(); ++k) {
    t.AddColumn("tau." + names[sens.torques.coordinates[k]], c.tau[k]);
  }
  return t;
}

/// The metadata lines of both records: trial name, seed, duration, steady-state times; the
/// sensor rates on the measured one.
void SetMetadata(const TrialRequest& req, Trial* m, Trial* t) {
  const SensorSuite& sens = req.sensors;
  for (Trial* trial : {m, t}) {
    trial->metadata["trial"] = req.name;
    trial->metadata["seed"] = std::to_string(req.seed);
    trial->metadata["duration_s"] = std::to_string(req.duration_s);
  }
  if (!req.steady_state_times_s.empty()) {
    std::string list;
    for (double x : req.steady_state_times_s) {
      list += (list.empty() ? "" : " ") + std::to_string(x);
    }
    m->metadata["steady_state_times_s"] = list;
    t->metadata["steady_state_times_s"] = list;
  }
  m->metadata["record"] = "measured";
  m->metadata["angle_rate_hz"] = std::to_string(sens.angles.rate_hz);
  m->metadata["velocity_rate_hz"] = std::to_string(sens.velocities.rate_hz);
  m->metadata["torque_rate_hz"] = std::to_string(sens.torques.rate_hz);
  t->metadata["record"] = "truth";
}

}  // namespace

StimulationSchedule MuscleStimulation(const ModelParams& model,
                                      const StimulationSchedule& commanded) {
  StimulationSchedule delayed = commanded;
  for (double& t : delayed.times) t += model.mechanisms.electromechanical_delay_s;
  return delayed;
}

TrialResult RunTrial(const UpperLimbModel& model, const TrialRequest& req,
                     const std::function<void(double)>& progress) {
  if (!(req.duration_s > 0.0)) throw std::invalid_argument("trial duration must be > 0");
  const SensorSuite& sens = req.sensors;
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
  MeasuredColumns meas;
  meas.u.resize(nc);
  meas.q.resize(sens.angles.coordinates.size());
  meas.qd.resize(sens.velocities.coordinates.size());
  meas.tau.resize(sens.torques.coordinates.size());
  TruthColumns tr;
  tr.u.resize(nc);
  tr.q.resize(kNumCoordinates);
  tr.qd.resize(kNumCoordinates);
  tr.a.resize(nm);
  tr.f.resize(nm);
  tr.tau_muscle.resize(kNumCoordinates);
  tr.tau.resize(sens.torques.coordinates.size());
  GaussianNoise angle_noise(DeriveSeed(req.seed, 1)), vel_noise(DeriveSeed(req.seed, 2)),
      torque_noise(DeriveSeed(req.seed, 3));
  std::vector<Artefacts> angle_art, vel_art, torque_art;
  std::uint64_t stream = 100;
  for (std::size_t k = 0; k < meas.q.size(); ++k) {
    angle_art.emplace_back(sens.angles, DeriveSeed(req.seed, stream++));
  }
  for (std::size_t k = 0; k < meas.qd.size(); ++k) {
    vel_art.emplace_back(sens.velocities, DeriveSeed(req.seed, stream++));
  }
  for (std::size_t k = 0; k < meas.tau.size(); ++k) {
    torque_art.emplace_back(sens.torques, DeriveSeed(req.seed, stream++));
  }
  // Electromechanical delay: the muscles see the stimulation δ late; the trial records what was
  // commanded (clipped to the stimulator's 0–300 µs, as the model clips it).
  const StimulationSchedule effective = MuscleStimulation(model.params(), req.stimulation);
  const auto commanded = [&](double t) {
    std::vector<double> u = req.stimulation.At(t, nc);
    for (double& x : u) x = std::clamp(x, 0.0, 300.0);
    return u;
  };

  std::size_t row = 0;
  SimTK::State state = model.MakeInitialState();
  // One report row at time t: the angles q, speeds qd, sensor torques tau (when a torque sensor
  // needs them) and the muscles (computed only on truth rows).
  const auto record = [&](double t, const std::vector<double>& q, const std::vector<double>& qd,
                          const std::vector<double>& tau, const auto& muscles) {
    const std::size_t i = row++;
    if (progress && (i % 256 == 0 || i + 1 == report.size())) progress(t / req.duration_s);
    const std::vector<double> u = commanded(t);
    if (on_truth[i]) {
      const MuscleSnapshot& m = muscles();
      result.fibre_clamped = result.fibre_clamped || m.any_clamped;
      tr.time.push_back(t);
      for (int k = 0; k < nc; ++k) tr.u[k].push_back(u[k]);
      for (int c = 0; c < kNumCoordinates; ++c) {
        tr.q[c].push_back(q[c]);
        tr.qd[c].push_back(qd[c]);
        tr.tau_muscle[c].push_back(m.joint_torque_nm[c]);
      }
      for (int j = 0; j < nm; ++j) {
        tr.a[j].push_back(m.activation[j]);
        tr.f[j].push_back(m.force_n[j]);
      }
      for (std::size_t k = 0; k < sens.torques.coordinates.size(); ++k) {
        tr.tau[k].push_back(tau[sens.torques.coordinates[k]]);
      }
    }
    const bool measured_row = (on_angle[i] && !meas.q.empty()) || (on_vel[i] && !meas.qd.empty()) ||
                              (on_torque[i] && !meas.tau.empty());
    if (!measured_row) return;
    meas.time.push_back(t);
    for (int k = 0; k < nc; ++k) meas.u[k].push_back(u[k]);
    for (std::size_t k = 0; k < meas.q.size(); ++k) {
      meas.q[k].push_back(on_angle[i]
                              ? angle_art[k].Apply(t, q[sens.angles.coordinates[k]] +
                                                          angle_noise.Sample(sens.angles.noise_std))
                              : kNaN);
    }
    for (std::size_t k = 0; k < meas.qd.size(); ++k) {
      meas.qd[k].push_back(
          on_vel[i] ? vel_art[k].Apply(t, qd[sens.velocities.coordinates[k]] +
                                              vel_noise.Sample(sens.velocities.noise_std))
                    : kNaN);
    }
    for (std::size_t k = 0; k < meas.tau.size(); ++k) {
      meas.tau[k].push_back(
          on_torque[i] ? torque_art[k].Apply(t, tau[sens.torques.coordinates[k]] +
                                                    torque_noise.Sample(sens.torques.noise_std))
                       : kNaN);
    }
  };
  if (sens.torques.coordinates.empty()) {
    // The rows read only state variables (q, u, activations: ComputeMuscles), so they are read
    // from the integrator's own vector, never written into the state.
    RhsWorkspace muscles_ws;  // the truth rows' muscles, its vectors reused row to row
    result.stats = IntegrateTrialVariables(
        model, req.integrator, effective, report, &state, [&](double t, const double* y) {
          record(t, model.GetQs(state, y), model.GetUs(state, y), {},
                 [&]() -> const MuscleSnapshot& {
                   return model.ComputeMuscles(state, y, &muscles_ws);
                 });
        });
  } else {
    // A torque sensor needs the motion forces: the state realised to Stage::Acceleration.
    result.stats = IntegrateTrial(
        model, req.integrator, effective, report, &state,
        [&](const SimTK::State& s) {
          const std::size_t i = row;
          const bool need_torque = on_torque[i] || on_truth[i];
          record(s.getTime(), model.GetQs(s), model.GetUs(s),
                 need_torque ? model.SensorTorques(s) : std::vector<double>(),
                 [&] { return model.ComputeMuscles(s); });
        },
        SimTK::Stage::Acceleration);
  }

  // Baseline-offset removal over the initial rest window, per measured column.
  RemoveBaseline(sens.angles, meas.time, &meas.q);
  RemoveBaseline(sens.velocities, meas.time, &meas.qd);
  RemoveBaseline(sens.torques, meas.time, &meas.tau);
  result.measured = MeasuredRecord(meas, model.params(), sens);
  result.truth = TruthRecord(tr, model.params(), sens);
  SetMetadata(req, &result.measured, &result.truth);
  return result;
}

}  // namespace fesim::sim
