#include "diagnosis/candidates.h"

#include <algorithm>
#include <cmath>

#include "diagnosis/reduced_model.h"
#include "tendons/tendon_network.h"

namespace fesim::diagnosis {
namespace {

using Target = ModelParameter::Target;

ModelParameter Param(const std::string& name, const std::string& unit, double start, double lower,
                     double upper, double scale,
                     std::function<void(double, sim::ModelParams*)> set) {
  ModelParameter p;
  p.name = name;
  p.unit = unit;
  p.start = start;
  p.lower = lower;
  p.upper = upper;
  p.scale = scale;
  p.set = std::move(set);
  return p;
}

Eigen::VectorXd Starts(const std::vector<ModelParameter>& params) {
  Eigen::VectorXd x(params.size());
  for (std::size_t k = 0; k < params.size(); ++k) x(k) = params[k].start;
  return x;
}

/// Probe = start with parameter k moved to `value`.
Eigen::VectorXd ProbeAt(const std::vector<ModelParameter>& params, int k, double value) {
  Eigen::VectorXd x = Starts(params);
  x(k) = value;
  return x;
}

/// The default start_from_step: start + Σ θ_k (probe_k − start), clamped to the bounds.
void SetLinearStart(Candidate* c) {
  const std::vector<ModelParameter> params = c->params;
  const std::vector<Eigen::VectorXd> probes = c->probes;
  c->start_from_step = [params, probes](const Eigen::VectorXd& theta) {
    Eigen::VectorXd x = Starts(params);
    for (std::size_t k = 0; k < probes.size(); ++k) x += theta(k) * (probes[k] - Starts(params));
    for (std::size_t k = 0; k < params.size(); ++k) {
      x(k) = std::clamp(x(k), params[k].lower, params[k].upper);
    }
    return x;
  };
}

/// Indices of the forearm muscles whose wrist_flexion moment arm is negative (extensors) or
/// positive (flexors).
std::vector<int> WristGroup(const sim::ModelParams& m, bool extensors) {
  std::vector<int> out;
  for (std::size_t j = 0; j < m.muscles.size(); ++j) {
    for (const auto& cr : m.muscles[j].path.crossings) {
      if (cr.joint == sim::kWristFlexion && cr.arm.d_m != 0.0 && (cr.arm.d_m < 0.0) == extensors) {
        out.push_back(static_cast<int>(j));
      }
    }
  }
  return out;
}

/// κ of the broad passive-nonlinearity probe, 1/rad.
constexpr double kBroadSharpness = 5.0;

std::vector<double> RestPosture(const sim::ModelParams& m) {
  std::vector<double> rest(sim::kNumCoordinates);
  for (int c = 0; c < sim::kNumCoordinates; ++c) rest[c] = m.coordinates[c].passive.rest_angle_rad;
  return rest;
}

}  // namespace

double ForearmWeightN(const sim::ModelParams& rig) {
  const auto& g = rig.gravity_m_s2;
  return rig.segments[sim::kForearm].mass_kg * std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
}

SupportCuff ForearmSupportCuff(const sim::ModelParams& rig) {
  SupportCuff cuff;
  cuff.cuff_in_segment_m = rig.segments[sim::kForearm].com_in_body_m;
  for (std::size_t k = 0; k < rig.weight_compensation.size(); ++k) {
    if (rig.weight_compensation[k].segment == sim::kForearm) {
      cuff.index = static_cast<int>(k);
      cuff.cuff_in_segment_m = rig.weight_compensation[k].cuff_in_segment_m;
      cuff.force_n = rig.weight_compensation[k].force_n;
      break;
    }
  }
  return cuff;
}

void SetForearmSupportForce(const SupportCuff& cuff, double force_n, sim::ModelParams* m) {
  if (cuff.index >= 0) {
    m->weight_compensation[cuff.index].force_n = force_n;
    return;
  }
  for (auto& w : m->weight_compensation) {  // added by an earlier call on this copy
    if (w.segment == sim::kForearm && w.cuff_in_segment_m == cuff.cuff_in_segment_m) {
      w.force_n = force_n;
      return;
    }
  }
  m->weight_compensation.push_back({sim::kForearm, cuff.cuff_in_segment_m, force_n});
}

const std::vector<std::string>& MechanismIds() {
  static const std::vector<std::string> ids = {"fatigue",
                                               "potentiation",
                                               "delay",
                                               "tremor",
                                               "crosstalk",
                                               "moment_arm_posture",
                                               "force_length_velocity",
                                               "unequal_muscle_dynamics",
                                               "passive_stiffness_nonlinear",
                                               "arm_support",
                                               "stiction",
                                               "spasticity",
                                               "sensor_drift"};
  return ids;
}

double JointTorqueScale(const sim::ModelParams& rig, int coordinate) {
  return std::max(rig.coordinates[coordinate].passive.stiffness_nm_per_rad, 0.05);
}

std::vector<ModelParameter> SubjectParameters(const sim::ModelParams& rig,
                                              const LibraryContext& ctx) {
  std::vector<ModelParameter> out;
  // A reduced model has no joints or muscles: only the input scales at the end apply.
  const std::vector<std::string> none;
  const std::vector<std::string>& joint_outputs = ctx.reduced_model.empty() ? ctx.outputs : none;
  for (const auto& o : joint_outputs) {
    const int c = sim::CoordinateIndex(o.substr(2));
    const double k = rig.coordinates[c].passive.stiffness_nm_per_rad;
    if (!(k > 0.0)) continue;
    out.push_back(Param("k." + o.substr(2), "N*m/rad", k, 0.2 * k, 5.0 * k, k,
                        [c](double v, sim::ModelParams* m) {
                          m->coordinates[c].passive.stiffness_nm_per_rad = v;
                        }));
  }
  if (ctx.reduced_model.empty()) {  // muscle strength: F_max of every muscle × s
    std::vector<double> fmax;
    for (const auto& m : rig.muscles) fmax.push_back(m.hill.max_isometric_force_n);
    out.push_back(
        Param("strength_scale", "1", 1.0, 0.3, 3.0, 1.0, [fmax](double v, sim::ModelParams* m) {
          for (std::size_t j = 0; j < fmax.size(); ++j) {
            m->muscles[j].hill.max_isometric_force_n = v * fmax[j];
          }
        }));
  }
  for (const auto& ch : ctx.channels) {
    ModelParameter p = Param("u_scale." + ch, "1", 1.0, 0.3, 3.0, 1.0, nullptr);
    p.target = Target::kInputScale;
    p.column = "u." + ch;
    out.push_back(p);
  }
  return out;
}

std::vector<Eigen::VectorXd> SubjectStarts(const std::vector<ModelParameter>& subject,
                                           const LibraryContext& ctx) {
  Eigen::VectorXd nominal(static_cast<Eigen::Index>(subject.size()));
  for (std::size_t k = 0; k < subject.size(); ++k) {
    nominal(static_cast<Eigen::Index>(k)) = subject[k].start;
  }
  std::vector<Eigen::VectorXd> out = {nominal};
  bool arm_output = false;
  for (const auto& o : ctx.outputs)
    arm_output |= sim::CoordinateIndex(o.substr(2)) <= sim::kElbowFlexion;
  if (!ctx.reduced_model.empty() || !arm_output) return out;
  for (const double stiffness : {0.8, 1.25}) {
    for (const double strength : {0.8, 1.25}) {
      Eigen::VectorXd x = nominal;
      for (std::size_t k = 0; k < subject.size(); ++k) {
        const std::string& name = subject[k].name;
        const double f = name.rfind("k.", 0) == 0   ? stiffness
                         : name == "strength_scale" ? strength
                                                    : 1.0;
        x(static_cast<Eigen::Index>(k)) =
            std::clamp(f * subject[k].start, subject[k].lower, subject[k].upper);
      }
      out.push_back(x);
    }
  }
  return out;
}

std::vector<Candidate> CandidateLibrary(const sim::ModelParams& rig, const LibraryContext& ctx) {
  std::vector<Candidate> out;
  const std::vector<std::string>& reducible = ReducedModelMechanisms();
  auto add = [&](Candidate c) {
    if (c.label.empty()) c.label = c.joint.empty() ? c.id : c.id + "@" + c.joint;
    if (!ctx.reduced_model.empty() && c.applicable &&
        std::find(reducible.begin(), reducible.end(), c.id) == reducible.end()) {
      c.applicable = false;
      c.not_applicable_reason = "acts inside the musculoskeletal model, which the reduced model " +
                                ctx.reduced_model + " does not have (diagnose with --model full)";
    }
    if (c.applicable && !c.start_from_step) SetLinearStart(&c);
    out.push_back(std::move(c));
  };
  std::vector<int> joints;
  for (const auto& o : ctx.outputs) joints.push_back(sim::CoordinateIndex(o.substr(2)));

  {  // fatigue: rate 1/T_fat; 0 = off.
    Candidate c;
    c.id = "fatigue";
    c.params.push_back(
        Param("fatigue.rate_per_s", "1/s", 0.0, 0.0, 1.0, 0.01, [](double v, sim::ModelParams* m) {
          m->mechanisms.fatigue.enabled = v > 1e-12;
          if (v > 1e-12) m->mechanisms.fatigue.fatigue_time_s = 1.0 / v;
        }));
    c.probes = {ProbeAt(c.params, 0, 0.05)};
    c.one_sided = {true};
    add(c);
  }
  {  // potentiation: gain g (0 = off; up to 5: force × 6 when fully potentiated, above the
     // planted suite's largest g = 4) and rise time.
    Candidate c;
    c.id = "potentiation";
    c.params.push_back(
        Param("potentiation.gain", "1", 0.0, 0.0, 5.0, 0.1, [](double v, sim::ModelParams* m) {
          m->mechanisms.potentiation.enabled = v > 1e-12;
          m->mechanisms.potentiation.gain = v;
        }));
    const double rise = rig.mechanisms.potentiation.rise_time_s;
    c.params.push_back(
        Param("potentiation.rise_time_s", "s", rise, 0.5, 60.0, rise,
              [](double v, sim::ModelParams* m) { m->mechanisms.potentiation.rise_time_s = v; }));
    // At the shortest rise time p ≈ 1 within a second of any stimulation and decays over
    // T_decay = 60 s: a constant gain 1 + g on the active force, i.e. strength_scale (default
    // suite crosstalk seed 1042: rise time 0.5 s, gain 0.14, standing in for the calibration).
    c.params.back().collapses_at = 0.5;
    c.probes = {ProbeAt(c.params, 0, 0.1)};
    c.one_sided = {true};
    add(c);
  }
  {
    Candidate c;
    c.id = "delay";
    c.params.push_back(
        Param("delay.s", "s", 0.0, 0.0, 0.3, 0.02,
              [](double v, sim::ModelParams* m) { m->mechanisms.electromechanical_delay_s = v; }));
    c.probes = {ProbeAt(c.params, 0, 0.02)};
    c.one_sided = {true};
    add(c);
  }
  for (std::size_t o = 0; o < joints.size(); ++o) {  // tremor at each output joint
    const int j = joints[o];
    Candidate c;
    c.id = "tremor";
    c.joint = sim::CoordinateNames()[j];
    const double tj = JointTorqueScale(rig, j);
    const double f0 = o < ctx.tremor_frequency_hz.size() ? ctx.tremor_frequency_hz[o] : 6.0;
    c.params.push_back(Param("tremor.amplitude_nm", "N*m", 0.0, 0.0, tj, 0.05 * tj,
                             [j](double v, sim::ModelParams* m) {
                               m->mechanisms.tremor.enabled = v > 0.0;
                               m->mechanisms.tremor.coordinate = j;
                               m->mechanisms.tremor.amplitude_nm = v;
                             }));
    c.params.push_back(
        Param("tremor.phase_rad", "rad", 0.0, -10.0, 10.0, 1.0,
              [](double v, sim::ModelParams* m) { m->mechanisms.tremor.phase_rad = v; }));
    c.params.push_back(
        Param("tremor.frequency_hz", "Hz", f0, std::max(3.0, f0 - 0.15), std::min(12.0, f0 + 0.15),
              0.1, [](double v, sim::ModelParams* m) { m->mechanisms.tremor.frequency_hz = v; }));
    const double a0 = 0.01 * tj;
    Eigen::VectorXd p0 = Starts(c.params), p1 = Starts(c.params);
    p0(0) = a0;
    p1(0) = a0;
    p1(1) = 0.5 * 3.14159265358979323846;
    c.probes = {p0, p1};
    c.one_sided = {false, false};
    const std::vector<ModelParameter> params = c.params;
    c.start_from_step = [params, a0, f0](const Eigen::VectorXd& theta) {
      Eigen::VectorXd x(3);
      x << std::min(a0 * std::hypot(theta(0), theta(1)), params[0].upper),
          std::atan2(theta(1), theta(0)), f0;
      return x;
    };
    add(c);
  }
  {  // crosstalk: only meaningful with array channels
    Candidate c;
    c.id = "crosstalk";
    bool array = false;
    for (const auto& ch : rig.channels) {
      for (const auto& name : ctx.channels) array |= ch.name == name && !ch.pads.empty();
    }
    if (!array) {
      c.applicable = false;
      c.not_applicable_reason = "no stimulated channel uses the electrode array";
    } else {
      c.params.push_back(
          Param("crosstalk.fraction", "1", 0.0, 0.0, 1.0, 0.1,
                [](double v, sim::ModelParams* m) { m->mechanisms.crosstalk.fraction = v; }));
      c.probes = {ProbeAt(c.params, 0, 0.1)};
      c.one_sided = {true};
    }
    add(c);
  }
  for (int j : joints) {  // moment_arm_posture at each output joint
    Candidate c;
    c.id = "moment_arm_posture";
    c.joint = sim::CoordinateNames()[j];
    const std::vector<double> rest = RestPosture(rig);
    c.params.push_back(Param("momentarm.posture_ratio", "1", 0.0, -6.0, 6.0, 1.0,
                             [j, rest](double v, sim::ModelParams* m) {
                               for (auto& muscle : m->muscles) {
                                 const double before =
                                     tendons::MusculotendonLength(muscle.path, rest);
                                 bool changed = false;
                                 for (auto& cr : muscle.path.crossings) {
                                   if (cr.joint != j || cr.arm.d_m == 0.0) continue;
                                   cr.arm.model = tendons::MomentArmParams::Model::kLandsmeer;
                                   cr.arm.d_tilde_m += v * cr.arm.d_m;
                                   changed = true;
                                 }
                                 if (changed) {
                                   muscle.path.length_at_ref_m +=
                                       before - tendons::MusculotendonLength(muscle.path, rest);
                                 }
                               }
                             }));
    c.probes = {ProbeAt(c.params, 0, 0.5)};
    c.one_sided = {false};
    add(c);
  }
  {
    Candidate c;
    c.id = "force_length_velocity";
    std::vector<int> forearm = WristGroup(rig, true), flex = WristGroup(rig, false);
    forearm.insert(forearm.end(), flex.begin(), flex.end());
    std::vector<double> vmax;
    vmax.reserve(forearm.size());
    for (int m : forearm) vmax.push_back(rig.muscles[m].hill.max_contraction_velocity);
    c.params.push_back(Param("hill.vmax_scale", "1", 1.0, 0.05, 5.0, 1.0,
                             [forearm, vmax](double v, sim::ModelParams* m) {
                               for (std::size_t i = 0; i < forearm.size(); ++i) {
                                 m->muscles[forearm[i]].hill.max_contraction_velocity = v * vmax[i];
                               }
                             }));
    c.probes = {ProbeAt(c.params, 0, 0.5)};
    c.one_sided = {false};
    add(c);
  }
  {
    Candidate c;
    c.id = "unequal_muscle_dynamics";
    const std::vector<int> ext = WristGroup(rig, true), flex = WristGroup(rig, false);
    std::vector<double> w_ext, w_flex;
    for (int m : ext) w_ext.push_back(rig.muscles[m].activation_omega_rad_s);
    for (int m : flex) w_flex.push_back(rig.muscles[m].activation_omega_rad_s);
    c.params.push_back(Param("omega.ext_flex_ratio", "1", 1.0, 0.2, 5.0, 1.0,
                             [ext, flex, w_ext, w_flex](double v, sim::ModelParams* m) {
                               for (std::size_t i = 0; i < ext.size(); ++i) {
                                 m->muscles[ext[i]].activation_omega_rad_s = w_ext[i] * v;
                               }
                               for (std::size_t i = 0; i < flex.size(); ++i) {
                                 m->muscles[flex[i]].activation_omega_rad_s = w_flex[i] / v;
                               }
                             }));
    c.probes = {ProbeAt(c.params, 0, 1.3)};
    c.one_sided = {false};
    add(c);
  }
  for (int j : joints) {  // passive_stiffness_nonlinear
    Candidate c;
    c.id = "passive_stiffness_nonlinear";
    c.joint = sim::CoordinateNames()[j];
    const auto& pj = rig.coordinates[j].passive;
    const double kl = std::max(pj.limit_stiffness_nm_per_rad, 0.1 * JointTorqueScale(rig, j));
    c.params.push_back(Param("passive.limit_scale", "1", 1.0, 0.0, 100.0, 1.0,
                             [j, kl](double v, sim::ModelParams* m) {
                               m->coordinates[j].passive.limit_stiffness_nm_per_rad = v * kl;
                             }));
    const double kappa = pj.limit_sharpness_per_rad;
    c.params.push_back(Param("passive.sharpness_per_rad", "1/rad", kappa, 2.0, 60.0, kappa,
                             [j](double v, sim::ModelParams* m) {
                               m->coordinates[j].passive.limit_sharpness_per_rad = v;
                             }));
    // Probe 1: a broad extra nonlinearity (κ = 5/rad, K_L × 5), felt across the range of
    // motion rather than only at its ends (κ = 8/rad was not: with the wrist within ±25° its
    // torque is e^{−8·0.95} ≈ 5e-4 of K_L/κ, and a protocol that keeps the training data
    // there saw nothing); probe 2: the nominal shape made broader. The start
    // takes probe 1's shape when its coefficient is positive (the torque is linear in K_L at a
    // fixed κ), else the linear map.
    Eigen::VectorXd broad = Starts(c.params);
    broad << 5.0, kBroadSharpness;
    c.probes = {broad, ProbeAt(c.params, 1, 0.7 * kappa)};
    c.one_sided = {false, false};
    const std::vector<ModelParameter> params = c.params;
    c.start_from_step = [params, kappa](const Eigen::VectorXd& theta) {
      Eigen::VectorXd x(2);
      if (theta(0) > 0.2) {
        x << 1.0 + 4.0 * theta(0), kBroadSharpness;
      } else {
        x << 1.0 + 4.0 * theta(0), kappa - 0.3 * kappa * theta(1);
      }
      for (int k = 0; k < 2; ++k) x(k) = std::clamp(x(k), params[k].lower, params[k].upper);
      return x;
    };
    add(c);
  }
  {  // arm_support: the support lifts the forearm more (or less) than the rig says.
    Candidate c;
    c.id = "arm_support";
    bool arm_output = false;
    for (int j : joints) arm_output |= j <= sim::kElbowFlexion;
    if (!arm_output) {
      c.applicable = false;
      c.not_applicable_reason =
          "no output joint is a shoulder or elbow coordinate (the support acts there)";
    } else {
      const SupportCuff cuff = ForearmSupportCuff(rig);
      const double weight = ForearmWeightN(rig);
      c.params.push_back(
          Param("support.weight_compensation_n", "N", cuff.force_n, 0.0,
                cuff.force_n + 2.0 * weight, 0.1 * weight,
                [cuff](double v, sim::ModelParams* m) { SetForearmSupportForce(cuff, v, m); }));
      if (!rig.bands.empty()) {
        std::vector<double> k;
        for (const auto& b : rig.bands) k.push_back(b.stiffness_n_per_m);
        c.params.push_back(Param("support.band_stiffness_scale", "1", 1.0, 0.0, 5.0, 1.0,
                                 [k](double v, sim::ModelParams* m) {
                                   for (std::size_t i = 0; i < k.size(); ++i) {
                                     m->bands[i].stiffness_n_per_m = v * k[i];
                                   }
                                 }));
      }
      // The score test is local: a probe of 2 % of the forearm weight stays where the outputs
      // are linear in the force. At 10 % (twice the suite's smallest planted support) the Σr²
      // profile over the force was past its minimum (a seed-1093 elbow-rig calibration:
      // minimum near 5 %, back at the zero-force value by 10 %), and the secant pointed the
      // one-sided test the wrong way (dof 0, never fitted; docs/diagnosis.md, session 9).
      // (Probes after the parameters: each is a full vector over them.)
      c.probes = {ProbeAt(c.params, 0, cuff.force_n + 0.02 * weight)};
      c.one_sided = {cuff.force_n == 0.0};  // no support: only a lifting force can appear
      // Profile starts over the force (10–50 % of the forearm's weight on top of the rig's, in
      // steps of 10 %): the force's Σr² valley runs through the strength–stiffness trade-off,
      // which a fit from the calibration (where F_w = 0 was absorbed) does not follow (session
      // 12). Steps of 20 % missed seed 1091's valley (planted 25 %: the lowest start was 10 %
      // from the calibration, whose fit ended at 7.6 %; at 25 % from the nominal values Σr² is
      // 1.37, the truth's 0.92; session 13).
      for (const double f : {0.1, 0.2, 0.3, 0.4, 0.5}) {
        c.profile_starts.push_back(ProbeAt(c.params, 0, cuff.force_n + f * weight));
      }
      if (c.params.size() > 1) {
        c.probes.push_back(ProbeAt(c.params, 1, 1.2));
        c.one_sided.push_back(false);
      }
    }
    add(c);
  }
  for (int j : joints) {  // stiction
    Candidate c;
    c.id = "stiction";
    c.joint = sim::CoordinateNames()[j];
    const double tj = JointTorqueScale(rig, j);
    c.params.push_back(Param(
        "friction.coulomb_nm", "N*m", 0.0, 0.0, 0.5 * tj, 0.01 * tj,
        [j](double v, sim::ModelParams* m) { m->coordinates[j].passive.coulomb_friction_nm = v; }));
    c.params.push_back(Param("friction.static_excess_nm", "N*m", 0.0, 0.0, 0.5 * tj, 0.01 * tj,
                             [j](double v, sim::ModelParams* m) {
                               // F_s = F_c + excess (the Coulomb parameter is applied first:
                               // ApplyModelParameters keeps the parameter order).
                               auto& p = m->coordinates[j].passive;
                               p.static_friction_nm = p.coulomb_friction_nm + v;
                             }));
    c.probes = {ProbeAt(c.params, 0, 0.0125 * tj)};
    c.one_sided = {true};
    // The outputs switch between sticking and slipping: at the default difference step LM
    // stalled with F_s − F_c 22–42 % off on 5 of 10 default-suite datasets (seed 1106: Σr² 6.663
    // against 6.290 from the truth; session 10). A refit at step 0.05 alone left the grid
    // datasets 27–41 % off; with the scanned starts of F_s − F_c all 10 are within 8 %
    // (docs/diagnosis.md, session 11).
    c.refit_fd_steps = {0.05};
    c.refit_scan_param = 1;
    c.refit_scan_factors = {0.5, 1.5, 2.0, 3.0};
    add(c);
  }
  for (int j : joints) {  // spasticity
    Candidate c;
    c.id = "spasticity";
    c.joint = sim::CoordinateNames()[j];
    const double tj = JointTorqueScale(rig, j);
    c.params.push_back(Param("reflex.gain_nms_per_rad", "N*m*s/rad", 0.0, 0.0, 2.0 * tj, 0.05 * tj,
                             [j](double v, sim::ModelParams* m) {
                               m->coordinates[j].passive.reflex_gain_nms_per_rad = v;
                             }));
    const double vth = rig.coordinates[j].passive.reflex_threshold_rad_s;
    c.params.push_back(Param("reflex.threshold_rad_s", "rad/s", vth, 0.0, 5.0, 0.5,
                             [j](double v, sim::ModelParams* m) {
                               m->coordinates[j].passive.reflex_threshold_rad_s = v;
                             }));
    c.probes = {ProbeAt(c.params, 0, 0.05 * tj)};
    c.one_sided = {true};
    add(c);
  }
  {
    Candidate c;
    c.id = "sensor_drift";
    for (const auto& o : ctx.outputs) {
      ModelParameter p = Param("drift." + o, "rad/s", 0.0, -0.05, 0.05, 1e-3, nullptr);
      p.target = Target::kOutputDrift;
      p.column = o;
      c.params.push_back(p);
    }
    for (std::size_t k = 0; k < c.params.size(); ++k) {
      c.probes.push_back(ProbeAt(c.params, static_cast<int>(k), 1e-3));
      c.one_sided.push_back(false);
    }
    add(c);
  }
  return out;
}

}  // namespace fesim::diagnosis
