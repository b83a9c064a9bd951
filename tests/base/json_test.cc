#include "base/json.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fesim {
namespace {

TEST(Json, CompactAndOrdered) {
  Json j = Json::Object();
  j.Set("b", 1.5).Set("a", "x\"y").Set("n", Json(std::nan(""))).Set("v", std::vector<double>{1, 2});
  j.Set("b", true);
  EXPECT_EQ(j.Dump(0), "{\"b\":true,\"a\":\"x\\\"y\",\"n\":null,\"v\":[1,2]}\n");
}

TEST(Json, Pretty) {
  Json j = Json::Object();
  j.Set("k", Json::Array().Push(1).Push("s"));
  EXPECT_EQ(j.Dump(2), "{\n  \"k\": [\n    1,\n    \"s\"\n  ]\n}\n");
}

TEST(Json, ParseRoundTripsDump) {
  Json j = Json::Object();
  j.Set("pi", 3.141592653589793).Set("tiny", 1e-300).Set("neg", -2.5e17).Set("s", "a\"\\\n\tµ°");
  j.Set("arr", Json::Array().Push(true).Push(false).Push(Json()).Push(Json::Object()));
  j.Set("empty", Json::Array());
  for (int indent : {0, 2}) {
    const Json back = Json::Parse(j.Dump(indent));
    EXPECT_EQ(back.Dump(indent), j.Dump(indent));
  }
  const Json back = Json::Parse(j.Dump());
  EXPECT_DOUBLE_EQ(back.Find("pi")->AsNumber(), 3.141592653589793);  // shortest round trip
  EXPECT_EQ(back.Find("s")->AsString(), "a\"\\\n\tµ°");
  EXPECT_TRUE(std::isnan(back.Find("arr")->Items()[2].AsNumber()));  // null reads as NaN
  EXPECT_EQ(back.Find("missing"), nullptr);
  EXPECT_EQ(back.Keys().size(), 6u);
}

TEST(Json, ParseEscapesAndNumbers) {
  const Json j = Json::Parse(" {\"u\": \"\\u00b5\\u2192x\", \"n\": [-0.5e-3, 12E2, 0]} ");
  EXPECT_EQ(j.Find("u")->AsString(), "µ→x");
  EXPECT_DOUBLE_EQ(j.Find("n")->Items()[0].AsNumber(), -0.5e-3);
  EXPECT_DOUBLE_EQ(j.Find("n")->Items()[1].AsNumber(), 1200.0);
}

TEST(Json, ParseRejectsMalformedTextWithOffset) {
  const std::pair<const char*, const char*> cases[] = {
      {"", "byte 0: unexpected end"},
      {"{\"a\" 1}", "byte 5: expected ':'"},
      {"[1,]", "byte 3: expected a value"},
      {"[1 2]", "byte 3: expected ',' or ']'"},
      {"\"abc", "unterminated string"},
      {"01x", "unexpected data after the value"},
      {"1e999", "number out of range"},
      {"{} {}", "unexpected data"},
      {"\"\\q\"", "bad escape"},
  };
  for (const auto& [text, why] : cases) {
    try {
      Json::Parse(text, "f.json");
      ADD_FAILURE() << "accepted: " << text;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << text << " -> " << e.what();
      EXPECT_EQ(std::string(e.what()).rfind("f.json: byte ", 0), 0u) << e.what();
    }
  }
  // Deep nesting is an error, not a stack overflow.
  EXPECT_THROW(Json::Parse(std::string(100000, '[')), std::runtime_error);
}

}  // namespace
}  // namespace fesim
