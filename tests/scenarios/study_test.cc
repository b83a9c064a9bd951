#include "scenarios/study.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "base/trial.h"
#include "sim/default_model.h"

namespace fesim {
namespace {

constexpr int kLargeCohort = 400;
constexpr double kStatTol = 0.2;  // of the sd: ≈ 4 standard errors at n = 400

TEST(Study, CohortDrawsFollowTheirDistributionsAndSeeds) {
  CohortParams c;
  c.size = kLargeCohort;
  c.seed = 7;
  c.height_m = {1.72, 0.08, 1.5, 1.95};
  c.strength_scale = {1.0, 0.2, 0.5, 1.6};
  const auto a = DrawCohort(c);
  const auto b = DrawCohort(c);
  double sum = 0, sum2 = 0;
  for (int k = 0; k < c.size; ++k) {
    EXPECT_EQ(a[k].height_m, b[k].height_m);  // same seed, same cohort
    EXPECT_GE(a[k].height_m, 1.5);
    EXPECT_LE(a[k].height_m, 1.95);
    EXPECT_GE(a[k].strength_scale, 0.5);
    EXPECT_LE(a[k].strength_scale, 1.6);
    EXPECT_EQ(a[k].omega_scale, 1.0);  // sd 0: the mean
    sum += a[k].height_m;
    sum2 += a[k].height_m * a[k].height_m;
  }
  const double mean = sum / c.size;
  EXPECT_NEAR(mean, 1.72, kStatTol * 0.08);
  EXPECT_NEAR(std::sqrt(sum2 / c.size - mean * mean), 0.08, 2 * kStatTol * 0.08);  // truncated
  EXPECT_NE(a[0].height_m, a[1].height_m);  // different participants differ
  // Participant k does not depend on the cohort size.
  c.size = 3;
  EXPECT_EQ(DrawCohort(c)[2].strength_scale, a[2].strength_scale);
  c.seed = 8;
  EXPECT_NE(DrawCohort(c)[0].height_m, a[0].height_m);
}

TEST(Study, ParticipantScalesTheModel) {
  sim::ModelParams m = sim::DefaultModelParams();
  const sim::ModelParams base = m;
  Participant p;
  p.strength_scale = 1.2;
  p.recruitment_threshold_scale = 2.0;
  p.omega_scale = 0.5;
  p.stiffness_scale = 1.5;
  p.electrode_offset_along_m = 0.004;
  ApplyParticipant(p, &m);
  EXPECT_NEAR(m.muscles[0].hill.max_isometric_force_n,
              1.2 * base.muscles[0].hill.max_isometric_force_n, 1e-9);
  EXPECT_NEAR(m.muscles[0].recruitment.beta_per_us, base.muscles[0].recruitment.beta_per_us / 2,
              1e-15);
  EXPECT_NEAR(m.muscles[3].activation_omega_rad_s, 0.5 * base.muscles[3].activation_omega_rad_s,
              1e-12);
  EXPECT_NEAR(m.coordinates[sim::kElbowFlexion].passive.stiffness_nm_per_rad,
              1.5 * base.coordinates[sim::kElbowFlexion].passive.stiffness_nm_per_rad, 1e-12);
  EXPECT_NEAR(m.array.origin.along_m, base.array.origin.along_m + 0.004, 1e-15);
}

TEST(Study, ItemsCoverParticipantsProtocolsAndRepetitions) {
  const std::string dir = ::testing::TempDir();
  WriteFileAtomic(dir + "rig.yaml",
                  "name: rig\nstimulation: {duration_s: 1, type: constant, values_us: {}}\n");
  WriteFileAtomic(dir + "st.yaml", R"(study: st
scenario: rig.yaml
repetitions: 2
cohort: {size: 3, seed: 4, height_m: {mean: 1.7, sd: 0.1, min: 1.5, max: 1.9}}
protocols:
  - {name: grid, stimulation: {type: protocol, protocol: {name: step_grid, channels: [ext, flex], u_max_us: 50, step_duration_s: 1}}}
  - {name: hold, stimulation: {duration_s: 2, type: constant, values_us: {bic: 100}}}
)");
  const Study st = LoadStudy(dir + "st.yaml", 1);
  ASSERT_EQ(st.items.size(), 3u * 2u * 2u);
  EXPECT_EQ(st.items[0].file_stem, "p1/grid_r1");
  EXPECT_EQ(st.items[11].file_stem, "p3/hold_r2");
  // Participant heights reach the model through the scenario's participant block.
  EXPECT_NEAR(st.items[4].scenario.model.segments[sim::kForearm].length_m,
              0.146 * st.participants[1].height_m, 1e-12);
  // The step grid's two repetitions traverse in opposite orders ([Hand Hammerstein] Fig. 6).
  EXPECT_NE(st.items[0].scenario.trial.stimulation.values[1],
            st.items[1].scenario.trial.stimulation.values[1]);
  EXPECT_NE(st.items[0].noise_seed, st.items[1].noise_seed);

  WriteFileAtomic(dir + "bad.yaml",
                  "study: b\nscenario: rig.yaml\ncohort: {size: 0}\nprotocols: []\n");
  try {
    LoadStudy(dir + "bad.yaml", 1);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yaml: cohort.size: 0 is outside [1, 1000]"),
              std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(IsStudy("study: x\n"));
  EXPECT_FALSE(IsStudy("name: x\n"));
}

// The same class as the scenario and benchmark-file fuzz findings (docs/reliability.md): a
// mapping used as a key is a one-line error naming the file and line, not yaml-cpp's bare
// "bad conversion".
TEST(StudyBadInput, MappingAsKeyNamesTheFile) {
  const std::string path = ::testing::TempDir() + "study_mapping_key.yaml";
  WriteFileAtomic(path, "study: s\n{a: 1}: 2\n");
  try {
    LoadStudy(path, 1);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), path + ":2: unexpected YAML structure (bad conversion)");
  }
}

// Issue 28: the study name (default DIR out/<study>, benchmark cache directories) and the
// protocol names (DIR/p<k>/<protocol>_r<r>.csv) are file stems, checked at load.
TEST(StudyBadInput, StudyAndProtocolNamesMustBeFileStems) {
  const std::string dir = ::testing::TempDir();
  WriteFileAtomic(dir + "stem_rig.yaml",
                  "name: rig\nstimulation: {duration_s: 1, type: constant, values_us: {}}\n");
  const auto error_of = [&](const std::string& study, const std::string& protocol) {
    const std::string path = dir + "stem_study.yaml";
    WriteFileAtomic(path, "study: \"" + study + "\"\nscenario: stem_rig.yaml\nprotocols:\n" +
                              "  - {name: \"" + protocol +
                              "\", stimulation: {duration_s: 1, type: constant, values_us: {}}}\n");
    try {
      LoadStudy(path, 1);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  const std::string allowed =
      "' cannot name output files (allowed: 1-200 of A-Z a-z 0-9 . _ -, not starting with '.')";
  const std::string path = dir + "stem_study.yaml";
  EXPECT_EQ(error_of("../up", "hold"), path + ": study: '../up" + allowed);
  EXPECT_EQ(error_of("", "hold"), path + ": study: '" + allowed);
  EXPECT_EQ(error_of("ok", "../../x"), path + ": protocols[0].name: '../../x" + allowed);
  EXPECT_EQ(error_of("ok", "a/b"), path + ": protocols[0].name: 'a/b" + allowed);
  EXPECT_EQ(error_of("ok", ".h"), path + ": protocols[0].name: '.h" + allowed);
  EXPECT_EQ(error_of("ok", "hold"), "(no error)");
}

}  // namespace
}  // namespace fesim
