#include "foreign/plant.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "foreign/check.h"
#include "foreign/integrator.h"
#include "foreign/joint.h"
#include "foreign/muscle.h"
#include "foreign/random.h"

namespace fesim::foreign {
namespace {

constexpr double kEquilibriumTolRadS2 = 1e-10;  // |q̈| at the passive equilibrium
constexpr double kEquilibriumFdStepRad = 1e-6;  // central-difference step of its Jacobian
constexpr double kEquilibriumMaxStepRad = 0.2;  // Newton step limit
constexpr int kEquilibriumMaxIterations = 100;
constexpr double kTimeMergeTolS = 1e-9;  // breakpoints closer than this are one

/// Everything the right-hand side derives from the state before the effects' hooks.
struct MuscleKinematics {
  std::array<Eigen::Vector3d, kNumMuscles> arms;  // ρ_m, m
  MuscleArray fibre_length_m{};
  MuscleArray lengthening_velocity_m_s{};
};

MuscleKinematics Kinematics(const Person& p, const Eigen::Vector3d& q, const Eigen::Vector3d& qd) {
  MuscleKinematics k;
  for (int m = 0; m < kNumMuscles; ++m) {
    const MuscleParams& mu = p.muscles[m];
    k.arms[m] = GeneralisedMomentArms(mu, q, p.body.dip_pip_ratio);
    k.fibre_length_m[m] =
        MusculotendonLength(mu, q, p.body.dip_pip_ratio) - mu.contraction.tendon_slack_length_m;
    k.lengthening_velocity_m_s[m] = -k.arms[m].dot(qd);
  }
  return k;
}

}  // namespace

Plant MakePlant(const Person& person, const std::vector<PlantedEffect>& effects, double duration_s,
                std::uint64_t seed) {
  ValidatePerson(person);
  CheckAbove(duration_s, 0.0, 1e6, "duration_s");
  Plant plant;
  plant.person = person;
  for (const PlantedEffect& e : effects) {
    EffectSetup setup{duration_s, DeriveSeed(seed, "effect:" + e.id),
                      DeriveSeed(person.seed, "effect:" + e.id)};
    std::shared_ptr<const EffectModel> model = MakeEffect(e, setup);
    model->ModifyPerson(&plant.person);
    plant.effect_offsets.push_back(plant.state_size);
    plant.state_size += model->NumStates();
    plant.stimulation_delay_s += model->StimulationDelay_s();
    plant.effects.push_back(std::move(model));
  }
  ValidatePerson(plant.person);
  plant.chain = Coefficients(plant.person.body);
  return plant;
}

Eigen::VectorXd RestState(const Plant& plant, const Eigen::Vector3d& q) {
  Eigen::VectorXd x = Eigen::VectorXd::Zero(plant.state_size);
  x.segment<3>(kStateQ) = q;
  for (std::size_t i = 0; i < plant.effects.size(); ++i) {
    plant.effects[i]->InitialState(x.data() + plant.effect_offsets[i]);
  }
  return x;
}

void PlantDerivatives(const Plant& plant, double t_s, const ChannelValues& u_us, const double* x,
                      double* dx, const RhsOptions& options) {
  const Person& p = plant.person;
  const Eigen::Map<const Eigen::Vector3d> q(x + kStateQ), qd(x + kStateQd);
  const MuscleKinematics kin = Kinematics(p, q, qd);
  EffectContext ctx;
  ctx.t_s = t_s;
  ctx.q_rad = q;
  ctx.qd_rad_s = qd;
  ctx.person = &p;
  ctx.lengthening_velocity_m_s = kin.lengthening_velocity_m_s;
  MuscleArray drive{}, capacity{};
  for (int m = 0; m < kNumMuscles; ++m) {
    double v_us = 0.0;
    for (int c = 0; c < kNumChannels; ++c) v_us += p.placement[m][c] * u_us[c];
    ctx.recruitment[m] = Recruitment(p.muscles[m].recruitment, v_us);
    ctx.coupling[m] = x[kStateCoupling + m];
    ctx.activation[m] = x[kStateActivation + m];
    drive[m] = ctx.recruitment[m];
    capacity[m] = 1.0;
  }
  const std::size_t n_eff = plant.effects.size();
  for (std::size_t i = 0; i < n_eff; ++i) {
    const double* xe = x + plant.effect_offsets[i];
    plant.effects[i]->AddDrive(ctx, xe, &drive);
    plant.effects[i]->ScaleCapacity(ctx, xe, &capacity);
  }
  Eigen::Vector3d tau = Eigen::Vector3d::Zero();
  for (int m = 0; m < kNumMuscles; ++m) {
    const ActivationParams& a = p.muscles[m].activation;
    const double d = std::clamp(drive[m], 0.0, 1.0);
    dx[kStateCoupling + m] = FirstOrderRate(d, ctx.coupling[m], a.coupling_activation_tau_s,
                                            a.coupling_deactivation_tau_s);
    dx[kStateActivation + m] = FirstOrderRate(ctx.coupling[m], ctx.activation[m],
                                              a.force_activation_tau_s, a.force_deactivation_tau_s);
    const double force =
        MuscleForce(p.muscles[m].contraction, std::clamp(ctx.activation[m], 0.0, 1.0), capacity[m],
                    kin.fibre_length_m[m], kin.lengthening_velocity_m_s[m]);
    tau += kin.arms[m] * force;
  }
  for (int j = 0; j < kNumJoints; ++j) {
    tau[j] += ElasticMoment(p.joints[j], q[j]) + DampingMoment(p.joints[j], qd[j]);
  }
  for (std::size_t i = 0; i < n_eff; ++i) {
    plant.effects[i]->AddJointTorque(ctx, x + plant.effect_offsets[i], &tau);
  }
  const EquationTerms eq = EvaluateEquations(plant.chain, p.gravity, q, qd);
  Eigen::Vector3d net = tau - eq.coriolis - eq.gravity;
  const Eigen::LLT<Eigen::Matrix3d> llt(eq.mass);
  if (options.friction && n_eff > 0) {
    const Eigen::Matrix3d m_inv = llt.solve(Eigen::Matrix3d::Identity());
    Eigen::Vector3d friction = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < n_eff; ++i) {
      plant.effects[i]->AddFrictionTorque(ctx, m_inv, net, &friction);
    }
    net += friction;
  }
  const Eigen::Vector3d qdd = llt.solve(net);
  for (int j = 0; j < kNumJoints; ++j) {
    dx[kStateQ + j] = qd[j];
    dx[kStateQd + j] = qdd[j];
  }
  for (std::size_t i = 0; i < n_eff; ++i) {
    const int off = plant.effect_offsets[i];
    plant.effects[i]->StateDerivative(ctx, x + off, dx + off);
  }
}

