#include "foreign/effects.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <stdexcept>

#include "foreign/check.h"
#include "foreign/random.h"

namespace fesim::foreign {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// Drive normalised by the muscle's reachable recruitment, ẽ = e/w_max, 0–1.
double NormalisedCoupling(const EffectContext& ctx, int m) {
  return std::clamp(ctx.coupling[m] / ctx.person->muscles[m].recruitment.max_fraction, 0.0, 1.0);
}

/// C¹ ramp: 0 for x ≤ 0, x²/(2ε) on (0, ε), x − ε/2 beyond.
double SmoothRamp(double x, double eps) {
  if (x <= 0.0) return 0.0;
  return x < eps ? x * x / (2.0 * eps) : x - 0.5 * eps;
}

/// C¹ step 0 → 1 over [0, 1] (cubic smoothstep).
double SmoothStep01(double x) {
  const double s = std::clamp(x, 0.0, 1.0);
  return s * s * (3.0 - 2.0 * s);
}

// ---------------------------------------------------------------------------------------------
/// "fatigue": force capacity c per muscle, after the fatigue model of Ding, Wexler &
/// Binder-Macleod 2000 (J Appl Physiol 89), dA/dt = −(A − A_rest)/τ_fat + α_A·C_N, with the
/// coupling state e standing for C_N. Departures: the loss is ∝ c (c stays positive) and ∝
/// ẽ = e/w_max, because FES recruits the same units at every pulse, so their fatigue follows how
/// hard the reachable pool is driven:  dc/dt = (1 − c)/τ_rec − s·k_f·ẽ·c.
class Fatigue final : public EffectModel {
 public:
  explicit Fatigue(double scale) : rate_per_s_(scale * kRatePerS) {}
  int NumStates() const override { return kNumMuscles; }
  void InitialState(double* x) const override { std::fill(x, x + kNumMuscles, 1.0); }
  void ScaleCapacity(const EffectContext&, const double* x, MuscleArray* cap) const override {
    for (int m = 0; m < kNumMuscles; ++m) (*cap)[m] *= std::max(0.0, x[m]);
  }
  void StateDerivative(const EffectContext& ctx, const double* x, double* dx) const override {
    for (int m = 0; m < kNumMuscles; ++m) {
      dx[m] = (1.0 - x[m]) / kRecoveryTauS - rate_per_s_ * NormalisedCoupling(ctx, m) * x[m];
    }
  }

 private:
  static constexpr double kRecoveryTauS = 127.0;  ///< τ_fat of Ding et al. 2000, s.
  static constexpr double kRatePerS = 0.025;      ///< k_f at s = 1, 1/s (assumed, calibrated).
  double rate_per_s_;
};

/// "potentiation": post-activation potentiation level π per muscle (assumed form):
/// dπ/dt = ẽ(1 − π)/τ_build − π/τ_decay, capacity × (1 + s·g·π); τ_decay of tens of seconds.
class Potentiation final : public EffectModel {
 public:
  explicit Potentiation(double scale) : gain_(scale * kGain) {}
  int NumStates() const override { return kNumMuscles; }
  void InitialState(double* x) const override { std::fill(x, x + kNumMuscles, 0.0); }
  void ScaleCapacity(const EffectContext&, const double* x, MuscleArray* cap) const override {
    for (int m = 0; m < kNumMuscles; ++m) (*cap)[m] *= 1.0 + gain_ * x[m];
  }
  void StateDerivative(const EffectContext& ctx, const double* x, double* dx) const override {
    for (int m = 0; m < kNumMuscles; ++m) {
      dx[m] = NormalisedCoupling(ctx, m) * (1.0 - x[m]) / kBuildTauS - x[m] / kDecayTauS;
    }
  }
  double CapacityBound() const override { return 1.0 + gain_; }

