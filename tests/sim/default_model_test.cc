#include "sim/default_model.h"

#include <gtest/gtest.h>

#include "tendons/tendon_network.h"

namespace fesim::sim {
namespace {

constexpr double kFdStep = 1e-6;  // rad
constexpr double kFdTol = 1e-8;   // m
constexpr int kGridPoints = 25;

TEST(DefaultModel, FourteenMusclesFromPaperList) {
  const ModelParams p = DefaultModelParams();
  EXPECT_EQ(p.muscles.size(), 14u);
  for (const char* n : {"ECRL", "ECRB", "ECU", "FCR", "FCU", "EDC", "FDS", "FDP", "BIC", "BRA",
                        "TRI", "DELT1", "DELT3"}) {
    bool found = false;
    for (const auto& m : p.muscles) found = found || m.name == n;
    EXPECT_TRUE(found) << n;
  }
}

TEST(DefaultModel, MomentArmIsMinusLengthGradientOverTheRange) {
  // Every muscle × crossed joint, on a grid across the joint's range, others at rest.
  const ModelParams p = DefaultModelParams();
  std::vector<double> q(kNumCoordinates);
  for (int i = 0; i < kNumCoordinates; ++i) q[i] = p.coordinates[i].passive.rest_angle_rad;
  for (std::size_t m = 0; m < p.muscles.size(); ++m) {
    for (const auto& c : p.muscles[m].path.crossings) {
      const auto& range = p.coordinates[c.joint].passive;
      for (int k = 0; k <= kGridPoints; ++k) {
        auto x = q;
        x[c.joint] =
            range.min_angle_rad + (range.max_angle_rad - range.min_angle_rad) * k / kGridPoints;
        const auto r = tendons::MomentArmMatrix({p.muscles[m].path}, x);
        auto hi = x, lo = x;
        hi[c.joint] += kFdStep;
        lo[c.joint] -= kFdStep;
        const double dl = (tendons::MusculotendonLength(p.muscles[m].path, hi) -
                           tendons::MusculotendonLength(p.muscles[m].path, lo)) /
                          (2 * kFdStep);
        EXPECT_NEAR(r[c.joint], -dl, kFdTol)
            << p.muscles[m].name << " at " << CoordinateNames()[c.joint] << " = " << x[c.joint];
      }
    }
  }
}

TEST(DefaultModel, FibresOptimalAtRestAndSignsAnatomical) {
  const ModelParams p = DefaultModelParams();
  std::vector<double> rest(kNumCoordinates);
  for (int i = 0; i < kNumCoordinates; ++i) rest[i] = p.coordinates[i].passive.rest_angle_rad;
  const auto r = tendons::MomentArmMatrix(
      [&] {
        std::vector<tendons::MusclePath> paths;
        for (const auto& m : p.muscles) paths.push_back(m.path);
        return paths;
      }(),
      rest);
  const std::size_t nm = p.muscles.size();
  for (std::size_t m = 0; m < nm; ++m) {
    EXPECT_NEAR(tendons::MusculotendonLength(p.muscles[m].path, rest),
                muscles::OptimalMusculotendonLength(p.muscles[m].hill), 1e-12);
    const std::string& n = p.muscles[m].name;
    const double wrist = r[kWristFlexion * nm + m];
    if (n[0] == 'E') {
      EXPECT_LT(wrist, 0.0) << n;  // extensors extend ([Hand Hammerstein] sign pattern)
    }
    if (n == "FCR" || n == "FCU" || n == "FDS" || n == "FDP") {
      EXPECT_GT(wrist, 0.0) << n;
    }
  }
}

TEST(DefaultModel, ElectrodeChannelsReachTheirMuscleGroups) {
  const ModelParams p = DefaultModelParams();
  const auto a = BuildElectrodeMatrix(p);
  ASSERT_EQ(a.channels, 6);
  const auto idx = [&](const std::string& n) {
    for (int j = 0; j < a.muscles; ++j) {
      if (p.muscles[j].name == n) return j;
    }
    return -1;
  };
  for (const char* ext : {"ECRL", "ECRB", "ECU", "EDC"}) {
    EXPECT_GT(a(idx(ext), 0), 5 * a(idx(ext), 1)) << ext;
  }
  for (const char* flex : {"FCR", "FCU", "FDS", "FDP"}) {
    EXPECT_GT(a(idx(flex), 1), 5 * a(idx(flex), 0)) << flex;
  }
  EXPECT_EQ(a(idx("BIC"), 2), 1.0);
  EXPECT_EQ(a(idx("BRA"), 2), 0.3);
  EXPECT_EQ(a(idx("TRI"), 2), 0.0);
}

}  // namespace
}  // namespace fesim::sim
