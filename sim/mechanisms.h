// Optional mechanisms (PRODUCT.md "Optional mechanisms", issue 3): each a small model that a
// scenario can switch on, to plant an effect in virtual data or to extend a model in diagnosis.
// Pure functions here; the Simbody force elements and the trial runner call them.
//
//  fatigue       Riener, Quintern & Schmidt 1996 (J Biomech 29:1157) muscle fitness, with its
//                stimulation-frequency factor folded into T_fat (fixed 40 Hz):
//                  dφ/dt = (φ_min − φ) a / T_fat + (1 − φ)(1 − a) / T_rec,   F ∝ φ
//  potentiation  post-activation potentiation as a first-order state (phenomenological; the
//                twitch enhancement of Tillin & Bishop 2009, Sports Med 39:147):
//                  dp/dt = a (1 − p) / T_rise − p / T_decay,   F ∝ 1 + g p
//  delay         electromechanical delay δ: recruitment sees u(t − δ) (Cavanagh & Komi 1979)
//  tremor        periodic joint torque τ = A (1 + m sin 2π f_m t) sin(2π (f t + ½ ḟ t²) + φ)
//                (3–12 Hz; amplitude modulation m, frequency drift ḟ; [Copur 2016] §2)
//  crosstalk     extra current spread: a second Gaussian spread (fraction c, spread σ_x) on the
//                array, and a fraction c to the muscles sharing a joint with a pair electrode's
//  spasticity    velocity-dependent stretch reflex: τ = −G_d (|q̇| − v_th) sign(q̇) for |q̇| > v_th,
//                G_d = G (1 + β) on extension (q̇ < 0, the flexors stretched), G (1 − β) on
//                flexion: β = 0 a reflex of both groups, β = 1 of the flexors alone (the
//                upper-limb pattern after stroke), β = −1 of the extensors alone
//                (Lance 1980's velocity-dependent resistance)
//  stretch reflex  spasticity at the muscles (Lance 1980's "velocity-dependent increase in tonic
//                stretch reflexes"): each listed muscle's drive gains
//                  d = G ramp(ṽ − ṽ_th),  ṽ = (dl_MT/dt) / l_opt  (1/s, > 0 lengthening),
//                ramp(x) = ½ (x + √(x² + ε²)) with ε = 0.05 /s (smooth for the integrator), after
//                a first-order loop lag τ_d (ẋ = (d − x)/τ_d; the short-latency stretch reflex of
//                the forearm flexors, ≈ 30–50 ms: Matthews 1991, Trends Neurosci 14:87), then
//                through the muscle's own eq. (6) activation (Ω_i): a reflex activation r added to
//                the stimulated one (eq. 6 is linear, so the two superpose; a + r, clipped to
//                [0, 1], is what the force, fatigue and potentiation see). It acts at every
//                joint the muscle crosses, unlike the joint-level spasticity above.
//  stiction      Stribeck friction: τ = −(F_c + (F_s − F_c) e^{−(q̇/v_s)²}) tanh(q̇/v_c)
//                ([Spagnol 2013] static friction of the exoskeleton)
//  sensor drift, dropouts, outliers: see sensors.h / SensorArtefacts.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace fesim::sim {

struct FatigueParams {
  bool enabled = false;
  double fatigue_time_s = 30.0;    ///< T_fat, s, > 0 (at full activation).
  double recovery_time_s = 300.0;  ///< T_rec, s, > 0.
  double min_fitness = 0.3;        ///< φ_min, 0–1.
};

struct PotentiationParams {
  bool enabled = false;
  double gain = 0.5;         ///< g, dimensionless, ≥ 0: force × (1 + g) when fully potentiated.
  double rise_time_s = 5.0;  ///< T_rise, s, > 0.
  double decay_time_s = 60.0;  ///< T_decay, s, > 0.
};

