#include "diagnosis/person.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include "base/parallel.h"
#include "diagnosis/mechanisms/library.h"
#include "tendons/tendon_network.h"

namespace fesim::diagnosis {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;
/// A muscle belongs to a channel's group when A reaches it with this share of the channel's
/// largest entry (eq. 1).
constexpr double kReachedShare = 0.02;
/// Posterior half-width over prior half-width above which a fitted parameter is reported as
/// prior-dominated.
constexpr double kPriorDominated = 0.7;
/// 1σ factors of the log-normal priors of strengths, recruitment steepness, stiffness and damping
/// (a person × 2 or × ½ is one σ: the spread of the planted and foreign persons) and of the
/// recruitment shape γ.
constexpr double kPriorFactor = 2.0, kShapePriorFactor = 3.0;
/// 1σ of the prior of the passive cubic stiffness k₃, × k per rad²: at 0.5 rad from rest the
/// cubic moment is then ±0.5 × the linear one — the mid-range stiffening of a normal passive
/// curve (passive_stiffness_nonlinear is a stiffening beyond that).
constexpr double kCubicPriorPerRad2 = 2.0;

struct MuscleGroup {
  std::string name;
  std::vector<int> muscles;
  std::vector<int> joints;  ///< output joints its muscles cross, proximal first.
};

bool IsFingerJoint(int c) {
  return c == sim::kMcpFlexion || c == sim::kPipFlexion || c == sim::kDipFlexion;
}

/// The groups of the stimulated channels' muscles (see person.h).
std::vector<MuscleGroup> MuscleGroups(const sim::ModelParams& rig, const LibraryContext& ctx) {
  const muscles::ArrayMatrix a = sim::BuildElectrodeMatrix(rig);
  std::vector<int> channels;
  for (const auto& name : ctx.channels) {
    for (std::size_t k = 0; k < rig.channels.size(); ++k) {
      if (rig.channels[k].name == name) channels.push_back(static_cast<int>(k));
    }
  }
  std::map<int, double> largest;
  for (int k : channels) {
    for (int j = 0; j < a.muscles; ++j) largest[k] = std::max(largest[k], a(j, k));
  }
  const std::vector<int> outputs = OutputJoints(ctx);
  std::vector<MuscleGroup> groups;
  for (int j = 0; j < a.muscles; ++j) {
    int best = -1;
    for (int k : channels) {
      if (largest[k] > 0.0 && a(j, k) >= kReachedShare * largest[k] &&
          (best < 0 || a(j, k) > a(j, best))) {
        best = k;
      }
    }
    if (best < 0) continue;
    bool finger = false;
    std::vector<int> crossed;
    for (int c : outputs) {
      for (const auto& cr : rig.muscles[j].path.crossings) {
        if (cr.joint == c && cr.arm.d_m != 0.0) {
          crossed.push_back(c);
          finger |= IsFingerJoint(c);
        }
      }
    }
    if (crossed.empty()) continue;  // moves no output joint
    const std::string name = rig.channels[best].name + (finger ? ".finger" : "");
    auto it = std::find_if(groups.begin(), groups.end(),
                           [&](const MuscleGroup& g) { return g.name == name; });
    if (it == groups.end()) {
      groups.push_back({name, {}, {}});
      it = groups.end() - 1;
    }
    it->muscles.push_back(j);
    for (int c : crossed) {
      if (std::find(it->joints.begin(), it->joints.end(), c) == it->joints.end()) {
        it->joints.push_back(c);
      }
    }
  }
  for (auto& g : groups) std::sort(g.joints.begin(), g.joints.end());
  return groups;
}

/// `p` with a Gaussian prior of 1σ `width` (its unit) around its start.
ModelParameter WithPrior(ModelParameter p, double width, bool sensitivity) {
  p.prior_width = width;
  p.sensitivity = sensitivity;
  return p;
}

/// `p` with a log-normal prior: ln(x / start) of 1σ ln(factor).
ModelParameter WithLogPrior(ModelParameter p, double factor, bool sensitivity) {
  p.prior_width = std::log(factor);
  p.log_prior = true;
  p.sensitivity = sensitivity;
  return p;
}

void AddGroupParameters(const sim::ModelParams& rig, const MuscleGroup& g,
                        std::vector<ModelParameter>* out) {
  std::vector<double> fmax, beta, gamma;
  for (int j : g.muscles) {
    fmax.push_back(rig.muscles[j].hill.max_isometric_force_n);
    beta.push_back(rig.muscles[j].recruitment.beta_per_us);
    gamma.push_back(rig.muscles[j].recruitment.gamma);
  }
  const std::vector<int> ms = g.muscles;
  out->push_back(WithLogPrior(Param("strength." + g.name, "1", 1.0, 0.01, 20.0, 1.0,
                                    [ms, fmax](double v, sim::ModelParams* m) {
                                      for (std::size_t i = 0; i < ms.size(); ++i) {
                                        m->muscles[ms[i]].hill.max_isometric_force_n = v * fmax[i];
                                      }
                                    }),
                              kPriorFactor, true));
  out->push_back(WithLogPrior(Param("beta." + g.name, "1", 1.0, 0.1, 10.0, 1.0,
                                    [ms, beta](double v, sim::ModelParams* m) {
                                      for (std::size_t i = 0; i < ms.size(); ++i) {
                                        m->muscles[ms[i]].recruitment.beta_per_us = v * beta[i];
                                      }
                                    }),
                              kPriorFactor, true));
  out->push_back(WithLogPrior(Param("gamma." + g.name, "1", 1.0, 1e-3, 1e4, 1.0,
                                    [ms, gamma](double v, sim::ModelParams* m) {
                                      for (std::size_t i = 0; i < ms.size(); ++i) {
                                        m->muscles[ms[i]].recruitment.gamma = v * gamma[i];
                                      }
                                    }),
                              kShapePriorFactor, true));
}

void AddJointParameters(const sim::ModelParams& rig, int c, std::vector<ModelParameter>* out) {
  const std::string joint = sim::CoordinateNames()[c];
  // A function of the joint's angle names it (ModelParameter::joint); the damping, of its speed,
  // does not.
  const auto of_angle = [&joint](ModelParameter p) {
    p.joint = joint;
    return p;
  };
  const auto& pj = rig.coordinates[c].passive;
  const double k = pj.stiffness_nm_per_rad, b = pj.damping_nms_per_rad, q0 = pj.rest_angle_rad;
  if (k > 0.0) {
    out->push_back(of_angle(WithLogPrior(Param("k." + joint, "N*m/rad", k, 0.1 * k, 10.0 * k, k,
                                               [c](double v, sim::ModelParams* m) {
                                                 m->coordinates[c].passive.stiffness_nm_per_rad = v;
                                               }),
                                         kPriorFactor, true)));
  }
  if (b > 0.0) {
    out->push_back(WithLogPrior(Param("b." + joint, "N*m*s/rad", b, 0.01 * b, 20.0 * b, b,
                                      [c](double v, sim::ModelParams* m) {
                                        m->coordinates[c].passive.damping_nms_per_rad = v;
                                      }),
                                kPriorFactor, true));
  }
  if (k > 0.0) {  // normal mid-range curvature of the passive curve (sim/passive_joint.h)
    // Softening k₃ ≥ −k/2 keeps the passive stiffness k + 3k₃d² positive within ±0.8 rad.
    out->push_back(
        of_angle(WithPrior(Param("k3." + joint, "N*m/rad^3", 0.0, -0.5 * k, 20.0 * k, k,
                                 [c](double v, sim::ModelParams* m) {
                                   m->coordinates[c].passive.cubic_stiffness_nm_per_rad3 = v;
                                 }),
                           kCubicPriorPerRad2 * k, true)));
  }
  out->push_back(of_angle(WithPrior(
      Param("rest." + joint, "rad", q0, q0 - 0.6, q0 + 0.6, 10.0 * kDeg,
            [c](double v, sim::ModelParams* m) { m->coordinates[c].passive.rest_angle_rad = v; }),
      10.0 * kDeg, true)));
}

ModelParameter OmegaScale(const sim::ModelParams& rig, const std::vector<MuscleGroup>& groups) {
  std::vector<int> ms;
  std::vector<double> omega;
  for (const auto& g : groups) {
    for (int j : g.muscles) {
      ms.push_back(j);
      omega.push_back(rig.muscles[j].activation_omega_rad_s);
    }
  }
  return WithLogPrior(Param("omega_scale", "1", 1.0, 0.3, 3.0, 1.0,
                            [ms, omega](double v, sim::ModelParams* m) {
                              for (std::size_t i = 0; i < ms.size(); ++i) {
                                m->muscles[ms[i]].activation_omega_rad_s = v * omega[i];
                              }
                            }),
                      1.35, false);  // differences: docs/diagnosis.md "The person" step 3
}

/// arm.g@j: the group's crossings of joint j × s, l_MT at the rig's rest posture kept.
ModelParameter ArmScale(const sim::ModelParams& rig, const MuscleGroup& g, int c) {
  const std::vector<double> rest = RestPosture(rig);
  const std::vector<int> ms = g.muscles;
  ModelParameter p = WithLogPrior(
      Param("arm." + g.name + "@" + sim::CoordinateNames()[c], "1", 1.0, 0.25, 4.0, 1.0,
            [ms, c, rest](double v, sim::ModelParams* m) {
              for (int j : ms) {
                auto& path = m->muscles[j].path;
                const double before = tendons::MusculotendonLength(path, rest);
                for (auto& cr : path.crossings) {
                  if (cr.joint != c) continue;
                  cr.arm.d_m *= v;
                  cr.arm.d_tilde_m *= v;
                }
                path.length_at_ref_m += before - tendons::MusculotendonLength(path, rest);
              }
            }),
      1.25, true);
  p.joint = sim::CoordinateNames()[c];
  return p;
}

ModelParameter HandMassScale(const sim::ModelParams& rig) {
  std::vector<sim::SegmentParams> nominal;
  const std::vector<int> segs = {sim::kHand, sim::kProximalPhalanx, sim::kMiddlePhalanx,
                                 sim::kDistalPhalanx};
  for (int s : segs) nominal.push_back(rig.segments[s]);
  return WithLogPrior(Param("mass.hand", "1", 1.0, 0.25, 4.0, 1.0,
                            [segs, nominal](double v, sim::ModelParams* m) {
                              for (std::size_t i = 0; i < segs.size(); ++i) {
                                auto& seg = m->segments[segs[i]];
                                seg.mass_kg = v * nominal[i].mass_kg;
                                for (int a = 0; a < 3; ++a) {
                                  seg.inertia_about_com_kg_m2[a] =
                                      v * nominal[i].inertia_about_com_kg_m2[a];
                                }
                              }
                            }),
                      1.2, false);
}

bool ArmOutput(const LibraryContext& ctx) {
  for (int c : OutputJoints(ctx)) {
    if (c <= sim::kElbowFlexion) return true;
  }
  return false;
}

/// Starts of the MAP fit over `fitted` (see person.h step 3): nominal, and the four corners with
/// an elbow or shoulder output; the corners alone with `corners_only`.
std::vector<Eigen::VectorXd> CalibrationStarts(const std::vector<ModelParameter>& fitted,
                                               const LibraryContext& ctx, bool corners_only) {
  Eigen::VectorXd nominal = Starts(fitted);
  std::vector<Eigen::VectorXd> out;
  if (!corners_only) out.push_back(nominal);
  if (!corners_only && (!ctx.reduced_model.empty() || !ArmOutput(ctx))) return out;
  for (const double stiffness : {0.8, 1.25}) {
    for (const double strength : {0.8, 1.25}) {
      Eigen::VectorXd x = nominal;
      for (std::size_t k = 0; k < fitted.size(); ++k) {
        const std::string& name = fitted[k].name;
        const double f = name.rfind("k.", 0) == 0          ? stiffness
                         : name.rfind("strength.", 0) == 0 ? strength
                                                           : 1.0;
        x(static_cast<Eigen::Index>(k)) =
            std::clamp(f * fitted[k].start, fitted[k].lower, fitted[k].upper);
      }
      out.push_back(x);
    }
  }
  return out;
}

/// Step 2: the indices of `params` kept, and every parameter's information (R diagonal in
/// pivot order, prior units).
std::vector<int> Identifiable(const Eigen::MatrixXd& jacobian,
                              const std::vector<ModelParameter>& params, double sigma,
                              double threshold, std::vector<double>* information) {
  const auto p = static_cast<Eigen::Index>(params.size());
  Eigen::MatrixXd scaled = jacobian / sigma;
  for (Eigen::Index k = 0; k < p; ++k) {
    const double w = !std::isfinite(params[k].prior_width) ? params[k].scale
                     : params[k].log_prior                 ? params[k].start * params[k].prior_width
                                                           : params[k].prior_width;
    scaled.col(k) *= w;
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(scaled);
  const Eigen::MatrixXd r = qr.matrixR().triangularView<Eigen::Upper>();
  information->assign(params.size(), 0.0);
  std::vector<int> kept;
  for (Eigen::Index i = 0; i < std::min<Eigen::Index>(p, r.rows()); ++i) {
    const auto k = qr.colsPermutation().indices()(i);
    (*information)[k] = std::abs(r(i, i));
    if (std::abs(r(i, i)) >= threshold) kept.push_back(static_cast<int>(k));
  }
  std::sort(kept.begin(), kept.end());
  return kept;
}

}  // namespace

void SetFittedValue(const ModelParameter& p, double value, double ci95, PersonValue* v) {
  v->fitted = true;
  v->value = value;
  v->ci95 = ci95;
  v->at_bound = RangeBoundSide(p, value) != 0;
  // The prior's half-width in the parameter's unit at its value (log-normal: × the value).
  const double prior_half = 1.96 * v->prior_width * (p.log_prior ? value : 1.0);
  v->prior_dominated =
      std::isfinite(v->prior_width) && std::isfinite(ci95) && ci95 >= kPriorDominated * prior_half;
}

std::vector<ModelParameter> PersonParameters(const sim::ModelParams& rig,
                                             const LibraryContext& ctx) {
  std::vector<ModelParameter> out;
  if (!ctx.reduced_model.empty()) {
    for (const auto& ch : ctx.channels) {
      ModelParameter p = Param("u_scale." + ch, "1", 1.0, 0.3, 3.0, 1.0, nullptr);
      p.target = ModelParameter::Target::kInputScale;
      p.column = "u." + ch;
      out.push_back(p);
    }
    return out;
  }
  const std::vector<MuscleGroup> groups = MuscleGroups(rig, ctx);
  for (const auto& g : groups) AddGroupParameters(rig, g, &out);
  for (int c : OutputJoints(ctx)) AddJointParameters(rig, c, &out);
  if (!groups.empty()) out.push_back(OmegaScale(rig, groups));
  for (const auto& g : groups) {
    for (std::size_t i = 1; i < g.joints.size(); ++i) out.push_back(ArmScale(rig, g, g.joints[i]));
  }
  const std::vector<int> outputs = OutputJoints(ctx);
  if (std::find(outputs.begin(), outputs.end(), sim::kWristFlexion) != outputs.end()) {
    out.push_back(HandMassScale(rig));
  }
  return out;
}

double NoiseFromSecondDifferences(const std::vector<double>& y) {
  std::vector<double> d2;
  for (std::size_t i = 1; i + 1 < y.size(); ++i) {
    if (std::isfinite(y[i - 1]) && std::isfinite(y[i]) && std::isfinite(y[i + 1])) {
      d2.push_back(std::abs(y[i + 1] - 2.0 * y[i] + y[i - 1]));
    }
  }
  if (d2.size() < 10) return 0.0;
  std::nth_element(d2.begin(), d2.begin() + d2.size() / 2, d2.end());
  return d2[d2.size() / 2] / 0.6745 / std::sqrt(6.0);
}

PersonCalibration CalibratePerson(const sim::ModelParams& rig, const LibraryContext& ctx,
                                  const DataView& train, const FitOptions& fo,
                                  const PersonCalibrationOptions& options) {
  PersonCalibration out;
  // 1. Noise.
  double ss = 0.0;
  for (const auto& o : train.outputs) {
    std::vector<double> series;
    for (std::size_t t = 0; t < train.trials.size(); ++t) {
      const auto& y = train.trials[t].Column(o);
      for (std::size_t i = 0; i < y.size(); ++i) series.push_back(train.use[t][i] ? y[i] : NAN);
      series.push_back(NAN);  // no difference across trials
    }
    out.noise_rad.push_back(NoiseFromSecondDifferences(series));
    ss += out.noise_rad.back() * out.noise_rad.back();
  }
  out.prior_sigma_rad =
      std::sqrt(ss / static_cast<double>(std::max<std::size_t>(1, train.outputs.size())));
  const std::vector<ModelParameter> all = PersonParameters(rig, ctx);
  FitOptions f = fo;
  f.prior_sigma = out.prior_sigma_rad > 0.0 ? out.prior_sigma_rad : 1e-3;
  f.stop_needs_predicted_decrease = f.hold_active_bounds = options.converged_stop;
  // 2. Identifiability at the nominal point.
  const Eigen::VectorXd nominal = Starts(all);
  std::vector<double> information(all.size(), 0.0);
  std::vector<int> kept;
  if (!ctx.reduced_model.empty() || options.identifiable_information <= 0.0) {
    for (std::size_t k = 0; k < all.size(); ++k) kept.push_back(static_cast<int>(k));
  } else {
    const std::vector<Trial> pred = Predict(rig, all, nominal, train, f);
    const Eigen::VectorXd r = StackResiduals(train, pred);
    out.fit.simulations += static_cast<int>(train.trials.size());
    const Eigen::MatrixXd j =
        ResidualJacobian(rig, all, nominal, r, train, f, &out.fit.simulations);
    kept = Identifiable(j, all, f.prior_sigma, options.identifiable_information, &information);
    if (kept.empty()) kept.push_back(0);
  }
  for (int k : kept) out.fitted.push_back(all[static_cast<std::size_t>(k)]);
  // 3. MAP fit from the starts; the lowest posterior cost is kept.
  const std::vector<Eigen::VectorXd> starts =
      CalibrationStarts(out.fitted, ctx, options.corner_starts_only);
  out.starts = static_cast<int>(starts.size());
  const int before = out.fit.simulations;
  out.fit = FitOverStarts(rig, out.fitted, starts, train, f, options.iterations);
  out.fit.simulations += before;
  // 4. Report table.
  for (std::size_t k = 0; k < all.size(); ++k) {
    PersonValue v;
    v.name = all[k].name;
    v.unit = all[k].unit;
    v.nominal = v.value = all[k].start;
    v.prior_width = all[k].prior_width;
    v.information = information[k];
    const auto it = std::find(kept.begin(), kept.end(), static_cast<int>(k));
    if (it != kept.end()) {
      const auto i = static_cast<Eigen::Index>(it - kept.begin());
      SetFittedValue(all[k], out.fit.x(i), out.fit.ci95(i), &v);
    }
    out.table.push_back(v);
  }
  return out;
}

}  // namespace fesim::diagnosis