 private:
  static constexpr double kBuildTauS = 8.0;   ///< s (assumed).
  static constexpr double kDecayTauS = 30.0;  ///< s (assumed, "tens of seconds").
  static constexpr double kGain = 0.35;       ///< g at s = 1 (assumed, calibrated).
  double gain_;
};

/// "delay": a pure transport delay of the stimulation, d = s·50 ms (assumed; 30–100 ms for
/// s ∈ [0.6, 2]). The plant shifts the stimulation schedule by d (exact, no interpolation).
class Delay final : public EffectModel {
 public:
  explicit Delay(double scale) : delay_s_(scale * kDelayS) {}
  double StimulationDelay_s() const override { return delay_s_; }

 private:
  static constexpr double kDelayS = 0.05;
  double delay_s_;
};

/// "tremor": a wrist torque τ = s·A·E(t)·sin(2πf t + φ) with a slow envelope
/// E(t) = ramp(t/1 s)·(1 + m sin(2π f_am t + φ_am))/(1 + m); f ~ U[4, 9] Hz (pathological band)
/// and f_am ~ U[0.05, 0.2] Hz are the person's (person_seed: a tremor keeps its frequency from
/// trial to trial), the phases are the trial's (seed). Amplitude A assumed, calibrated.
class Tremor final : public EffectModel {
 public:
  int JointIndex() const override { return 0; }
  Tremor(double scale, const EffectSetup& setup) : amplitude_nm_(scale * kAmplitudeNm) {
    std::mt19937_64 person_rng(setup.person_seed);
    frequency_hz_ = UniformIn(person_rng, 4.0, 9.0);
    envelope_hz_ = UniformIn(person_rng, 0.05, 0.2);
    std::mt19937_64 rng(setup.seed);
    phase_rad_ = UniformIn(rng, 0.0, 2.0 * kPi);
    envelope_phase_rad_ = UniformIn(rng, 0.0, 2.0 * kPi);
  }
  void AddJointTorque(const EffectContext& ctx, const double*,
                      Eigen::Vector3d* tau) const override {
    const double t = ctx.t_s;
    const double envelope =
        SmoothStep01(t / kOnsetS) *
        (1.0 + kModulation * std::sin(2 * kPi * envelope_hz_ * t + envelope_phase_rad_)) /
        (1.0 + kModulation);
    (*tau)[0] += amplitude_nm_ * envelope * std::sin(2 * kPi * frequency_hz_ * t + phase_rad_);
  }

 private:
  static constexpr double kAmplitudeNm = 0.1;  ///< A at s = 1, N·m (assumed).
  static constexpr double kModulation = 0.5;   ///< m (assumed).
  static constexpr double kOnsetS = 1.0;       ///< smooth onset, s (assumed).
  double amplitude_nm_;
  double frequency_hz_, phase_rad_, envelope_hz_, envelope_phase_rad_;
};

/// "crosstalk": current spread; each channel also reaches the antagonist group with fraction
/// c = s·0.45 of its own weight, W[m][c'] += c·W[m][c] for the other channel c' (assumed; at
/// s = 1 the antagonists see 135 µs when a channel delivers 300 µs, above their thresholds).
class Crosstalk final : public EffectModel {
 public:
  explicit Crosstalk(double scale) : fraction_(scale * kFraction) {}
  void ModifyPerson(Person* p) const override {
    for (int m = 0; m < kNumMuscles; ++m) {
      const int on = IsExtensor(m) ? kExtChannel : kFlexChannel;
      const int off = 1 - on;
      p->placement[m][off] = std::min(2.0, p->placement[m][off] + fraction_ * p->placement[m][on]);
    }
  }

