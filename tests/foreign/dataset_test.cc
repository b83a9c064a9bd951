// foreign/dataset.cc: a drawn person's trials of the hand rig's protocols, clean or with effects
// raised to the floor.
#include "foreign/dataset.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace fesim::foreign {
namespace {

DatasetSpec ShortSpec() {
  DatasetSpec spec;
  spec.person_seed = 3;
  spec.seed = 11;
  spec.protocols = {"steps", "steps"};
  spec.duration_s = 8.0;
  return spec;
}

/// RMS of measured − truth over the finite samples of every q.* column (the sensor noise).
double NoiseRms(const Dataset& d) {
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t t = 0; t < d.trials.size(); ++t) {
    for (const auto& name : d.trials[t].NamesWithPrefix("q.")) {
      const auto& y = d.trials[t].Column(name);
      const auto& x = d.truth[t].Column(name);
      for (std::size_t i = 0; i < y.size(); ++i) {
        if (!std::isfinite(y[i])) continue;
        sum += (y[i] - x[i]) * (y[i] - x[i]);
        ++n;
      }
    }
  }
  return std::sqrt(sum / static_cast<double>(n));
}

TEST(ForeignDataset, ACleanPersonsTrialsAreTheTruthPlusTheSensorsNoiseOnItsGrid) {
  const Dataset d = MakeDataset(ShortSpec());
  ASSERT_EQ(d.trials.size(), 2u);
  ASSERT_EQ(d.truth.size(), 2u);
  EXPECT_EQ(d.effect_rms_rad, 0.0);
  EXPECT_EQ(d.noise_rms_rad, 0.01);
  for (const auto& trial : d.trials) {
    ASSERT_EQ(trial.size(), 8u * 60u + 1u);  // 60 Hz from 0 to 8 s
    EXPECT_NEAR(trial.time[60], 1.0, 1e-9);
    EXPECT_TRUE(trial.Has("u.ext") && trial.Has("u.flex"));
    EXPECT_EQ(trial.NamesWithPrefix("q.").size(), 3u);
  }
  EXPECT_NEAR(NoiseRms(d), 0.01, 0.001);  // σ = 0.01 rad over ≈ 2 800 samples
  // The two steps trials draw their own sequences.
  EXPECT_NE(d.trials[0].Column("u.ext"), d.trials[1].Column("u.ext"));
}

TEST(ForeignDataset, APlantedEffectIsRaisedToTheFloorAndTheSameSeedGivesTheSameData) {
  DatasetSpec spec = ShortSpec();
  spec.effects = {{"sensor_drift", 0.1}};
  spec.floor = 1.0;
  const Dataset d = MakeDataset(spec);
  ASSERT_EQ(d.effects.size(), 1u);
  EXPECT_GT(d.effects[0].scale, 0.1);  // 0.1 × 0.5 mrad/s over 8 s is far below the noise
  EXPECT_GE(d.effect_rms_rad, 1.0 * d.noise_rms_rad);
  const Dataset again = MakeDataset(spec);
  EXPECT_EQ(again.trials[1].Column("q.wrist_flexion"), d.trials[1].Column("q.wrist_flexion"));
  spec.person_seed = 4;
  EXPECT_NE(MakeDataset(spec).truth[0].Column("q.wrist_flexion"),
            d.truth[0].Column("q.wrist_flexion"));
}

TEST(ForeignDataset, AHeldProgramReplaysARecordsInputsAtEverySample) {
  // A record of another simulator: 2 channels, 60 Hz, a switch on one channel at t = 0.5 s and
  // on the other at 1 s.
  Trial record;
  std::vector<double> ext, flex;
  for (int k = 0; k <= 90; ++k) {
    const double t = k / 60.0;
    record.time.push_back(t);
    ext.push_back(t < 0.5 - 1e-9 ? 0.0 : 150.0);
    flex.push_back(t < 1.0 - 1e-9 ? 50.0 : 0.0);
  }
  record.AddColumn("u.ext", ext);
  record.AddColumn("u.flex", flex);
  const protocols::StimulationProgram p = HeldProgram(record);
  EXPECT_EQ(p.channels, (std::vector<std::string>{"ext", "flex"}));
  ASSERT_EQ(p.times_s.size(), 3u);  // the start and the two switches
  EXPECT_NEAR(p.times_s[1], 0.5, 1e-12);
  EXPECT_NEAR(p.times_s[2], 1.0, 1e-12);
  EXPECT_NEAR(p.duration_s, 1.5, 1e-12);
  for (std::size_t k = 0; k < record.size(); ++k) {
    const std::vector<double> v = protocols::ValueAt(p, record.time[k]);
    EXPECT_EQ(v[0], ext[k]) << k;
    EXPECT_EQ(v[1], flex[k]) << k;
  }
  // Simulated on a foreign person, the record's inputs come back at the same times.
  const ForeignTrial t = SimulateTrial(NominalPerson(), {}, p, SensorSpec{}, 5);
  ASSERT_EQ(t.measured.size(), record.size());
  EXPECT_EQ(t.measured.Column("u.ext"), ext);
  Trial empty;
  empty.time = {0.0, 1.0};
  EXPECT_THROW(HeldProgram(empty), std::invalid_argument);
}

TEST(ForeignDataset, AnUnknownProtocolIsNamed) {
  try {
    DatasetProgram("ramp", 10.0, 1);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("ramp"), std::string::npos) << e.what();
  }
  EXPECT_EQ(DatasetProgram("grid", 10.0, 1).duration_s, 56.0);
}

}  // namespace
}  // namespace fesim::foreign
