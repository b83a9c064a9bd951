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
//  stiction      Stribeck friction: τ = −(F_c + (F_s − F_c) e^{−(q̇/v_s)²}) tanh(q̇/v_c)
//                ([Spagnol 2013] static friction of the exoskeleton)
//  sensor drift, dropouts, outliers: see sensors.h / SensorArtefacts.
#pragma once

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

struct MechanismParams {
  FatigueParams fatigue;
  PotentiationParams potentiation;
  double electromechanical_delay_s = 0.0;  ///< δ, s, ≥ 0.
  TremorParams tremor;
  CrosstalkParams crosstalk;
};

/// dφ/dt of the fitness model for activation a (0–1) and fitness φ.
double FitnessDerivative(const FatigueParams& p, double activation, double fitness);
/// dp/dt of the potentiation state for activation a and state p.
double PotentiationDerivative(const PotentiationParams& p, double activation, double state);
/// Tremor torque at time t (N·m), 0 when disabled.
double TremorTorque(const TremorParams& p, double t_s);
/// Stretch-reflex torque (N·m) for gain G (N·m·s/rad, ≥ 0), threshold v_th (rad/s) and direction
/// bias β ∈ [−1, 1] (header: the gain on extension is G (1 + β), on flexion G (1 − β)).
double ReflexTorque(double gain_nms_per_rad, double threshold_rad_s, double qdot_rad_s,
                    double direction_bias = 0.0);

}  // namespace fesim::sim
