/*
 * pcl_mi: a fixed split of work over a few threads.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <functional>
#include <vector>

namespace pcl_mi {
namespace core {

/** \brief Runs \a work on the calling thread and on \a helpers other threads at once, and
 * returns when every one of them has returned; \a work must not throw. The helpers are
 * kept between calls, polling briefly and then asleep: an alignment splits its work
 * hundreds of times, and starting threads for each split costs about as much as a small
 * split's work. Where the kept threads are busy (a split inside a split, or alignments on
 * several user threads) or the process has forked since they started, fresh threads run
 * it. */
void
runOnThreads(int helpers, const std::function<void()>& work);

/** \brief Runs task(0, worker) .. task(tasks - 1, worker) on up to \a threads threads (the
 * caller's included), each thread taking the next task as it becomes free, and rethrows
 * the first failure (by task order). \a worker (0 .. threads - 1) names the thread that
 * runs the task, one index per thread, so a task may use that thread's own state (an
 * evaluator, a scratch buffer) without a lock. Each task must write only its own results:
 * the split into tasks, not the threads or the order they run in, then fixes every
 * floating-point sum, so results do not depend on the thread count. */
template <typename Task>
void
parallelForOnWorkers(int tasks, int threads, const Task& task)
{
  threads = std::max(1, std::min(threads, tasks));
  std::vector<std::exception_ptr> failures(static_cast<std::size_t>(std::max(tasks, 0)));
  std::atomic<int> next{0};
  std::atomic<int> workers{0};
  const std::function<void()> run = [&] {
    const int worker = workers++;
    for (int i = next++; i < tasks; i = next++) {
      try {
        task(i, worker);
      }
      catch (...) {
        failures[static_cast<std::size_t>(i)] = std::current_exception();
      }
    }
  };
  if (threads == 1)
    run();
  else
    runOnThreads(threads - 1, run);
  for (const auto& f : failures)
    if (f)
      std::rethrow_exception(f);
}

/** \brief parallelForOnWorkers() for tasks that need no thread state: task(0) ..
 * task(tasks - 1). */
template <typename Task>
void
parallelFor(int tasks, int threads, const Task& task)
{
  parallelForOnWorkers(tasks, threads, [&task](int i, int) { task(i); });
}

} // namespace core
} // namespace pcl_mi