 private:
  static constexpr double kFraction = 0.45;
  double fraction_;
};

/// "moment_arm_posture": wrist moment arms much more posture dependent, r1 += s·κ·r0 for every
/// wrist crossing (|r| grows with flexion), κ = 0.6 /rad (assumed). l_MT follows from the
/// polynomial, so r = −∂l_MT/∂q still holds.
class MomentArmPosture final : public EffectModel {
 public:
  int JointIndex() const override { return 0; }
  explicit MomentArmPosture(double scale) : kappa_per_rad_(scale * kKappaPerRad) {}
  void ModifyPerson(Person* p) const override {
    for (MuscleParams& m : p->muscles) {
      MomentArmPoly& r = m.moment_arms[kWristCrossing];
      if (r.crosses)
        r.r1_m_per_rad = std::clamp(r.r1_m_per_rad + kappa_per_rad_ * r.r0_m, -0.05, 0.05);
    }
  }

 private:
  static constexpr double kKappaPerRad = 0.6;
  double kappa_per_rad_;
};

/// "force_length_velocity": much slower muscles, v_max ÷ (1 + s·3) (assumed).
class ForceLengthVelocity final : public EffectModel {
 public:
  explicit ForceLengthVelocity(double scale) : divisor_(1.0 + scale * kSlowdown) {}
  void ModifyPerson(Person* p) const override {
    for (MuscleParams& m : p->muscles) m.contraction.max_velocity_lopt_per_s /= divisor_;
  }

 private:
  static constexpr double kSlowdown = 3.0;
  double divisor_;
};

/// "unequal_muscle_dynamics": extensor activation time constants × ρ, flexor ones ÷ ρ,
/// ρ = 1 + s·0.5 (assumed).
class UnequalMuscleDynamics final : public EffectModel {
 public:
  explicit UnequalMuscleDynamics(double scale) : ratio_(1.0 + scale * kRatioStep) {}
  void ModifyPerson(Person* p) const override {
    for (int m = 0; m < kNumMuscles; ++m) {
      const double f = IsExtensor(m) ? ratio_ : 1.0 / ratio_;
      ActivationParams& a = p->muscles[m].activation;
      a.coupling_activation_tau_s = std::min(2.0, a.coupling_activation_tau_s * f);
      a.coupling_deactivation_tau_s = std::min(2.0, a.coupling_deactivation_tau_s * f);
      a.force_activation_tau_s = std::min(2.0, a.force_activation_tau_s * f);
      a.force_deactivation_tau_s = std::min(2.0, a.force_deactivation_tau_s * f);
    }
  }

 private:
  static constexpr double kRatioStep = 0.5;
  double ratio_;
};

/// "passive_stiffness_nonlinear": an extra, purely stiffening elastic wrist moment about the
/// wrist's rest angle, τ = −s·K·(sinh(βd) − βd)/β, d = q1 − q_r (potential
/// s·K·(cosh βd − 1 − β²d²/2)/β²): no stiffness at rest, e^{β|d|} growth across the range.
/// K = 0.3 N·m/rad, β = 4 /rad (assumed).
class PassiveStiffnessNonlinear final : public EffectModel {
 public:
  int JointIndex() const override { return 0; }
  explicit PassiveStiffnessNonlinear(double scale) : k_nm_per_rad_(scale * kStiffnessNmPerRad) {}
  void AddJointTorque(const EffectContext& ctx, const double*,
                      Eigen::Vector3d* tau) const override {
    const double bd = kBetaPerRad * (ctx.q_rad[0] - ctx.person->joints[0].rest_angle_rad);
    (*tau)[0] -= k_nm_per_rad_ * (std::sinh(bd) - bd) / kBetaPerRad;
  }
  Eigen::Vector3d StiffnessBound(const Person& p, const Eigen::Vector3d& q) const override {
    const double bd = kBetaPerRad * std::abs(q[0] - p.joints[0].rest_angle_rad);
    return {k_nm_per_rad_ * (std::cosh(bd) - 1.0), 0.0, 0.0};
  }

