#include "diagnosis/planted.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fesim::diagnosis {
namespace {

Scenario Rig() {
  return LoadScenario(std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios/hand_rig.yaml");
}

TEST(Planted, CleanDataHaveNoEffectAndAPlantedOneIsOfTheNoiseOrder) {
  const Scenario rig = Rig();
  PlantedSpec spec;
  spec.trials = 1;
  spec.duration_s = 20.0;
  spec.seed = 3;
  const PlantedDataset clean = MakePlantedDataset(rig, spec);
  EXPECT_EQ(clean.effect_rms_rad, 0.0);
  EXPECT_TRUE(clean.planted.empty());
  EXPECT_GE(clean.stiffness_scale, 0.8);
  EXPECT_LE(clean.stiffness_scale, 1.25);
  ASSERT_EQ(clean.trials.size(), 1u);
  EXPECT_TRUE(clean.trials[0].Has("q.wrist_flexion"));
  EXPECT_NEAR(clean.noise_rms_rad, 3.14159265358979 / 180.0, 1e-12);  // hand rig: 1 deg
  spec.mechanisms = {"sensor_drift"};
  const PlantedDataset drift = MakePlantedDataset(rig, spec);
  // Drift 0.0005 rad/s · t over 20 s on every angle: RMS = 0.0005 · 20 / √3.
  EXPECT_NEAR(drift.effect_rms_rad, 0.0005 * 20.0 / std::sqrt(3.0), 2e-4);
  ASSERT_EQ(drift.planted.size(), 3u);
  EXPECT_EQ(drift.planted[0].name, "sensor_drift:drift.q.wrist_flexion");
  // Same seed, same participant and noise apart from the planted effect.
  EXPECT_EQ(drift.stiffness_scale, clean.stiffness_scale);
  const auto& a = drift.trials[0].Column("q.wrist_flexion");
  const auto& b = clean.trials[0].Column("q.wrist_flexion");
  const auto& t = drift.trials[0].time;
  for (std::size_t i = 0; i < a.size(); i += 97) {
    if (std::isfinite(a[i])) {
      EXPECT_NEAR(a[i] - b[i], 0.0005 * t[i], 1e-9);
    }
  }
  spec.mechanisms = {"no_such_effect"};
  EXPECT_THROW(MakePlantedDataset(rig, spec), std::invalid_argument);
}

TEST(Planted, NoiselessReadsOfTheTwinsDifferByTheEffectAndTheMeasuredByTheNoise) {
  // The clean twin of bench/diagnosis_suite.cc --twin: the same seed without the mechanism. Its
  // noiseless reads differ from the planted data set's by the effect, whose RMS is the reported
  // effect size; each data set's measured outputs differ from its noiseless reads by the sensor
  // noise (the same draws in both, σ = 1°), on the measured record's grid.
  const Scenario rig = Rig();
  PlantedSpec spec;
  spec.trials = 1;
  spec.duration_s = 20.0;
  spec.seed = 11;
  const PlantedDataset twin = MakePlantedDataset(rig, spec);
  spec.mechanisms = {"sensor_drift"};
  const PlantedDataset with = MakePlantedDataset(rig, spec);
  ASSERT_EQ(with.truth.size(), 1u);
  ASSERT_EQ(twin.truth.size(), 1u);
  const Trial &m = with.trials[0], &z = with.truth[0], &m0 = twin.trials[0], &z0 = twin.truth[0];
  ASSERT_EQ(z.time, m.time);
  ASSERT_EQ(z0.time, m.time);
  double effect_ss = 0.0, noise_ss = 0.0;
  long effect_n = 0, noise_n = 0, read = 0;
  for (const std::string q : {"q.wrist_flexion", "q.mcp_flexion", "q.pip_flexion"}) {
    for (std::size_t i = 0; i < m.size(); ++i) {
      const double e = z.Column(q)[i] - z0.Column(q)[i];
      if (std::isfinite(e)) {
        effect_ss += e * e;
        ++effect_n;
      }
      if (std::isfinite(m.Column(q)[i])) {
        ASSERT_TRUE(std::isfinite(z.Column(q)[i])) << q << " at " << m.time[i];
        ++read;
        const double noise = m.Column(q)[i] - z.Column(q)[i];
        // the same noise draw in the twin
        EXPECT_NEAR(m0.Column(q)[i] - z0.Column(q)[i], noise, 1e-12);
        noise_ss += noise * noise;
        ++noise_n;
      }
    }
  }
  ASSERT_GT(read, 1000);
  EXPECT_NEAR(std::sqrt(effect_ss / effect_n), with.effect_rms_rad, 1e-12);
  EXPECT_NEAR(std::sqrt(noise_ss / noise_n), with.noise_rms_rad, 0.05 * with.noise_rms_rad);
}

TEST(Planted, PostureAndVelocityEffectsAtScaleOneReachTheNoiseOnBothProtocols) {
  // Issue 7 asks for effect sizes from "effect RMS = noise RMS" upward, so effect scale 1 (the
  // suite's smallest) must reach it whatever the participant and protocol. The range-limit
  // stiffening at κ = 8/rad gave 0.14–0.57 × noise on steps (the wrist stays below ~50°, far
  // from the 80° limit). (spasticity is not here: 0.2–0.25 × noise on the grid, docs/diagnosis.md.)
  const Scenario rig = Rig();
  for (const std::string mechanism : {"passive_stiffness_nonlinear"}) {
    for (const std::string protocol : {"steps", "grid"}) {
      for (std::uint64_t seed : {1001u, 1002u, 1003u}) {
        PlantedSpec spec;
        spec.mechanisms = {mechanism};
        spec.protocol = protocol;
        spec.trials = 1;
        spec.duration_s = 40.0;
        spec.seed = seed;
        const PlantedDataset d = MakePlantedDataset(rig, spec);
        EXPECT_GE(d.effect_rms_rad, d.noise_rms_rad) << mechanism << " " << protocol << " " << seed;
      }
    }
  }
}

TEST(Planted, AnEffectBelowTheFloorIsRaisedToItWithTheSameParticipantAndProtocol) {
  const Scenario rig = Rig();
  PlantedSpec spec;
  spec.mechanisms = {"delay"};
  spec.trials = 1;
  spec.duration_s = 20.0;
  spec.seed = 7;
  spec.effect_scale = 0.2;  // δ = 14 ms: well below the 1° noise
  const PlantedDataset low = MakePlantedDataset(rig, spec);
  ASSERT_LT(low.effect_rms_rad, 0.8 * low.noise_rms_rad);
  PlantedSpec raised = spec;
  const PlantedDataset d = MakePlantedDatasetAtLeast(rig, &raised, 1.0);
  EXPECT_GE(d.effect_rms_rad, d.noise_rms_rad);
  EXPECT_LT(d.effect_rms_rad, 1.6 * d.noise_rms_rad);  // raised to the floor, not far past it
  EXPECT_GT(raised.effect_scale, spec.effect_scale);
  ASSERT_EQ(d.planted.size(), 1u);
  EXPECT_NEAR(d.planted[0].value, 0.07 * raised.effect_scale, 1e-12);  // the spec's scale
  EXPECT_EQ(d.stiffness_scale, low.stiffness_scale);
  EXPECT_EQ(d.strength_scale, low.strength_scale);
  EXPECT_EQ(d.trials[0].Column("u.ext"), low.trials[0].Column("u.ext"));
  // At or above the floor: returned as generated.
  PlantedSpec again = raised;
  const PlantedDataset same = MakePlantedDatasetAtLeast(rig, &again, 1.0);
  EXPECT_EQ(again.effect_scale, raised.effect_scale);
  EXPECT_EQ(same.effect_rms_rad, d.effect_rms_rad);
  // Capped: never above max_scale, even when the floor is not reached.
  PlantedSpec capped = spec;
  const PlantedDataset c = MakePlantedDatasetAtLeast(rig, &capped, 1.0, 0.3);
  EXPECT_EQ(capped.effect_scale, 0.3);
  EXPECT_LT(c.effect_rms_rad, c.noise_rms_rad);
  EXPECT_EQ(PlantedProtocols("spasticity"), std::vector<std::string>{"steps"});
  EXPECT_EQ(PlantedProtocols("delay"), (std::vector<std::string>{"steps", "grid"}));
}

}  // namespace
}  // namespace fesim::diagnosis
