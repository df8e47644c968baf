/*
 * The thread split: every task runs once, failures come back in task order, and splits
 * inside splits or on several user threads at once do not wait for each other's threads.
 */
#include "util/parallel.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <stdexcept>
#include <thread>
#include <vector>

using pcl_mi::core::parallelFor;
using pcl_mi::core::parallelForOnWorkers;

TEST(ParallelFor, RunsEveryTaskOnceOnAnyNumberOfThreads)
{
  for (const int threads : {1, 2, 3, 8}) {
    // Many calls in a row: the kept threads serve one call after another.
    for (int call = 0; call < 200; ++call) {
      std::vector<int> runs(37, 0);
      parallelFor(static_cast<int>(runs.size()), threads, [&](int i) { ++runs[i]; });
      for (std::size_t i = 0; i < runs.size(); ++i)
        ASSERT_EQ(runs[i], 1) << "threads " << threads << ", call " << call << ", task " << i;
    }
  }
}

TEST(ParallelFor, EachWorkerHasItsOwnIndex)
{
  // Per-worker state without a lock: each worker appends the tasks it ran to its own list;
  // together the lists hold every task once, and no index reaches the thread count.
  for (const int threads : {1, 2, 3}) {
    for (int call = 0; call < 100; ++call) {
      std::vector<std::vector<int>> ran(static_cast<std::size_t>(threads));
      std::atomic<bool> in_range{true};
      parallelForOnWorkers(41, threads, [&](int i, int worker) {
        if (worker < 0 || worker >= threads) {
          in_range = false;
          return;
        }
        ran[static_cast<std::size_t>(worker)].push_back(i);
      });
      ASSERT_TRUE(in_range) << "threads " << threads;
      std::vector<int> runs(41, 0);
      for (const auto& list : ran)
        for (const int i : list)
          ++runs[static_cast<std::size_t>(i)];
      for (std::size_t i = 0; i < runs.size(); ++i)
        ASSERT_EQ(runs[i], 1) << "threads " << threads << ", call " << call << ", task " << i;
    }
  }
}

TEST(ParallelFor, RethrowsTheFirstFailureInTaskOrder)
{
  std::atomic<int> ran{0};
  try {
    parallelFor(10, 2, [&](int i) {
      ++ran;
      if (i == 3 || i == 7)
        throw std::runtime_error("task " + std::to_string(i));
    });
    FAIL() << "no failure came back";
  }
  catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "task 3");
  }
  EXPECT_EQ(ran.load(), 10); // the other tasks still ran
}

TEST(ParallelFor, SplitsInsideSplitsAndOnSeveralUserThreadsFinish)
{
  std::vector<std::thread> users;
  std::vector<int> sums(4, 0);
  for (int u = 0; u < 4; ++u)
    users.emplace_back([&, u] {
      for (int call = 0; call < 50; ++call) {
        std::vector<int> inner(6, 0);
        parallelFor(3, 2, [&](int outer) {
          parallelFor(2, 2, [&](int k) { inner[static_cast<std::size_t>(2 * outer + k)] += 1; });
        });
        for (const int v : inner)
          sums[static_cast<std::size_t>(u)] += v;
      }
    });
  for (std::thread& t : users)
    t.join();
  for (const int s : sums)
    EXPECT_EQ(s, 50 * 6);
}

TEST(ParallelFor, AForkedChildRunsItsSplitsOnFreshThreads)
{
  parallelFor(4, 2, [](int) {}); // the parent keeps a thread now
  // A death test forks: the child has none of the parent's kept threads.
  EXPECT_EXIT(
      {
        std::vector<int> runs(16, 0);
        parallelFor(16, 2, [&](int i) { ++runs[static_cast<std::size_t>(i)]; });
        int total = 0;
        for (const int r : runs)
          total += r;
        std::exit(total == 16 ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}