Eigen::Vector3d PassiveEquilibrium(const Plant& plant) {
  Eigen::VectorXd x = RestState(plant, Eigen::Vector3d::Zero());
  Eigen::VectorXd dx(plant.state_size);
  const RhsOptions no_friction{false};
  const ChannelValues zero{0.0, 0.0};
  auto accel = [&](const Eigen::Vector3d& q) {
    x.segment<3>(kStateQ) = q;
    PlantDerivatives(plant, 0.0, zero, x.data(), dx.data(), no_friction);
    return Eigen::Vector3d(dx.segment<3>(kStateQd));
  };
  Eigen::Vector3d q;
  for (int j = 0; j < kNumJoints; ++j) q[j] = plant.person.joints[j].rest_angle_rad;
  for (int it = 0; it < kEquilibriumMaxIterations; ++it) {
    const Eigen::Vector3d r = accel(q);
    if (r.norm() < kEquilibriumTolRadS2) return q;
    Eigen::Matrix3d jac;
    for (int j = 0; j < kNumJoints; ++j) {
      Eigen::Vector3d dq = Eigen::Vector3d::Zero();
      dq[j] = kEquilibriumFdStepRad;
      jac.col(j) = (accel(q + dq) - accel(q - dq)) / (2.0 * kEquilibriumFdStepRad);
    }
    Eigen::Vector3d step = -jac.partialPivLu().solve(r);
    const double norm = step.cwiseAbs().maxCoeff();
    if (norm > kEquilibriumMaxStepRad) step *= kEquilibriumMaxStepRad / norm;
    q += step;
  }
  throw std::runtime_error("foreign: passive equilibrium did not converge");
}

