// Tests of cluster/cluster.h. The same binary runs as one process (ctest's discovered tests) and
// under `mpirun -np 3` (test cluster_mpi_np3, see CMakeLists.txt): then rank 0 checks what came
// back, the other ranks only compute. Expected results are written so they hold for any rank
// count.
#include "cluster/cluster.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>

namespace fesim::cluster {

/// The process's cluster, made once in main (MPI can be initialised once per process).
Cluster* the_cluster = nullptr;

namespace {

std::string Square(std::size_t i) { return std::to_string(i * i); }

TEST(ClusterMap, EveryItemOnceInIndexOrder) {
  Cluster& c = *the_cluster;
  const std::size_t n = 40;
  std::size_t last_done = 0;
  const auto out = c.Map(
      n,
      [](std::size_t i) {
        // Uneven items, so that every rank gets some under dynamic assignment.
        std::this_thread::sleep_for(std::chrono::milliseconds(2 + (i % 5) * 2));
        return Square(i);
      },
      2,
      [&](std::size_t k, std::size_t i, const ItemOutcome& o) {
        last_done = k;
        EXPECT_EQ(o.payload, Square(i));  // told with the item's own outcome
      });
  if (!c.is_root()) {
    EXPECT_TRUE(out.empty());
    return;
  }
  ASSERT_EQ(out.size(), n);
  std::set<int> ranks;
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_TRUE(out[i].ok) << i;
    EXPECT_EQ(out[i].payload, Square(i)) << i;
    ranks.insert(out[i].rank);
  }
  EXPECT_EQ(last_done, n);
  // Load balancing: with 40 items of 2–10 ms every rank computes some.
  EXPECT_EQ(static_cast<int>(ranks.size()), c.size());
}

TEST(ClusterMap, FailuresAreReportedAndTheOthersFinish) {
  Cluster& c = *the_cluster;
  const auto out = c.Map(
      23,
      [](std::size_t i) -> std::string {
        if (i % 7 == 3) throw std::runtime_error("item " + std::to_string(i) + " broke");
        return Square(i);
      },
      3);
  if (!c.is_root()) return;
  ASSERT_EQ(out.size(), 23u);
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (i % 7 == 3) {
      EXPECT_FALSE(out[i].ok) << i;
      EXPECT_EQ(out[i].payload, "item " + std::to_string(i) + " broke");
    } else {
      EXPECT_TRUE(out[i].ok) << i;
      EXPECT_EQ(out[i].payload, Square(i));
    }
    EXPECT_GE(out[i].rank, 0);
    EXPECT_LT(out[i].rank, c.size());
  }
}

TEST(ClusterMap, LargeAndEmptyResultsArriveIntact) {
  Cluster& c = *the_cluster;
  const auto out = c.Map(6, [](std::size_t i) {
    if (i == 2) return std::string();
    std::string s(3'000'000 + i, '\0');
    for (std::size_t k = 0; k < s.size(); ++k) s[k] = static_cast<char>((k * 31 + i) & 0xff);
    return s;
  });
  if (!c.is_root()) return;
  ASSERT_EQ(out.size(), 6u);
  for (std::size_t i = 0; i < 6; ++i) {
    ASSERT_TRUE(out[i].ok);
    if (i == 2) {
      EXPECT_TRUE(out[i].payload.empty());
      continue;
    }
    ASSERT_EQ(out[i].payload.size(), 3'000'000 + i);
    bool same = true;
    for (std::size_t k = 0; k < out[i].payload.size(); ++k) {
      same = same && out[i].payload[k] == static_cast<char>((k * 31 + i) & 0xff);
    }
    EXPECT_TRUE(same) << i;
  }
}

TEST(ClusterMap, MapAllGivesEveryRankTheOutcomes) {
  Cluster& c = *the_cluster;
  const auto out = c.MapAll(17, [](std::size_t i) -> std::string {
    if (i == 5) throw std::runtime_error("five");
    return std::string(i * 1000, static_cast<char>('a' + i));
  });
  ASSERT_EQ(out.size(), 17u);  // on every rank
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (i == 5) {
      EXPECT_FALSE(out[i].ok);
      EXPECT_EQ(out[i].payload, "five");
      continue;
    }
    EXPECT_TRUE(out[i].ok) << i;
    EXPECT_EQ(out[i].payload, std::string(i * 1000, static_cast<char>('a' + i))) << i;
    EXPECT_GE(out[i].rank, 0);
    EXPECT_GE(out[i].seconds, 0.0);
  }
}

TEST(ClusterMap, NoItems) {
  const auto out = the_cluster->Map(0, [](std::size_t) -> std::string {
    ADD_FAILURE() << "no items";
    return {};
  });
  EXPECT_TRUE(out.empty());
}

TEST(ClusterCollectives, BroadcastAndGather) {
  Cluster& c = *the_cluster;
  const std::string from_root = c.is_root() ? std::string(100'000, 'r') + "end" : "ignored";
  EXPECT_EQ(c.Broadcast(from_root), std::string(100'000, 'r') + "end");
  const auto all = c.Gather("rank " + std::to_string(c.rank()));
  if (c.is_root()) {
    ASSERT_EQ(static_cast<int>(all.size()), c.size());
    for (int r = 0; r < c.size(); ++r) EXPECT_EQ(all[r], "rank " + std::to_string(r));
  } else {
    EXPECT_TRUE(all.empty());
  }
  c.Barrier();
}

TEST(ClusterStart, OneProcessWithoutLauncher) {
  if (StartedByMpiLauncher()) GTEST_SKIP() << "running under mpirun";
  EXPECT_EQ(the_cluster->size(), 1);
  EXPECT_EQ(the_cluster->rank(), 0);
  EXPECT_FALSE(the_cluster->is_mpi());
}

}  // namespace
}  // namespace fesim::cluster

int main(int argc, char** argv) {
  std::unique_ptr<fesim::cluster::Cluster> cluster = fesim::cluster::Cluster::Start(&argc, &argv);
  fesim::cluster::the_cluster = cluster.get();
  ::testing::InitGoogleTest(&argc, argv);
  // Only rank 0 prints gtest's report (the others' failures still fail the job's exit code).
  if (!cluster->is_root() && std::getenv("CLUSTER_TEST_VERBOSE") == nullptr) {
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  const int rc = RUN_ALL_TESTS();
  return rc;
}
