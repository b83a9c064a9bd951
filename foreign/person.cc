#include "foreign/person.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "foreign/check.h"
#include "foreign/random.h"

namespace fesim::foreign {
namespace {

constexpr double kNominalHeightM = 1.75;
constexpr double kNominalMassKg = 75.0;
constexpr double kMinRecruitmentSpanUs = 10.0;  // DrawPerson keeps u_sat ≥ u_th + this

/// One nominal muscle. Moment arms: magnitudes of the order of Loren et al. 1996 (J Biomech 29(3))
/// for the wrist and An et al. 1983 (J Biomech 16(6)) for the index finger; the polynomial
/// coefficients themselves are assumed. Optimal fibre lengths of the order of Lieber et al. 1992
/// (J Hand Surg Am 17(5)); strengths, tendon slack lengths and recruitment are assumed and
/// calibrated so that the nominal responses fall in the ranges of foreign/simulate.h.
struct NominalMuscle {
  MuscleId id;
  std::array<MomentArmPoly, kNumCrossings> arms;  // wrist, MCP, PIP, DIP
  double max_force_n;
  double optimal_fibre_length_m;
  double tendon_slack_length_m;
  double fibre_length_at_zero_lopt;  // l_M(θ = 0)/l_opt
  RecruitmentParams recruitment;
};

constexpr MomentArmPoly kNone{};
constexpr MomentArmPoly Arm(double r0, double r1, double r2) { return {true, r0, r1, r2}; }

std::array<NominalMuscle, kNumMuscles> NominalMuscles() {
  return {{
      {kEcr,
       {Arm(-0.013, 0.002, 0.001), kNone, kNone, kNone},
       220.0,
       0.080,
       0.22,
       1.00,
       {60.0, 260.0, 0.35}},
      {kEcu,
       {Arm(-0.007, 0.001, 0.0), kNone, kNone, kNone},
       90.0,
       0.045,
       0.22,
       1.00,
       {80.0, 330.0, 0.30}},
      {kEdc,
       {Arm(-0.010, 0.0, 0.0), Arm(-0.009, -0.001, 0.0), Arm(-0.003, 0.0, 0.0),
        Arm(-0.002, 0.0, 0.0)},
       30.0,
       0.065,
       0.30,
       0.95,
       {70.0, 300.0, 0.25}},
      {kFcr,
       {Arm(0.014, 0.001, -0.001), kNone, kNone, kNone},
       120.0,
       0.052,
       0.24,
       1.00,
       {60.0, 260.0, 0.35}},
      {kFcu,
       {Arm(0.014, 0.0, 0.0), kNone, kNone, kNone},
       130.0,
       0.042,
       0.24,
       1.00,
       {80.0, 330.0, 0.30}},
      {kFds,
       {Arm(0.012, 0.0, 0.0), Arm(0.011, 0.002, 0.0), Arm(0.008, 0.001, 0.0), kNone},
       60.0,
       0.070,
       0.26,
       1.00,
       {70.0, 300.0, 0.15}},
      {kFdp,
       {Arm(0.010, 0.0, 0.0), Arm(0.011, 0.002, 0.0), Arm(0.0075, 0.001, 0.0),
        Arm(0.005, 0.0, 0.0)},
       80.0,
       0.072,
       0.27,
       1.00,
       {80.0, 340.0, 0.10}},
  }};
}

/// Nominal passive joints (assumed): wrist stiffness at rest ≈ 1 N·m/rad, stiffening
/// κ = 1/rad (the stiffness 2k·cosh(κd) is 1.2× its rest value at d = 0.6 rad, 1.4× at 0.9 rad:
/// the near-linear mid-range of passive wrist moments, Formica et al. 2012 J Neurophysiol 108(4));
/// fingers κ = 1.5/rad. A strongly stiffening passive curve is the planted effect
/// passive_stiffness_nonlinear (effects.h), not a property of a clean person. Damping (wrist
/// 0.04 N·m·s/rad) such that a co-contracted wrist does not ring: with 0.012 a drawn person's
/// wrist rang at ≈ 2 Hz after every co-contraction step (damping ratio ≈ 0.1), against the smooth
/// and slow stimulated hand movement of [Hand Hammerstein] Assumption 1.
std::array<JointParams, kNumJoints> NominalJoints() {
  return {{
      {-0.10, 0.5, 1.0, 0.5, 1.0, 0.04},
      {0.40, 0.08, 1.5, 0.08, 1.5, 0.01},
      {0.50, 0.03, 1.5, 0.03, 1.5, 0.004},
  }};
}

double Draw(std::mt19937_64& rng, const UniformRange& r) { return UniformIn(rng, r.lo, r.hi); }

void CheckSpreadRange(const UniformRange& r, double lo, double hi, const std::string& field) {
  CheckRange(r.lo, lo, hi, "spread." + field + ".lo");
  CheckRange(r.hi, r.lo, hi, "spread." + field + ".hi");
}

void ValidateSpread(const PersonSpread& s) {
  CheckSpreadRange(s.height_m, 1.0, 2.5, "height_m");
  CheckSpreadRange(s.mass_kg, 20.0, 250.0, "mass_kg");
  CheckSpreadRange(s.max_force, 0.01, 100.0, "max_force");
  CheckSpreadRange(s.recruitment_points, 0.01, 5.0, "recruitment_points");
  CheckSpreadRange(s.activation_common, 0.05, 10.0, "activation_common");
  CheckRange(s.activation_per_muscle, 0.0, 0.5, "spread.activation_per_muscle");
  CheckSpreadRange(s.moment_arm, 0.05, 3.0, "moment_arm");
  CheckSpreadRange(s.segment_mass, 0.05, 5.0, "segment_mass");
  CheckRange(s.rest_angle_half_width_rad, 0.0, 0.5, "spread.rest_angle_half_width_rad");
  CheckSpreadRange(s.joint_stiffness, 0.01, 100.0, "joint_stiffness");
  CheckSpreadRange(s.joint_damping, 0.01, 100.0, "joint_damping");
  CheckSpreadRange(s.placement_on, 0.0, 2.0, "placement_on");
  CheckSpreadRange(s.placement_crosstalk, 0.0, 1.0, "placement_crosstalk");
}

void SpreadMuscles(const PersonSpread& s, std::mt19937_64& rng, Person* p) {
  const double common = Draw(rng, s.activation_common);
  for (int m = 0; m < kNumMuscles; ++m) {
    MuscleParams& mu = p->muscles[m];
    mu.contraction.max_force_n *= Draw(rng, s.max_force);
    RecruitmentParams& r = mu.recruitment;
    r.threshold_us *= Draw(rng, s.recruitment_points);
    r.saturation_us *= Draw(rng, s.recruitment_points);
    r.saturation_us = std::max(r.saturation_us, r.threshold_us + kMinRecruitmentSpanUs);
    const double f =
        common * UniformIn(rng, 1.0 - s.activation_per_muscle, 1.0 + s.activation_per_muscle);
    mu.activation.coupling_activation_tau_s *= f;
    mu.activation.coupling_deactivation_tau_s *= f;
    mu.activation.force_activation_tau_s *= f;
    mu.activation.force_deactivation_tau_s *= f;
    for (MomentArmPoly& arm : mu.moment_arms) {
      if (!arm.crosses) continue;
      const double k = Draw(rng, s.moment_arm);
      arm.r0_m *= k;
      arm.r1_m_per_rad *= k;
      arm.r2_m_per_rad2 *= k;
    }
    for (int c = 0; c < kNumChannels; ++c) {
      const bool on = (c == kExtChannel) == IsExtensor(m);
      p->placement[m][c] = on ? Draw(rng, s.placement_on) : Draw(rng, s.placement_crosstalk);
    }
  }
}

}  // namespace

void ValidatePerson(const Person& p) {
  CheckRange(p.height_m, 1.0, 2.5, "person.height_m");
  CheckRange(p.mass_kg, 20.0, 250.0, "person.mass_kg");
  ValidateBody(p.body);
  ValidateGravity(p.gravity);
  for (int j = 0; j < kNumJoints; ++j) {
    ValidateJoint(p.joints[j], (std::string("person.joints.") + kJointNames[j]).c_str());
  }
  for (int m = 0; m < kNumMuscles; ++m) {
    const std::string name = std::string("person.muscles.") + kMuscleNames[m];
    ValidateMuscle(p.muscles[m], name);
    for (int c = 0; c < kNumChannels; ++c) {
      CheckRange(p.placement[m][c], 0.0, 2.0,
                 std::string("person.placement.") + kMuscleNames[m] + "." + kChannelNames[c]);
    }
  }
}

Person ScaledPerson(double height_m, double mass_kg) {
  Person p;
  p.height_m = height_m;
  p.mass_kg = mass_kg;
  p.body = HandBody(height_m, mass_kg);
  p.joints = NominalJoints();
  const double length_scale = height_m / kNominalHeightM;
  const double force_scale = std::pow(mass_kg / kNominalMassKg, 2.0 / 3.0);
  for (const NominalMuscle& n : NominalMuscles()) {
    MuscleParams& m = p.muscles[n.id];
    m.moment_arms = n.arms;
    for (MomentArmPoly& a : m.moment_arms) {
      a.r0_m *= length_scale;
      a.r1_m_per_rad *= length_scale;
      a.r2_m_per_rad2 *= length_scale;
    }
    m.recruitment = n.recruitment;
    ContractionParams& c = m.contraction;
    c.max_force_n = n.max_force_n * force_scale;
    c.optimal_fibre_length_m = n.optimal_fibre_length_m * length_scale;
    c.tendon_slack_length_m = n.tendon_slack_length_m * length_scale;
    c.mt_length_at_zero_m =
        c.tendon_slack_length_m + n.fibre_length_at_zero_lopt * c.optimal_fibre_length_m;
    for (int ch = 0; ch < kNumChannels; ++ch) {
      p.placement[n.id][ch] = ((ch == kExtChannel) == IsExtensor(n.id)) ? 1.0 : 0.0;
    }
  }
  return p;
}

Person NominalPerson() { return ScaledPerson(kNominalHeightM, kNominalMassKg); }

Person DrawPerson(const PersonSpread& spread, std::uint64_t seed) {
  ValidateSpread(spread);
  std::mt19937_64 rng(seed);
  const double height = Draw(rng, spread.height_m);
  const double mass = Draw(rng, spread.mass_kg);
  Person p = ScaledPerson(height, mass);
  p.seed = seed;
  for (SegmentParams& s : p.body.segments) {
    const double k = Draw(rng, spread.segment_mass);
    s.mass_kg *= k;
    s.inertia_kg_m2 *= k;
  }
  for (JointParams& j : p.joints) {
    j.rest_angle_rad +=
        UniformIn(rng, -spread.rest_angle_half_width_rad, spread.rest_angle_half_width_rad);
    const double k = Draw(rng, spread.joint_stiffness);
    j.flexion_stiffness_nm_per_rad *= k;
    j.extension_stiffness_nm_per_rad *= k;
    j.damping_nm_s_per_rad *= Draw(rng, spread.joint_damping);
  }
  SpreadMuscles(spread, rng, &p);
  ValidatePerson(p);
  return p;
}

}  // namespace fesim::foreign