 private:
  static constexpr double kStiffnessNmPerRad = 0.3;
  static constexpr double kBetaPerRad = 4.0;
  double k_nm_per_rad_;
};

/// "stiction": static + Coulomb friction at the wrist, a smoothed Karnopp model (Karnopp 1985,
/// J Dyn Syst Meas Control 107(1)). Outside the stick band |q̇1| ≥ Δv the friction is −F_c sgn q̇1;
/// inside it blends (weight 1 − σ, σ = smoothstep(|q̇1|/Δv)) into the sticking force that keeps
/// q̈1 = 0, f_hold = −(M⁻¹ net)_1/(M⁻¹)_11, clipped to ±F_s, plus a band viscosity −F_s q̇1/Δv that
/// brings q̇1 to rest. F_s = s·0.06 N·m, F_c = s·0.04 N·m, Δv = 0.05 rad/s (assumed).
class Stiction final : public EffectModel {
 public:
  int JointIndex() const override { return 0; }
  explicit Stiction(double scale)
      : static_nm_(scale * kStaticNm), coulomb_nm_(scale * kCoulombNm) {}
  void AddFrictionTorque(const EffectContext& ctx, const Eigen::Matrix3d& m_inv,
                         const Eigen::Vector3d& net, Eigen::Vector3d* tau) const override {
    const double v = ctx.qd_rad_s[0];
    const double sigma = SmoothStep01(std::abs(v) / kBandRadS);
    const double hold = std::clamp(-m_inv.row(0).dot(net) / m_inv(0, 0), -static_nm_, static_nm_);
    const double sign = v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0);
    (*tau)[0] += (1.0 - sigma) * (hold - static_nm_ * v / kBandRadS) - sigma * coulomb_nm_ * sign;
  }
  Eigen::Vector3d DampingBound(const Person&, const Eigen::Vector3d&) const override {
    return {(static_nm_ + 1.5 * (static_nm_ + coulomb_nm_)) / kBandRadS, 0.0, 0.0};
  }

 private:
  static constexpr double kStaticNm = 0.06;
  static constexpr double kCoulombNm = 0.04;
  static constexpr double kBandRadS = 0.05;
  double static_nm_, coulomb_nm_;
};

/// "spasticity": a velocity-dependent stretch reflex ("a velocity-dependent increase in tonic
/// stretch reflexes", Lance 1980) of the flexors FCR, FCU, FDS, FDP: the reflex drive
/// s·G·ramp(ṽ − ṽ_th), ṽ = (dl_MT/dt)/l_opt (1/s), passes a 4-stage Erlang (gamma) lag of mean
/// 40 ms — a distributed reflex-loop delay kept as ODE states — and adds to the muscle's drive.
/// G = 0.08 per l_opt/s, ṽ_th = 0.1 /s, ramp smoothing 0.05 /s (assumed).
class Spasticity final : public EffectModel {
 public:
  explicit Spasticity(double scale) : gain_(scale * kGain) {}
  int NumStates() const override { return kNumFlexors * kStages; }
  void InitialState(double* x) const override { std::fill(x, x + NumStates(), 0.0); }
  void AddDrive(const EffectContext&, const double* x, MuscleArray* drive) const override {
    for (int i = 0; i < kNumFlexors; ++i) (*drive)[kFlexors[i]] += x[i * kStages + kStages - 1];
  }
  void StateDerivative(const EffectContext& ctx, const double* x, double* dx) const override {
    const double stage_tau = kDelayS / kStages;
    for (int i = 0; i < kNumFlexors; ++i) {
      const int m = kFlexors[i];
      const double v = ctx.lengthening_velocity_m_s[m] /
                       ctx.person->muscles[m].contraction.optimal_fibre_length_m;
      double input = gain_ * SmoothRamp(v - kThresholdPerS, kSmoothingPerS);
      for (int k = 0; k < kStages; ++k) {
        const int s = i * kStages + k;
        dx[s] = (input - x[s]) / stage_tau;
        input = x[s];
      }
    }
  }
  // Stretch velocities stay below ≈ 3 l_opt/s in these movements (assumed for the bound).
  double DriveBound() const override { return std::min(1.0, gain_ * 3.0); }