double StiffnessEstimate(const Plant& plant, const double* x, const ChannelValues& u_us) {
  const Person& p = plant.person;
  const Eigen::Map<const Eigen::Vector3d> q(x + kStateQ);
  double drive_bound = 0.0, capacity_bound = 1.0;
  Eigen::Vector3d damping = Eigen::Vector3d::Zero(), stiffness = Eigen::Vector3d::Zero();
  for (const auto& e : plant.effects) {
    drive_bound += e->DriveBound();
    capacity_bound *= e->CapacityBound();
    damping += e->DampingBound(p, q);
    stiffness += e->StiffnessBound(p, q);
  }
  Eigen::Matrix3d b = Eigen::Matrix3d::Zero(), k = Eigen::Matrix3d::Zero();
  for (int j = 0; j < kNumJoints; ++j) {
    b(j, j) = p.joints[j].damping_nm_s_per_rad + damping[j];
    k(j, j) = ElasticStiffness(p.joints[j], q[j]) + stiffness[j];
  }
  const MuscleKinematics kin = Kinematics(p, q, Eigen::Vector3d::Zero());
  for (int m = 0; m < kNumMuscles; ++m) {
    const ContractionParams& c = p.muscles[m].contraction;
    double v_us = 0.0;
    for (int ch = 0; ch < kNumChannels; ++ch) v_us += p.placement[m][ch] * u_us[ch];
    const double reach = std::max({x[kStateCoupling + m], x[kStateActivation + m],
                                   Recruitment(p.muscles[m].recruitment, v_us)});
    const double a = std::min(1.0, reach + drive_bound);
    const double active = c.max_force_n * a * capacity_bound;
    const double lt = kin.fibre_length_m[m] / c.optimal_fibre_length_m;
    b += kin.arms[m] * kin.arms[m].transpose() *
         (active * ForceVelocityMaxSlope(c.hill_curvature) /
          (c.max_velocity_lopt_per_s * c.optimal_fibre_length_m));
    const double fl_slope = 2.0 * std::abs(lt - 1.0) / (c.fl_width * c.fl_width);
    const double fpe_slope = 2.0 * c.passive_coefficient * std::max(0.0, lt - 1.0);
    k += kin.arms[m] * kin.arms[m].transpose() *
         (c.max_force_n * fpe_slope + active * c.eccentric_plateau * fl_slope) /
         c.optimal_fibre_length_m;
  }
  const Eigen::Matrix3d mass =
      EvaluateEquations(plant.chain, p.gravity, q, Eigen::Vector3d::Zero()).mass;
  const Eigen::LLT<Eigen::Matrix3d> llt(mass);
  return llt.solve(b).trace() + std::sqrt(std::max(0.0, llt.solve(k).trace()));
}

ChannelValues StimulationSchedule::At(double t_s) const {
  const auto it = std::upper_bound(times_s.begin(), times_s.end(), t_s);
  if (it == times_s.begin()) return values_us.front();
  return values_us[static_cast<std::size_t>(it - times_s.begin()) - 1];
}

