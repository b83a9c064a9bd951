#include "diagnosis/mechanisms/library.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "sim/upper_limb_model.h"

namespace fesim::diagnosis {

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

ModelParameter Sensed(ModelParameter p) {
  p.sensitivity = true;
  return p;
}

Eigen::VectorXd Starts(const std::vector<ModelParameter>& params) {
  Eigen::VectorXd x(params.size());
  for (std::size_t k = 0; k < params.size(); ++k) x(k) = params[k].start;
  return x;
}

Eigen::VectorXd ProbeAt(const std::vector<ModelParameter>& params, int k, double value) {
  Eigen::VectorXd x = Starts(params);
  x(k) = value;
  return x;
}

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

std::vector<int> OutputJoints(const LibraryContext& ctx) {
  std::vector<int> joints;
  joints.reserve(ctx.outputs.size());
  for (const auto& o : ctx.outputs) joints.push_back(sim::CoordinateIndex(o.substr(2)));
  return joints;
}

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

std::vector<double> RestPosture(const sim::ModelParams& m) {
  std::vector<double> rest(sim::kNumCoordinates);
  for (int c = 0; c < sim::kNumCoordinates; ++c) rest[c] = m.coordinates[c].passive.rest_angle_rad;
  return rest;
}

double JointTorqueScale(const sim::ModelParams& rig, int coordinate) {
  return std::max(rig.coordinates[coordinate].passive.stiffness_nm_per_rad, 0.05);
}

double PeriodicTorqueScale(const sim::ModelParams& rig, int coordinate, double f_hz) {
  const sim::UpperLimbModel model(rig);
  SimTK::State state = model.MakeInitialState();
  const int u = model.UIndex(coordinate);
  if (u < 0) throw std::invalid_argument("PeriodicTorqueScale: coordinate without a mobility");
  SimTK::Matrix mass;
  model.matter().calcM(state, mass);
  constexpr double kTwoPi = 6.283185307179586;
  const double omega = kTwoPi * f_hz;
  const auto& passive = rig.coordinates[coordinate].passive;
  return JointTorqueScale(rig, coordinate) + mass(u, u) * omega * omega +
         passive.damping_nms_per_rad * omega;
}

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

void PlantViaCandidate(const std::string& id, const std::string& name, double value,
                       const LibraryContext& ctx, sim::ModelParams* truth,
                       std::vector<NamedValue>* planted) {
  const sim::ModelParams nominal = *truth;
  for (const auto& c : FindMechanism(id).candidates(nominal, ctx)) {
    if (!c.joint.empty() && c.joint != "wrist_flexion") continue;
    for (const auto& p : c.params) {
      if (p.name != name) continue;
      p.set(value, truth);
      const std::string label = c.joint.empty() ? c.id : c.id + "@" + c.joint;
      planted->push_back({label + ":" + name, p.unit, value, NAN});
      return;
    }
  }
  throw std::invalid_argument("planted data: no parameter " + id + ":" + name + " on this rig");
}

std::string Fmt(const char* format, double a, double b, double c) {
  char buf[320];
  std::snprintf(buf, sizeof buf, format, a, b, c);
  return buf;
}

std::string InputLagEvidence(const OutputSignature& s) {
  return Fmt("input-residual cross-correlation peak %.2f at lag %.3f s (", s.input_lag_corr,
             s.input_lag_s) +
         s.input_lag_column + " rate)";
}

std::string PostureEvidence(const OutputSignature& s) {
  return Fmt("corr(residual, posture) %.2f", s.corr_posture);
}

std::string VelocityEvidence(const OutputSignature& s) {
  return Fmt("corr(residual, velocity) %.2f, corr(residual, sign velocity) %.2f", s.corr_velocity,
             s.corr_velocity_sign);
}

std::string UseEvidence(const OutputSignature& s) {
  return Fmt("corr(residual, cumulative stimulation) %.2f, corr(residual, time) %.2f",
             s.corr_cumulative_stimulation, s.corr_time);
}

}  // namespace fesim::diagnosis
