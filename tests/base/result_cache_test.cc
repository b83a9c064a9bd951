// The resume cache shared by `fesim benchmark` and `fesim diagnose` (base/result_cache.h).
#include "base/result_cache.h"

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <limits>

namespace fesim {
namespace {

TEST(ResultCache, KeyHashesVersionLayoutAndParts) {
  const ResultCache a("/unused", "1.2.3", "fit-cache-2");
  // The benchmark's fit cache (paper_benchmark/work.cc) keyed "<version>\nfit-cache-2\n<part>…"
  // before this class existed; the same text keeps old cache directories valid.
  EXPECT_EQ(a.Key({"fit", "spline-arx"}), Fnv1a64Hex("1.2.3\nfit-cache-2\nfit\nspline-arx"));
  EXPECT_NE(a.Key({"fit", "spline-arx"}), a.Key({"fit", "spline-oe"}));
  EXPECT_NE(a.Key({"ab", "c"}), a.Key({"a", "bc"}));  // parts are separated
  EXPECT_NE(a.Key({"x"}), ResultCache("/unused", "1.2.4", "fit-cache-2").Key({"x"}));
  EXPECT_NE(a.Key({"x"}), ResultCache("/unused", "1.2.3", "diagnose-cache-1").Key({"x"}));
  EXPECT_EQ(a.Path({"x"}), "/unused/" + a.Key({"x"}));
}

TEST(ResultCache, StoresAtomicallyAndReadsBackExactNumbers) {
  const std::string dir = ::testing::TempDir() + "result_cache/sub";
  std::filesystem::remove_all(::testing::TempDir() + "result_cache");
  ResultCache cache(dir, "v", "test-1");
  Json out;
  EXPECT_FALSE(cache.Load({"a"}, &out));
  EXPECT_FALSE(std::filesystem::exists(dir));  // nothing is created before the first Store
  const std::vector<double> values = {0.1 + 0.2, 1.0 / 3.0, 5e-324, -1.7976931348623157e308,
                                      std::nan("")};
  Json v = Json::Object();
  v.Set("x", values).Set("n", 42);
  cache.Store({"a"}, v);
  EXPECT_FALSE(cache.Load({"b"}, &out));
  ASSERT_TRUE(cache.Load({"a"}, &out));
  const auto& x = out.Find("x")->Items();
  ASSERT_EQ(x.size(), values.size());
  for (std::size_t k = 0; k + 1 < values.size(); ++k) EXPECT_EQ(x[k].AsNumber(), values[k]) << k;
  EXPECT_TRUE(std::isnan(x.back().AsNumber()));
  EXPECT_EQ(out.Find("n")->AsNumber(), 42.0);
  int files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    EXPECT_EQ(e.path().filename().string(), cache.Key({"a"}) + ".json");
    ++files;
  }
  EXPECT_EQ(files, 1);  // no temporary left
}

TEST(ResultCache, FailedFirstStoreLeavesNoEmptyDirectories) {
  // A file-size limit makes the write fail the way a full disk does (EFBIG instead of ENOSPC;
  // SIGXFSZ ignored so write() returns the error instead of killing the test).
  const std::string base = ::testing::TempDir() + "result_cache_full";
  std::filesystem::remove_all(base);
  MakeDirs(base);
  ResultCache cache(base + "/out/cache", "v", "test-1");
  Json v = Json::Object();
  v.Set("x", std::vector<double>(1000, 1.0 / 3.0));
  rlimit old_limit{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old_limit), 0);
  rlimit small = old_limit;
  small.rlim_cur = 64;  // bytes
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  std::string message;
  try {
    cache.Store({"a"}, v);
  } catch (const std::runtime_error& e) {
    message = e.what();
  }
  ::setrlimit(RLIMIT_FSIZE, &old_limit);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_NE(message.find(base + "/out/cache/"), std::string::npos) << message;
  EXPECT_NE(message.find("write failed"), std::string::npos) << message;
  EXPECT_FALSE(std::filesystem::exists(base + "/out")) << "empty directories left behind";
  EXPECT_TRUE(std::filesystem::exists(base));  // what existed before is not touched
  // Once the disk has room, the same cache works, and a later failure keeps what exists.
  cache.Store({"a"}, v);
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  std::signal(SIGXFSZ, SIG_IGN);
  EXPECT_THROW(cache.Store({"b"}, v), std::runtime_error);
  ::setrlimit(RLIMIT_FSIZE, &old_limit);
  std::signal(SIGXFSZ, old_handler);
  Json out;
  EXPECT_TRUE(cache.Load({"a"}, &out));
  EXPECT_FALSE(cache.Load({"b"}, &out));
}

