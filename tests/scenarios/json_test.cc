#include "scenarios/json.h"

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

}  // namespace
}  // namespace fesim