 private:
  static constexpr int kNumFlexors = 4;
  static constexpr int kStages = 4;
  static constexpr std::array<int, kNumFlexors> kFlexors = {kFcr, kFcu, kFds, kFdp};
  static constexpr double kGain = 0.08;
  static constexpr double kThresholdPerS = 0.1;
  static constexpr double kSmoothingPerS = 0.05;
  static constexpr double kDelayS = 0.04;
  double gain_;
};

/// "sensor_drift": each angle reading drifts linearly, offset_j = s·k_j·σ_j·0.5 mrad/s·t,
/// k_j ~ U[0.7, 1.3], σ_j = ±1 (seeded). Sensor-level: the body does not move.
class SensorDrift final : public EffectModel {
 public:
  SensorDrift(double scale, const EffectSetup& setup) {
    std::mt19937_64 rng(setup.seed);
    for (int j = 0; j < kNumJoints; ++j) {
      rate_rad_s_[j] = scale * kRateRadS * UniformIn(rng, 0.7, 1.3) * RandomSign(rng);
    }
  }
  Eigen::Vector3d ReadingOffset(double t_s) const override { return rate_rad_s_ * t_s; }

 private:
  static constexpr double kRateRadS = 5e-4;
  Eigen::Vector3d rate_rad_s_;
};

/// "wander": baseline wander of each reading, two sinusoids of 0.05–0.2 Hz (seeded frequencies
/// and phases per joint), each of amplitude s·0.02 rad (assumed).
class Wander final : public EffectModel {
 public:
  Wander(double scale, const EffectSetup& setup) : amplitude_rad_(scale * kAmplitudeRad) {
    std::mt19937_64 rng(setup.seed);
    for (int j = 0; j < kNumJoints; ++j) {
      for (int k = 0; k < 2; ++k) {
        frequency_hz_[j][k] = UniformIn(rng, 0.05, 0.2);
        phase_rad_[j][k] = UniformIn(rng, 0.0, 2.0 * kPi);
      }
    }
  }
  Eigen::Vector3d ReadingOffset(double t_s) const override {
    Eigen::Vector3d out;
    for (int j = 0; j < kNumJoints; ++j) {
      out[j] = 0.0;
      for (int k = 0; k < 2; ++k) {
        out[j] += amplitude_rad_ * std::sin(2 * kPi * frequency_hz_[j][k] * t_s + phase_rad_[j][k]);
      }
    }
    return out;
  }

 private:
  static constexpr double kAmplitudeRad = 0.02;
  double amplitude_rad_;
  std::array<std::array<double, 2>, kNumJoints> frequency_hz_{}, phase_rad_{};
};

/// "slip": a glove/marker slip: at one time t_s ~ U[0.3, 0.7]·duration every reading's offset
/// steps by s·σ_j·U[0.02, 0.04] rad (seeded signs σ_j).
class Slip final : public EffectModel {
 public:
  Slip(double scale, const EffectSetup& setup) {
    std::mt19937_64 rng(setup.seed);
    time_s_ = UniformIn(rng, 0.3, 0.7) * setup.duration_s;
    for (int j = 0; j < kNumJoints; ++j)
      step_rad_[j] = scale * UniformIn(rng, 0.02, 0.04) * RandomSign(rng);
  }
  Eigen::Vector3d ReadingOffset(double t_s) const override {
    return t_s >= time_s_ ? step_rad_ : Eigen::Vector3d::Zero();
  }

 private:
  double time_s_ = 0.0;
  Eigen::Vector3d step_rad_;
};

