/*
 * pcl_mi: a fixed split of work over a few threads.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <algorithm>
#include <exception>
#include <thread>
#include <vector>

namespace pcl_mi {
namespace core {

/** \brief Runs task(0) .. task(tasks - 1) on up to \a threads threads (the caller's
 * included) and rethrows the first exception. Each task must write only its own results:
 * the split into tasks, not the number of threads, then fixes every floating-point sum,
 * so results do not depend on the thread count. */
template <typename Task>
void
parallelFor(int tasks, int threads, const Task& task)
{
  threads = std::max(1, std::min(threads, tasks));
  std::vector<std::exception_ptr> failures(static_cast<std::size_t>(threads));
  auto run = [&](int worker) {
    try {
      for (int i = worker; i < tasks; i += threads)
        task(i);
    }
    catch (...) {
      failures[static_cast<std::size_t>(worker)] = std::current_exception();
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
