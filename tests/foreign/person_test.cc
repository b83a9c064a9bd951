// Tests of foreign/person.h: the nominal person is valid and scaled as stated; DrawPerson is
// deterministic per seed and keeps every property inside its spread.
#include "foreign/person.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace fesim::foreign {
namespace {

constexpr double kRangeTol = 1e-12;  // relative slack on factor bounds (rounding)
constexpr int kPersons = 40;

void ExpectFactorIn(double value, double nominal, const UniformRange& r, const std::string& what) {
  const double f = value / nominal;
  EXPECT_GE(f, r.lo * (1 - kRangeTol)) << what;
  EXPECT_LE(f, r.hi * (1 + kRangeTol)) << what;
}

TEST(ForeignPerson, NominalIsValidWithCleanPlacement) {
  const Person p = NominalPerson();
  EXPECT_NO_THROW(ValidatePerson(p));
  EXPECT_EQ(p.seed, 0u);
  for (int m = 0; m < kNumMuscles; ++m) {
    EXPECT_EQ(p.placement[m][kExtChannel], IsExtensor(m) ? 1.0 : 0.0) << kMuscleNames[m];
    EXPECT_EQ(p.placement[m][kFlexChannel], IsExtensor(m) ? 0.0 : 1.0) << kMuscleNames[m];
  }
}

TEST(ForeignPerson, ScalingFollowsHeightAndMass) {
  const Person a = ScaledPerson(1.75, 75), b = ScaledPerson(1.75 * 1.1, 75 * 1.331);
  for (int m = 0; m < kNumMuscles; ++m) {
    EXPECT_NEAR(b.muscles[m].moment_arms[0].r0_m / a.muscles[m].moment_arms[0].r0_m, 1.1, 1e-12);
    EXPECT_NEAR(b.muscles[m].contraction.max_force_n / a.muscles[m].contraction.max_force_n,
                std::pow(1.331, 2.0 / 3.0), 1e-12);
    // The fibre is at the same normalised length at q = 0 whatever the size.
    const auto& ca = a.muscles[m].contraction;
    const auto& cb = b.muscles[m].contraction;
    EXPECT_NEAR((cb.mt_length_at_zero_m - cb.tendon_slack_length_m) / cb.optimal_fibre_length_m,
                (ca.mt_length_at_zero_m - ca.tendon_slack_length_m) / ca.optimal_fibre_length_m,
                1e-12);
  }
}

TEST(ForeignPerson, DrawIsDeterministicPerSeedAndDiffersAcrossSeeds) {
  const PersonSpread spread;
  const Person a = DrawPerson(spread, 17), b = DrawPerson(spread, 17), c = DrawPerson(spread, 18);
  EXPECT_EQ(a.height_m, b.height_m);
  EXPECT_EQ(a.muscles[kFdp].contraction.max_force_n, b.muscles[kFdp].contraction.max_force_n);
  EXPECT_EQ(a.placement[kFcu][kExtChannel], b.placement[kFcu][kExtChannel]);
  EXPECT_EQ(a.seed, 17u);
  EXPECT_NE(a.height_m, c.height_m);
  EXPECT_NE(a.muscles[kEcr].recruitment.threshold_us, c.muscles[kEcr].recruitment.threshold_us);
}

TEST(ForeignPerson, DrawnPropertiesStayInsideTheSpread) {
  const PersonSpread s;
  for (int seed = 1; seed <= kPersons; ++seed) {
    const Person p = DrawPerson(s, seed);
    ASSERT_NO_THROW(ValidatePerson(p));
    EXPECT_GE(p.height_m, s.height_m.lo);
    EXPECT_LE(p.height_m, s.height_m.hi);
    EXPECT_GE(p.mass_kg, s.mass_kg.lo);
    EXPECT_LE(p.mass_kg, s.mass_kg.hi);
    const Person n = ScaledPerson(p.height_m, p.mass_kg);
    for (int k = 0; k < kNumBodies; ++k) {
      ExpectFactorIn(p.body.segments[k].mass_kg, n.body.segments[k].mass_kg, s.segment_mass,
                     "segment mass");
    }
    for (int j = 0; j < kNumJoints; ++j) {
      EXPECT_LE(std::abs(p.joints[j].rest_angle_rad - n.joints[j].rest_angle_rad),
                s.rest_angle_half_width_rad + kRangeTol);
      ExpectFactorIn(p.joints[j].flexion_stiffness_nm_per_rad,
                     n.joints[j].flexion_stiffness_nm_per_rad, s.joint_stiffness, "stiffness");
      // One factor for both sides of a joint.
      EXPECT_NEAR(
          p.joints[j].flexion_stiffness_nm_per_rad / n.joints[j].flexion_stiffness_nm_per_rad,
          p.joints[j].extension_stiffness_nm_per_rad / n.joints[j].extension_stiffness_nm_per_rad,
          1e-12);
      ExpectFactorIn(p.joints[j].damping_nm_s_per_rad, n.joints[j].damping_nm_s_per_rad,
                     s.joint_damping, "damping");
    }
    double tau_min = 1e9, tau_max = 0.0;
    for (int m = 0; m < kNumMuscles; ++m) {
      const MuscleParams& mu = p.muscles[m];
      const MuscleParams& nu = n.muscles[m];
      ExpectFactorIn(mu.contraction.max_force_n, nu.contraction.max_force_n, s.max_force, "F_max");
      ExpectFactorIn(mu.recruitment.threshold_us, nu.recruitment.threshold_us, s.recruitment_points,
                     "u_th");
      EXPECT_GT(mu.recruitment.saturation_us, mu.recruitment.threshold_us);
      const double f = mu.activation.force_activation_tau_s / nu.activation.force_activation_tau_s;
      EXPECT_NEAR(
          mu.activation.coupling_deactivation_tau_s / nu.activation.coupling_deactivation_tau_s, f,
          1e-12);
      tau_min = std::min(tau_min, f);
      tau_max = std::max(tau_max, f);
      for (int j = 0; j < kNumCrossings; ++j) {
        const MomentArmPoly& a = mu.moment_arms[j];
        if (!a.crosses) continue;
        ExpectFactorIn(a.r0_m, nu.moment_arms[j].r0_m, s.moment_arm, "moment arm");
      }
      for (int c = 0; c < kNumChannels; ++c) {
        const bool on = (c == kExtChannel) == IsExtensor(m);
        const UniformRange& r = on ? s.placement_on : s.placement_crosstalk;
        EXPECT_GE(p.placement[m][c], r.lo);
        EXPECT_LE(p.placement[m][c], r.hi);
      }
    }
    // One common factor in [0.7, 1.3], each muscle within ±5 % of it.
    EXPECT_GE(tau_min, 0.7 * 0.95 - kRangeTol);
    EXPECT_LE(tau_max, 1.3 * 1.05 + kRangeTol);
    EXPECT_LE(tau_max / tau_min, 1.05 / 0.95 + kRangeTol);
  }
}

TEST(ForeignPerson, BadInputIsRejectedWithTheFieldName) {
  Person p = NominalPerson();
  p.placement[kFds][kFlexChannel] = 3.0;
  try {
    ValidatePerson(p);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("person.placement.fds.flex"), std::string::npos);
  }
  PersonSpread s;
  s.max_force = {2.0, 0.5};  // reversed
  try {
    DrawPerson(s, 1);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("spread.max_force"), std::string::npos);
  }
}

}  // namespace
}  // namespace fesim::foreign
