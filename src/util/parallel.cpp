/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "util/parallel.h"

#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>

namespace pcl_mi {
namespace core {

namespace {

/** How long a thread polls before it sleeps, when it waits for a job or for the helpers to
 * finish theirs: a split of a few tens of microseconds follows the last one closely, and
 * waking a sleeping thread costs about as long as such a split. */
constexpr std::chrono::microseconds kPollTime{50};

/** Polls \a ready until it turns true or kPollTime has passed; the caller then waits on
 * its condition variable either way. */
template <typename Ready>
void
pollFor(const Ready& ready)
{
  const auto until = std::chrono::steady_clock::now() + kPollTime;
  while (!ready()) {
    if (std::chrono::steady_clock::now() >= until)
      return;
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#elif defined(__aarch64__)
    asm volatile("yield");
#endif
  }
}

/** Threads that wait for work between calls, one job at a time. The job and its counts
 * change under the mutex; two atomic copies let a waiting thread poll them without it. */
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
      polled_finished_.store(0);
      ++generation_;
      polled_generation_.store(generation_, std::memory_order_release);
    }
    wake_.notify_all();
    work();
    {
      pollFor([&] { return polled_finished_.load(std::memory_order_acquire) == helpers; });
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
      lock.unlock();
      pollFor([&] { return polled_generation_.load(std::memory_order_acquire) != seen; });
      lock.lock();
      wake_.wait(lock, [&] { return generation_ != seen; });
      seen = generation_;
      if (taken_ >= wanted_)
        continue;
      ++taken_;
      const std::function<void()>* job = job_;
      lock.unlock();
      (*job)();
      lock.lock();
      polled_finished_.store(++finished_, std::memory_order_release);
      if (finished_ == wanted_)
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
  std::atomic<std::uint64_t> polled_generation_{0};
  std::atomic<int> polled_finished_{0};
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
