/*
 * pcl_mi: a fixed split of work over a few threads.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <thread>
#include <vector>

namespace pcl_mi {
namespace core {

/** \brief Runs task(0) .. task(tasks - 1) on up to \a threads threads (the caller's
 * included), each thread taking the next task as it becomes free, and rethrows the first
 * failure (by task order). Each task must write only its own results: the split into
 * tasks, not the threads or the order they run in, then fixes every floating-point sum,
 * so results do not depend on the thread count. */
template <typename Task>
void
parallelFor(int tasks, int threads, const Task& task)
{
  threads = std::max(1, std::min(threads, tasks));
  std::vector<std::exception_ptr> failures(static_cast<std::size_t>(std::max(tasks, 0)));
  std::atomic<int> next{0};
  auto run = [&](int) {
    for (int i = next++; i < tasks; i = next++) {
      try {
        task(i);
      }
      catch (...) {
        failures[static_cast<std::size_t>(i)] = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  for (int w = 1; w < threads; ++w)
    pool.emplace_back(run, w);
  run(0);
  for (auto& t : pool)
    t.join();
  for (const auto& f : failures)
    if (f)
      std::rethrow_exception(f);
}

} // namespace core
} // namespace pcl_mi