TEST(ResultCache, MalformedEntryIsAnErrorNamingTheFile) {
  const std::string dir = ::testing::TempDir() + "result_cache_bad";
  MakeDirs(dir);
  const ResultCache cache(dir, "v", "test-1");
  WriteFileAtomic(cache.Path({"a"}) + ".json", "{\"x\": [1, 2");
  Json out;
  try {
    cache.Load({"a"}, &out);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(cache.Path({"a"}) + ".json: byte", 0), 0u) << e.what();
  }
}

TEST(ResultCache, TrialsRoundTripThroughJsonText) {
  Trial t;
  t.metadata["name"] = "p1";
  t.time = {0.0, 0.01, 0.02};
  t.AddColumn("q.elbow_flexion", {0.1, std::nan(""), 12.5});  // beyond a full turn: kept
  t.AddColumn("u.bic", {0.0, 150.0, 300.0});
  const std::vector<Trial> back =
      TrialsFromJson(Json::Parse(TrialsToJson({t, t}).Dump(0)), "cache.json");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[1].metadata.at("name"), "p1");
  EXPECT_EQ(back[1].time, t.time);
  EXPECT_EQ(back[1].names, t.names);
  EXPECT_EQ(back[1].Column("q.elbow_flexion")[2], 12.5);
  EXPECT_TRUE(std::isnan(back[1].Column("q.elbow_flexion")[1]));
  EXPECT_EQ(back[1].Column("u.bic"), t.Column("u.bic"));
}

TEST(ResultCache, MalformedTrialsAreAnErrorNamingTheSource) {
  for (const char* text : {"{}", "[{\"time\": [0]}]",
                           "[{\"metadata\": {}, \"time\": [0, 1], "
                           "\"columns\": {\"q.a\": [1]}}]",
                           "[{\"metadata\": {\"a\": 1}, \"time\": [], \"columns\": {}}]"}) {
    try {
      TrialsFromJson(Json::Parse(text), "cache.json");
      FAIL() << text;
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()).rfind("cache.json: cached trials: ", 0), 0u) << e.what();
    }
  }
}

TEST(ResultCache, ExactNumberTextRoundTrips) {
  for (const double v : {0.1, 1.0 / 3.0, 6.02214076e23, -0.0, 5e-324}) {
    EXPECT_EQ(std::strtod(ExactNumberText(v).c_str(), nullptr), v) << ExactNumberText(v);
  }
  EXPECT_EQ(ExactNumberText(0.5), "0.5");
}

// Issue 28: a resumed run counts a file as written only when it still has the recorded size and
// hash; every kind of damage is named with the file.
TEST(WrittenFile, RecordDetectsTruncationEditsAndLoss) {
  const std::string dir = ::testing::TempDir() + "written_file";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir + "/p1");
  const std::string text = "time,q.x\n0,1\n0.01,2\n0.02,3\n";
  WriteFileAtomic(dir + "/p1/a.csv", text);
  const Json record = WrittenFileRecord("p1/a.csv", text);
  EXPECT_EQ(record.Find("bytes")->AsNumber(), static_cast<double>(text.size()));
  EXPECT_EQ(record.Find("fnv1a64")->AsString(), Fnv1a64Hex(text));
  EXPECT_EQ(CheckWrittenFile(dir, record), "");
  // Truncated at a row boundary: still a valid CSV, but not what was written.
  WriteFileAtomic(dir + "/p1/a.csv", text.substr(0, text.size() - 8));
  EXPECT_EQ(CheckWrittenFile(dir, record), dir + "/p1/a.csv: " + std::to_string(text.size() - 8) +
                                               " bytes, " + std::to_string(text.size()) +
                                               " were written");
  std::string edited = text;
  edited[edited.size() - 2] = '4';
  WriteFileAtomic(dir + "/p1/a.csv", edited);
  EXPECT_EQ(CheckWrittenFile(dir, record),
            dir + "/p1/a.csv: contents differ from what was written (same size, other hash)");
  std::filesystem::remove(dir + "/p1/a.csv");
  EXPECT_EQ(CheckWrittenFile(dir, record), dir + "/p1/a.csv: missing");
  std::filesystem::create_directories(dir + "/p1/a.csv");
  EXPECT_EQ(CheckWrittenFile(dir, record), dir + "/p1/a.csv: missing");
  EXPECT_THROW(CheckWrittenFile(dir, Json::Object()), std::runtime_error);
}

}  // namespace
}  // namespace fesim