/// "voluntary": short voluntary finger movements not caused by the stimulation: raised-cosine
/// bursts of extra drive (duration U[0.3, 0.6] s, peak s·U[0.5, 1.0]·0.10) to the finger flexors
/// (FDS, FDP) or to EDC (fair coin), starting at Poisson times of mean interval 8 s after the
/// first 1 s (seeded; assumed values).
class Voluntary final : public EffectModel {
 public:
  Voluntary(double scale, const EffectSetup& setup) : peak_(scale * kPeakDrive) {
    std::mt19937_64 rng(setup.seed);
    double t = 1.0;
    while (true) {
      t += -kMeanIntervalS * std::log(Uniform01(rng));
      const Burst b{t, UniformIn(rng, 0.3, 0.6), UniformIn(rng, 0.5, 1.0), Uniform01(rng) < 0.5};
      if (t + b.duration_s > setup.duration_s) break;
      bursts_.push_back(b);
      t += b.duration_s;
    }
  }
  void AddDrive(const EffectContext& ctx, const double*, MuscleArray* drive) const override {
    for (const Burst& b : bursts_) {
      const double x = (ctx.t_s - b.start_s) / b.duration_s;
      if (x <= 0.0 || x >= 1.0) continue;
      const double d = peak_ * b.level * 0.5 * (1.0 - std::cos(2.0 * kPi * x));
      if (b.flex) {
        (*drive)[kFds] += d;
        (*drive)[kFdp] += d;
      } else {
        (*drive)[kEdc] += d;
      }
    }
  }
  double DriveBound() const override { return std::min(1.0, peak_); }

 private:
  struct Burst {
    double start_s, duration_s, level;
    bool flex;
  };
  static constexpr double kPeakDrive = 0.10;
  static constexpr double kMeanIntervalS = 8.0;
  double peak_;
  std::vector<Burst> bursts_;
};

template <typename T>
std::unique_ptr<EffectModel> MakeScaled(double scale, const EffectSetup&) {
  return std::make_unique<T>(scale);
}
template <typename T>
std::unique_ptr<EffectModel> MakeSeeded(double scale, const EffectSetup& setup) {
  return std::make_unique<T>(scale, setup);
}

}  // namespace

std::vector<EffectEntry> EffectTable() {
  return {
      {"fatigue", &MakeScaled<Fatigue>},
      {"potentiation", &MakeScaled<Potentiation>},
      {"delay", &MakeScaled<Delay>},
      {"tremor", &MakeSeeded<Tremor>},
      {"crosstalk", &MakeScaled<Crosstalk>},
      {"moment_arm_posture", &MakeScaled<MomentArmPosture>},
      {"force_length_velocity", &MakeScaled<ForceLengthVelocity>},
      {"unequal_muscle_dynamics", &MakeScaled<UnequalMuscleDynamics>},
      {"passive_stiffness_nonlinear", &MakeScaled<PassiveStiffnessNonlinear>},
      {"stiction", &MakeScaled<Stiction>},
      {"spasticity", &MakeScaled<Spasticity>},
      {"sensor_drift", &MakeSeeded<SensorDrift>},
      {"wander", &MakeSeeded<Wander>},
      {"slip", &MakeSeeded<Slip>},
      {"voluntary", &MakeSeeded<Voluntary>},
  };
}

std::vector<std::string> EffectIds() {
  std::vector<std::string> ids;
  for (const EffectEntry& e : EffectTable()) ids.emplace_back(e.id);
  return ids;
}

std::unique_ptr<EffectModel> MakeEffect(const PlantedEffect& effect, const EffectSetup& setup) {
  CheckAbove(effect.scale, 0.0, 1000.0, "effect." + effect.id + ".scale");
  CheckAbove(setup.duration_s, 0.0, 1e6, "effect setup duration_s");
  for (const EffectEntry& e : EffectTable()) {
    if (effect.id == e.id) return e.make(effect.scale, setup);
  }
  std::ostringstream msg;
  msg << "foreign: effect id \"" << effect.id << "\" unknown, allowed:";
  for (const std::string& id : EffectIds()) msg << ' ' << id;
  throw std::invalid_argument(msg.str());
}

}  // namespace fesim::foreign
