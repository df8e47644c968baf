/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "search/two_evaluators.h"

#include "util/parallel.h"

#include <atomic>
#include <exception>
#include <thread>

namespace pcl_mi {
namespace core {

namespace {

/** Pauses one step of a wait. The evaluations waited on take microseconds, so the waits
 * spin; past the first few thousand steps they also yield, so that two threads sharing one
 * core still take turns. */
void
pause(int& steps)
{
  if (++steps > 4096)
    std::this_thread::yield();
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#endif
}

/** Where one evaluator hands points to the other: it fills in the job, then posts it; the
 * other evaluates them and answers. Only its own evaluator posts on a desk. */
struct HelpDesk {
  enum State : int { kEmpty, kPosted, kAnswered };
  std::atomic<int> state{kEmpty};
  const Eigen::VectorXd* const* points = nullptr; // the job's points ...
  double* values = nullptr;                       // ... and where their values go
  std::size_t count = 0;
  /** Set once its evaluator has no run left: from then on it helps, and posts no more. */
  std::atomic<bool> idle{false};
};

class TwoEvaluators {
public:
  TwoEvaluators(std::vector<NelderMeadRun>& runs, const SlotCost& cost)
  : runs_(runs), cost_(cost)
  {}

  /** Evaluator \a slot's share of the work: runs in turn, then help until the other one
   * has no run left either. Never throws: a failure is kept for rethrow(). */
  void
  work(int slot)
  {
    try {
      for (int i = next_++; i < static_cast<int>(runs_.size()) && !failed_.load(); i = next_++)
        drive(runs_[static_cast<std::size_t>(i)], slot);
    }
    catch (...) {
      fail(slot);
    }
    desks_[slot].idle.store(true, std::memory_order_release);
    HelpDesk& other = desks_[1 - slot];
    int steps = 0;
    while (true) {
      if (other.state.load(std::memory_order_acquire) == HelpDesk::kPosted) {
        try {
          for (std::size_t k = 0; k < other.count; ++k)
            other.values[k] = cost_(slot, *other.points[k]);
        }
        catch (...) {
          fail(slot);
        }
        other.state.store(HelpDesk::kAnswered, std::memory_order_release);
        steps = 0;
      }
      // The other one posts only while it is not idle, and waits for every answer first.
      else if (other.idle.load(std::memory_order_acquire))
        return;
      else
        pause(steps);
    }
  }

  /** Rethrows the first failure of either evaluator, if any. */
  void
  rethrow() const
  {
    for (const std::exception_ptr& f : failures_)
      if (f)
        std::rethrow_exception(f);
  }

  int
  requests() const
  {
    return requests_.load();
  }

private:
  void
  drive(NelderMeadRun& run, int slot)
  {
    HelpDesk& desk = desks_[slot];
    const HelpDesk& other = desks_[1 - slot];
    std::vector<const Eigen::VectorXd*> points;
    std::vector<double> values;
    for (; !run.finished() && !failed_.load(); ++requests_) {
      const std::vector<Eigen::VectorXd>& request = run.request();
      points.clear();
      for (const Eigen::VectorXd& x : request)
        points.push_back(&x);
      // Where the other evaluator is free, it takes the second half, or the spare point.
      const bool helped = other.idle.load(std::memory_order_acquire);
      const Eigen::VectorXd* spare = helped && request.size() == 1 ? run.spare() : nullptr;
      if (spare)
        points.push_back(spare);
      values.assign(points.size(), 0.0);
      const std::size_t own = helped ? (points.size() + 1) / 2 : points.size();
      if (own == points.size()) {
        for (std::size_t k = 0; k < own; ++k)
          values[k] = cost_(slot, *points[k]);
      }
      else {
        desk.points = points.data() + own;
        desk.values = values.data() + own;
        desk.count = points.size() - own;
        desk.state.store(HelpDesk::kPosted, std::memory_order_release);
        // The helper writes into values: wait for its answer even where this part fails.
        std::exception_ptr failure;
        try {
          for (std::size_t k = 0; k < own; ++k)
            values[k] = cost_(slot, *points[k]);
        }
        catch (...) {
          failure = std::current_exception();
        }
        int steps = 0;
        while (desk.state.load(std::memory_order_acquire) != HelpDesk::kAnswered)
          pause(steps);
        desk.state.store(HelpDesk::kEmpty, std::memory_order_relaxed);
        if (failure)
          std::rethrow_exception(failure);
      }
      if (spare) {
        run.offerSpare(values.back());
        values.pop_back();
      }
      run.reply(values);
    }
  }

  void
  fail(int slot)
  {
    if (!failures_[slot])
      failures_[slot] = std::current_exception();
    failed_.store(true);
  }

  std::vector<NelderMeadRun>& runs_;
  const SlotCost& cost_;
  std::atomic<int> next_{0};
  std::atomic<int> requests_{0};
  std::atomic<bool> failed_{false};
  std::exception_ptr failures_[2];
  HelpDesk desks_[2];
};

} // namespace

int
runOnTwoEvaluators(std::vector<NelderMeadRun>& runs, const SlotCost& cost, int threads)
{
  if (threads < 2) {
    int requests = 0;
    for (NelderMeadRun& run : runs)
      requests += runToEnd(run, [&](const std::vector<Eigen::VectorXd>& xs,
                                    std::vector<double>& values) {
        for (std::size_t i = 0; i < xs.size(); ++i)
          values[i] = cost(0, xs[i]);
      });
    return requests;
  }
  TwoEvaluators evaluators(runs, cost);
  std::atomic<int> slots{0};
  runOnThreads(1, [&] { evaluators.work(slots++); });
  evaluators.rethrow();
  return evaluators.requests();
}

} // namespace core
} // namespace pcl_mi