StimulationSchedule MakeSchedule(const protocols::StimulationProgram& program, double delay_s) {
  const auto& ch = program.channels;
  int ext = -1, flex = -1;
  for (std::size_t c = 0; c < ch.size(); ++c) {
    if (ch[c] == kChannelNames[kExtChannel] && ext < 0) ext = static_cast<int>(c);
    if (ch[c] == kChannelNames[kFlexChannel] && flex < 0) flex = static_cast<int>(c);
  }
  if (ch.size() != 2 || ext < 0 || flex < 0) {
    throw std::invalid_argument("foreign: program.channels must be exactly \"ext\" and \"flex\"");
  }
  if (program.times_s.empty() || program.times_s.size() != program.values_us.size()) {
    throw std::invalid_argument("foreign: program.times_s and values_us: equal, nonzero sizes");
  }
  CheckRange(delay_s, 0.0, 10.0, "stimulation delay_s");
  StimulationSchedule s;
  s.duration_s = program.duration_s;
  for (std::size_t k = 0; k < program.times_s.size(); ++k) {
    const double t = program.times_s[k];
    if (program.values_us[k].size() != 2) {
      throw std::invalid_argument("foreign: program.values_us[k] must hold 2 values");
    }
    CheckRange(t, k == 0 ? 0.0 : std::nextafter(program.times_s[k - 1], 1e300), 1e6,
               "program.times_s[" + std::to_string(k) + "]");
    const ChannelValues v{program.values_us[k][ext], program.values_us[k][flex]};
    for (double u : v) CheckRange(u, 0.0, protocols::kMaxPulseWidthUs, "program.values_us");
    if (k == 0) {
      // Before its first time a program holds its first value (protocols::ValueAt); a delayed
      // one reaches the muscles only after the delay.
      s.times_s.push_back(0.0);
      s.values_us.push_back(delay_s > 0.0 ? ChannelValues{0.0, 0.0} : v);
      if (delay_s > 0.0) {
        s.times_s.push_back(delay_s);
        s.values_us.push_back(v);
      }
    } else {
      s.times_s.push_back(t + delay_s);
      s.values_us.push_back(v);
    }
  }
  CheckAbove(program.duration_s, program.times_s.back(), 1e6, "program.duration_s");
  return s;
}

std::vector<Eigen::VectorXd> IntegratePlant(const Plant& plant, const StimulationSchedule& schedule,
                                            const Eigen::VectorXd& x0,
                                            const std::vector<double>& sample_times_s,
                                            const IntegrationSpec& spec) {
  CheckAbove(spec.max_step_s, 0.0, 0.01, "integration.max_step_s");
  CheckAbove(spec.stability_factor, 0.0, 2.7, "integration.stability_factor");
  if (x0.size() != plant.state_size) throw std::invalid_argument("foreign: x0 has the wrong size");
  // Breakpoints: 0, switching instants inside (0, duration), samples, duration.
  std::vector<double> events = {0.0, schedule.duration_s};
  for (double t : schedule.times_s) {
    if (t > 0.0 && t < schedule.duration_s) events.push_back(t);
  }
  for (double t : sample_times_s) {
    CheckRange(t, 0.0, schedule.duration_s, "sample time");
    events.push_back(t);
  }
  std::sort(events.begin(), events.end());
  std::vector<double> merged;
  for (double t : events) {
    if (merged.empty() || t - merged.back() > kTimeMergeTolS) merged.push_back(t);
  }
  std::vector<Eigen::VectorXd> out;
  out.reserve(sample_times_s.size());
  Eigen::VectorXd x = x0;
  Rk4 rk4(plant.state_size);
  std::size_t next_sample = 0;
  auto record = [&](double t) {
    while (next_sample < sample_times_s.size() &&
           std::abs(sample_times_s[next_sample] - t) <= kTimeMergeTolS) {
      out.push_back(x);
      ++next_sample;
    }
  };
  record(0.0);
  for (std::size_t i = 0; i + 1 < merged.size(); ++i) {
    const double ta = merged[i], tb = merged[i + 1];
    const ChannelValues u = schedule.At(0.5 * (ta + tb));
    const OdeFunction f = [&](double t, const double* xs, double* dxs) {
      PlantDerivatives(plant, t, u, xs, dxs);
    };
    const double lambda = StiffnessEstimate(plant, x.data(), u);
    const double h = std::min(spec.max_step_s, spec.stability_factor / std::max(lambda, 1e-12));
    rk4.Integrate(f, ta, tb, h, x.data());
    if (!x.allFinite()) {
      std::ostringstream msg;
      msg << "foreign: integration diverged at t = " << tb << " s";
      throw std::runtime_error(msg.str());
    }
    record(tb);
  }
  if (out.size() != sample_times_s.size()) {
    throw std::invalid_argument("foreign: sample times must be increasing inside the trial");
  }
  return out;
}

}  // namespace fesim::foreign
