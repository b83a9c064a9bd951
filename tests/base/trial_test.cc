#include "base/trial.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>

namespace fesim {
namespace {

constexpr double kPi = 3.14159265358979323846;

Trial MakeTrial() {
  Trial t;
  t.metadata["seed"] = "7";
  t.metadata["scenario"] = "unit";
  t.time = {0.0, 0.025, 0.05};
  t.AddColumn("u.ch1", {0.0, 150.0, 300.0});
  t.AddColumn("q.wrist_flexion", {0.1, -0.2, 1.0 / 3.0});
  return t;
}

std::string ErrorOf(const std::string& text) {
  try {
    ParseTrialCsv(text, "x.csv");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(TrialCsv, RoundTripIsExact) {
  const Trial t = MakeTrial();
  const Trial r = ParseTrialCsv(FormatTrialCsv(t), "mem");
  EXPECT_EQ(r.metadata, t.metadata);
  EXPECT_EQ(r.time, t.time);
  EXPECT_EQ(r.names, t.names);
  EXPECT_EQ(r.columns, t.columns);  // shortest round-trip formatting is exact
  EXPECT_EQ(FormatTrialCsv(r), FormatTrialCsv(t));
}

TEST(TrialCsv, DegreesConvertedAndEmptyCellsAreNaN) {
  const Trial r = ParseTrialCsv("time,q.wrist_deg,q.mcp\n0,90,\n1,-45,nan\n", "mem");
  ASSERT_TRUE(r.Has("q.wrist"));
  EXPECT_NEAR(r.Column("q.wrist")[0], kPi / 2, 1e-15);
  EXPECT_NEAR(r.Column("q.wrist")[1], -kPi / 4, 1e-15);
  EXPECT_TRUE(std::isnan(r.Column("q.mcp")[0]));
  EXPECT_TRUE(std::isnan(r.Column("q.mcp")[1]));
}

TEST(TrialCsv, BadInputNamesFileLineAndColumn) {
  EXPECT_EQ(ErrorOf("t,q.a\n0,1\n"), "x.csv:1: header must start with column 'time', found 't'");
  EXPECT_EQ(ErrorOf("time,q.a\n0,1\n1,abc\n"), "x.csv:3: column q.a: 'abc' is not a number");
  EXPECT_EQ(ErrorOf("time,q.a\n0,1,2\n"), "x.csv:2: expected 2 cells, found 3");
  EXPECT_EQ(ErrorOf("time,q.a,q.a\n0,1,2\n"), "x.csv:1: column q.a: duplicate column name");
  EXPECT_EQ(ErrorOf("time,q.a\n0,1\n0,2\n"),
            "x.csv:3: column time: 0 is not greater than the previous time");
  EXPECT_EQ(ErrorOf("time,q.a\n0,inf\n"), "x.csv:2: column q.a: 'inf' is not a number");
  EXPECT_EQ(ErrorOf(""), "x.csv:0: no header row (expected 'time,...')");
  EXPECT_EQ(ErrorOf("time,q.a\n"), "x.csv:1: no data rows");
}

TEST(TrialSto, HasOpenSimHeader) {
  const std::string sto = FormatTrialSto(MakeTrial(), "trial");
  EXPECT_NE(sto.find("nRows=3\n"), std::string::npos);
  EXPECT_NE(sto.find("nColumns=3\n"), std::string::npos);
  EXPECT_NE(sto.find("inDegrees=no\n"), std::string::npos);
  EXPECT_NE(sto.find("endheader\ntime\tu.ch1\tq.wrist_flexion\n"), std::string::npos);
}

TEST(AtomicWrite, ReplacesWholeFileAndFailsCleanly) {
  const std::string path = ::testing::TempDir() + "atomic_test.txt";
  WriteFileAtomic(path, "first");
  WriteFileAtomic(path, "second");
  EXPECT_EQ(ReadFile(path), "second");
  std::remove(path.c_str());
  EXPECT_THROW(WriteFileAtomic("/nonexistent-dir/x.txt", "y"), std::runtime_error);
  std::ifstream in("/nonexistent-dir/x.txt");
  EXPECT_FALSE(in.good());
}

TEST(TrialRecord, ColumnErrors) {
  Trial t = MakeTrial();
  EXPECT_THROW(t.AddColumn("u.ch1", {1, 2, 3}), std::invalid_argument);
  EXPECT_THROW(t.AddColumn("u.ch2", {1, 2}), std::invalid_argument);
  EXPECT_THROW(t.Column("q.none"), std::out_of_range);
  EXPECT_EQ(t.NamesWithPrefix("q."), std::vector<std::string>{"q.wrist_flexion"});
}

TEST(RegisteredTempFiles, SlotsFillFreeAndReadBack) {
  std::vector<int> slots;
  for (int k = 0; k < kMaxRegisteredTempFiles; ++k) {
    slots.push_back(RegisterTempFile("/tmp/x" + std::to_string(k)));
    ASSERT_GE(slots.back(), 0);
    EXPECT_STREQ(RegisteredTempFile(slots.back()), ("/tmp/x" + std::to_string(k)).c_str());
  }
  EXPECT_EQ(RegisterTempFile("/tmp/full"), -1);  // all slots taken
  UnregisterTempFile(slots[3]);
  EXPECT_STREQ(RegisteredTempFile(slots[3]), "");
  EXPECT_EQ(RegisterTempFile("/tmp/again"), slots[3]);
  EXPECT_EQ(RegisterTempFile(std::string(5000, 'a')), -1);  // too long for a slot
  EXPECT_EQ(RegisterTempFile(""), -1);
  for (int s : slots) UnregisterTempFile(s);
  UnregisterTempFile(-1);  // no-op
  for (int k = 0; k < kMaxRegisteredTempFiles; ++k) EXPECT_STREQ(RegisteredTempFile(k), "");
}

}  // namespace
}  // namespace fesim