struct TremorParams {
  bool enabled = false;
  int coordinate = 5;                   ///< Coordinate index (default wrist_flexion).
  double frequency_hz = 6.0;            ///< f, Hz, 3–12.
  double amplitude_nm = 0.05;           ///< A, N·m, ≥ 0.
  double amplitude_modulation = 0.0;    ///< m, 0–1.
  double modulation_hz = 0.2;           ///< f_m, Hz, ≥ 0.
  double frequency_drift_hz_per_s = 0;  ///< ḟ, Hz/s.
  double phase_rad = 0.0;               ///< φ, rad.
};

struct CrosstalkParams {
  double fraction = 0.0;   ///< c, 0–1 (0 = off).
  double spread_m = 0.03;  ///< σ_x, m, > 0.
};

struct StretchReflexParams {
  double gain = 0.0;                 ///< G, activation per l_opt/s of stretch, ≥ 0 (0 = off).
  double threshold_per_s = 0.1;      ///< ṽ_th, l_opt/s, ≥ 0.
  double loop_delay_s = 0.04;        ///< τ_d, s, > 0.
  std::vector<std::string> muscles;  ///< names of the muscles with the reflex.

  bool enabled() const { return gain > 0.0 && !muscles.empty(); }
};

struct MechanismParams {
  FatigueParams fatigue;
  PotentiationParams potentiation;
  double electromechanical_delay_s = 0.0;  ///< δ, s, ≥ 0.
  TremorParams tremor;
  CrosstalkParams crosstalk;
  StretchReflexParams stretch_reflex;
};

/// True when a mechanism adds integrated states to the model (fatigue, potentiation, the
/// stretch reflex).
bool HasMechanismStates(const MechanismParams& m);

/// dφ/dt of the fitness model for activation a (0–1) and fitness φ.
double FitnessDerivative(const FatigueParams& p, double activation, double fitness);
/// dp/dt of the potentiation state for activation a and state p.
double PotentiationDerivative(const PotentiationParams& p, double activation, double state);
/// Partial derivatives of FitnessDerivative and PotentiationDerivative (both bilinear in the
/// activation and the state), 1/s: {∂/∂a, ∂/∂state} at activation a and the state.
struct StateRatePartials {
  double activation = 0.0;
  double state = 0.0;
};
StateRatePartials FitnessDerivativePartials(const FatigueParams& p, double activation,
                                            double fitness);
StateRatePartials PotentiationDerivativePartials(const PotentiationParams& p, double activation,
                                                 double state);
/// The gain on a muscle's active force (the header's F ∝ φ and F ∝ 1 + g p): φ (1 + g p) with
/// fitness φ and potentiation state p, each factor 1 when its mechanism is off.
double ActiveForceGain(const MechanismParams& m, double fitness, double potentiation);
/// Tremor torque at time t (N·m), 0 when disabled.
double TremorTorque(const TremorParams& p, double t_s);
/// Stretch-reflex torque (N·m) for gain G (N·m·s/rad, ≥ 0), threshold v_th (rad/s) and direction
/// bias β ∈ [−1, 1] (header: the gain on extension is G (1 + β), on flexion G (1 − β)).
/// The stretch reflex's drive d = G ramp(ṽ − ṽ_th) (header) for normalised lengthening velocity
/// ṽ = (dl_MT/dt)/l_opt, 1/s; dimensionless, ≥ 0.
double StretchReflexDrive(const StretchReflexParams& p, double stretch_per_s);
/// d/dt of one muscle's reflex states {x, r, ṙ} (loop lag, then eq. 6 with Ω rad/s) for drive d.
std::array<double, 3> StretchReflexDerivative(const StretchReflexParams& p, double omega_rad_s,
                                              double drive, const std::array<double, 3>& state);
double ReflexTorque(double gain_nms_per_rad, double threshold_rad_s, double qdot_rad_s,
                    double direction_bias = 0.0);

}  // namespace fesim::sim
