// Issue 28: which rows and time stamps the identification methods accept
// (identification/method_support.h): interleaved sensor rates, rounded tracker time stamps,
// implausible sample rates, and data errors that name the trial's file.
#include "identification/method_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "identification/spline_hammerstein.h"
#include "identification/tremor_arx.h"

namespace fesim::identification {
namespace {

std::string ErrorOf(const Trial& t) {
  try {
    UniformSamplePeriod(t, "train trial 0");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(no error)";
}

Trial Uniform(std::size_t n, double T, int decimals) {
  Trial t;
  const double scale = std::pow(10.0, decimals);
  for (std::size_t i = 0; i < n; ++i) {
    t.time.push_back(std::round(static_cast<double>(i) * T * scale) / scale);
  }
  t.AddColumn("q.wrist_flexion", std::vector<double>(n, 0.1));
  t.metadata["source"] = "rec.csv";
  return t;
}

// The hand rig as `fesim simulate` writes it: 60 Hz angle rows and 100 Hz torque rows on one
// time column (the union of both grids), NaN where a sensor did not sample, inputs on every row.
TEST(SensorRows, KeepsTheNeededSensorsRowsAndItsDropouts) {
  std::vector<std::pair<double, int>> rows;  // (time, 1: angle row, 2: torque row, 3: both)
  for (int i = 0; i <= 18; ++i) rows.emplace_back(i / 60.0, 1);
  for (int j = 0; j <= 30; ++j) {
    bool merged = false;
    for (auto& r : rows) {
      if (std::abs(r.first - j / 100.0) < 1e-12) {
        r.second = 3;
        merged = true;
      }
    }
    if (!merged) rows.emplace_back(j / 100.0, 2);
  }
  std::sort(rows.begin(), rows.end());
  Trial t;
  std::vector<double> u, q, tau;
  for (const auto& [time, kind] : rows) {
    t.time.push_back(time);
    u.push_back(100.0);
    q.push_back(kind & 1 ? time : NAN);
    tau.push_back(kind & 2 ? 0.5 : NAN);
  }
  // A tracker dropout at t = 7/60 s (no torque sample there): the row stays, its angle NaN.
  const std::size_t dropout = std::find(t.time.begin(), t.time.end(), 7 / 60.0) - t.time.begin();
  q[dropout] = NAN;
  t.AddColumn("u.bic", u);
  t.AddColumn("q.elbow_flexion", q);
  t.AddColumn("tau.wrist_flexion", tau);
  ASSERT_EQ(t.size(), 19u + 31u - 7u);  // 0, 0.05, …, 0.3 s are on both grids
  EXPECT_THROW(UniformSamplePeriod(t, "both"), std::runtime_error);
  const Trial angles = SensorRows(t, {"q.elbow_flexion"});
  ASSERT_EQ(angles.size(), 19u);
  for (std::size_t i = 0; i < angles.size(); ++i) EXPECT_EQ(angles.time[i], i / 60.0);
  EXPECT_TRUE(std::isnan(angles.Column("q.elbow_flexion")[7]));
  EXPECT_NEAR(UniformSamplePeriod(angles, "angles"), 1.0 / 60.0, 1e-15);
  const Trial torques = SensorRows(t, {"tau.wrist_flexion"});
  ASSERT_EQ(torques.size(), 31u);  // not the angle dropout row: it is off the 100 Hz grid
  EXPECT_NEAR(UniformSamplePeriod(torques, "torques"), 0.01, 1e-15);
  // A record of one sensor: every row kept.
  EXPECT_EQ(SensorRows(Uniform(10, 0.01, 9), {"q.wrist_flexion"}).size(), 10u);
}

TEST(UniformSamplePeriod, AcceptsRoundedTrackerTimeStampsWithinAQuarterStep) {
  // 60 Hz written to 4 decimals: steps 0.0166 and 0.0167 s.
  EXPECT_NEAR(UniformSamplePeriod(Uniform(600, 1.0 / 60.0, 4), "t"), 1.0 / 60.0, 1e-7);
  // Jitter of ±20 % of a step passes, 30 % does not.
  Trial jitter = Uniform(100, 0.01, 12);
  for (std::size_t i = 1; i + 1 < jitter.size(); ++i) jitter.time[i] += (i % 2 ? 0.002 : -0.002);
  EXPECT_EQ(ErrorOf(jitter), "(no error)");
  jitter.time[51] += 0.001;
  EXPECT_EQ(ErrorOf(jitter),
            "train trial 0 (rec.csv): column time is not uniformly sampled (near t = 0.513 s, "
            "more than 25 % of the 0.01 s step off its grid point); resample first");
  // A missing row is not jitter.
  Trial gap = Uniform(100, 0.01, 12);
  gap.time.erase(gap.time.begin() + 40);
  gap.columns[0].erase(gap.columns[0].begin() + 40);
  EXPECT_NE(ErrorOf(gap).find("is not uniformly sampled"), std::string::npos) << ErrorOf(gap);
}

TEST(UniformSamplePeriod, RefusesImplausibleRatesWithTheReason) {
  // 100 Hz with time in ms: steps of 10 "s".
  EXPECT_EQ(ErrorOf(Uniform(100, 10.0, 9)),
            "train trial 0 (rec.csv): column time: sample period 10 s (0.1 Hz) is implausible for "
            "a measured trial (allowed: 1e-05 to 1 s; time in ms?)");
  EXPECT_EQ(ErrorOf(Uniform(100, 1e-6, 12))
                .find("train trial 0 (rec.csv): column time: sample "
                      "period 1e-06 s (1e+06 Hz) is implausible"),
            0u);
  EXPECT_EQ(ErrorOf(Uniform(100, 1.0, 9)), "(no error)");
  EXPECT_EQ(ErrorOf(Uniform(100, 2e-5, 12)), "(no error)");
}

TEST(RequireColumns, ErrorsNameTheTrialsFile) {
  Trial t = Uniform(5, 0.01, 9);
  t.MutableColumn("q.wrist_flexion")[2] = NAN;
  try {
    RequireColumns(t, {"q.wrist_flexion"}, "test trial 1");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "test trial 1 (rec.csv): column q.wrist_flexion is not finite at t = 0.02 s "
              "(NaN/dropouts must be removed first)");
  }
  EXPECT_THROW(RequireColumns(t, {"q.x"}, "x"), std::runtime_error);
}

// Issue 28: a constant output is named as the cause, instead of the fit's "regressor matrix is
// rank deficient".
TEST(RequireVaryingOutput, ConstantOutputIsNamed) {
  Trial t = Uniform(200, 0.01, 9);
  std::vector<double> fcr, ecr;
  for (std::size_t k = 0; k < t.size(); ++k) {
    fcr.push_back(30.0 + static_cast<double>(k % 50));
    ecr.push_back(45.0);
  }
  t.AddColumn("u.fcr", fcr);
  t.AddColumn("u.ecr", ecr);
  t.MutableColumn("q.wrist_flexion")[3] = NAN;  // a dropout does not make it vary
  const std::string expected =
      "train: output column q.wrist_flexion is constant (0.1 in every sample): nothing to "
      "identify (the regressor matrix would be rank deficient)";
  for (const MethodEntry& m : {TremorArxMethod(), SplineArxMethod()}) {
    try {
      Trial one = t;
      if (m.name != "tremor-arx") {  // spline-arx: one input
        one.names.erase(one.names.begin() + 2);
        one.columns.erase(one.columns.begin() + 2);
      }
      m.run({one}, {}, nullptr);
      ADD_FAILURE() << m.name << ": no error";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()), expected) << m.name;
    }
  }
  t.MutableColumn("q.wrist_flexion")[7] = 0.2;
  EXPECT_NO_THROW(RequireVaryingOutput({t}, "q.wrist_flexion", "train"));
}

}  // namespace
}  // namespace fesim::identification
