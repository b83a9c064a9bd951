#include "base/parallel.h"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <string>
#include <vector>

namespace fesim {
namespace {

TEST(ParallelFor, EveryIndexOnceForAnyThreadCount) {
  for (int threads : {-1, 0, 1, 2, 7, 100}) {
    std::vector<std::atomic<int>> hits(37);
    ParallelFor(hits.size(), threads, [&](std::size_t i) { ++hits[i]; });
    for (const auto& h : hits) EXPECT_EQ(h.load(), 1) << threads;
  }
  ParallelFor(0, 4, [](std::size_t) { FAIL() << "no items"; });
}

TEST(ParallelFor, RethrowsTheLowestFailingIndexAfterRunningAll) {
  for (int threads : {1, 2, 5}) {
    std::atomic<int> ran{0};
    try {
      ParallelFor(30, threads, [&](std::size_t i) {
        ++ran;
        if (i == 21 || i == 4 || i == 9) throw std::runtime_error(std::to_string(i));
      });
      FAIL() << "no exception";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "4") << threads;
    }
    EXPECT_EQ(ran.load(), 30) << threads;
  }
}

}  // namespace
}  // namespace fesim
