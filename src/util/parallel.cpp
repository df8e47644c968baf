/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "util/parallel.h"

#include <unistd.h>

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>

namespace pcl_mi {
namespace core {

namespace {

/** Threads that wait for work between calls, one job at a time. */
class KeptThreads {
public:
  /** \brief Runs \a work on \a helpers kept threads besides the caller; false, with nothing
   * run, where they are in use or were started by another process (before a fork). */
  bool
  tryRun(int helpers, const std::function<void()>& work)
  {
    if (in_worker_ || owner_ != ::getpid() || in_use_.exchange(true))
      return false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      while (static_cast<int>(count_) < helpers) {
        std::thread(&KeptThreads::serve, this).detach();
        ++count_;
      }
      job_ = &work;
      wanted_ = helpers;
      taken_ = 0;
      finished_ = 0;
      ++generation_;
    }
    wake_.notify_all();
    work();
    {
      std::unique_lock<std::mutex> lock(mutex_);
      done_.wait(lock, [this] { return finished_ == wanted_; });
      job_ = nullptr;
    }
    in_use_ = false;
    return true;
  }

private:
  void
  serve()
  {
    in_worker_ = true;
    std::uint64_t seen = 0;
    std::unique_lock<std::mutex> lock(mutex_);
    while (true) {
      wake_.wait(lock, [&] { return generation_ != seen; });
      seen = generation_;
      if (taken_ >= wanted_)
        continue;
      ++taken_;
      const std::function<void()>* job = job_;
      lock.unlock();
      (*job)();
      lock.lock();
      if (++finished_ == wanted_)
        done_.notify_one();
    }
  }

  const pid_t owner_ = ::getpid();
  std::atomic<bool> in_use_{false};
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  std::size_t count_ = 0;
  const std::function<void()>* job_ = nullptr;
  int wanted_ = 0, taken_ = 0, finished_ = 0;
  std::uint64_t generation_ = 0;
  static thread_local bool in_worker_;
};

thread_local bool KeptThreads::in_worker_ = false;

} // namespace

void
runOnThreads(int helpers, const std::function<void()>& work)
{
  // Never destroyed: its threads wait until the process ends, so no exit or unload order
  // can join them while they hold a job.
  static KeptThreads* const kept = new KeptThreads();
  if (helpers <= 0) {
    work();
    return;
  }
  if (kept->tryRun(helpers, work))
    return;
  std::vector<std::thread> fresh;
  for (int h = 0; h < helpers; ++h)
    fresh.emplace_back(work);
  work();
  for (std::thread& t : fresh)
    t.join();
}

} // namespace core
} // namespace pcl_mi
