/*
 * Nelder-Mead runs on two evaluators: the same results as each run alone, the idle
 * evaluator helping, and failures carried out.
 */
#include "search/two_evaluators.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <vector>

using pcl_mi::core::minimizeNelderMead;
using pcl_mi::core::NelderMeadOptions;
using pcl_mi::core::NelderMeadRun;

namespace {

/** A rugged 4-D cost with plateaus, so that runs take very different paths. */
double
ruggedCost(const Eigen::VectorXd& x)
{
  const double bowl = (x - Eigen::Vector4d(3.0, -2.0, 0.5, 1.0)).squaredNorm();
  return std::floor(40.0 * bowl) / 40.0 + 0.2 * std::cos(3.0 * x[0]) * std::sin(2.0 * x[1]);
}

/** ruggedCost() taking about as long as an evaluation of a coarse grid, so that the two
 * evaluators' threads overlap. */
double
slowRuggedCost(const Eigen::VectorXd& x)
{
  const auto until = std::chrono::steady_clock::now() + std::chrono::microseconds(20);
  while (std::chrono::steady_clock::now() < until) {
  }
  return ruggedCost(x);
}

NelderMeadOptions
optionsWithCap(int cap)
{
  NelderMeadOptions o;
  o.max_iterations = cap;
  o.tolerance = Eigen::VectorXd::Constant(4, 1e-5);
  return o;
}

struct Start {
  Eigen::VectorXd x0, steps;
  int cap;
};

std::vector<Start>
unevenStarts(int count)
{
  std::vector<Start> starts;
  for (int k = 0; k < count; ++k)
    starts.push_back({Eigen::VectorXd::Constant(4, 0.7 * k),
                      (k % 2 ? -1.0 : 1.0) * Eigen::Vector4d(4.0, 4.0, 1.0, 1.0),
                      k % 3 == 1 ? 7 : 100 + 150 * k});
  return starts;
}

std::vector<NelderMeadRun>
runsFrom(const std::vector<Start>& starts)
{
  std::vector<NelderMeadRun> runs;
  for (const Start& s : starts)
    runs.emplace_back(s.x0, s.steps, optionsWithCap(s.cap));
  return runs;
}

/** Expects \a run finished where the run from \a start ends alone, one point at a time;
 * returns that lone run's requests. */
int
expectEndsAsAlone(const NelderMeadRun& run, const Start& start)
{
  const auto alone = minimizeNelderMead(ruggedCost, start.x0, start.steps,
                                        optionsWithCap(start.cap));
  const auto r = run.result();
  EXPECT_TRUE(run.finished());
  EXPECT_EQ(r.x, alone.x);
  EXPECT_EQ(r.value, alone.value);
  EXPECT_EQ(r.iterations, alone.iterations);
  EXPECT_EQ(r.evaluations, alone.evaluations);
  EXPECT_EQ(r.converged, alone.converged);
  return alone.requests;
}

} // namespace

TEST(TwoEvaluators, EveryRunEndsAsAloneAndTheIdleEvaluatorHelps)
{
  for (const int count : {1, 2, 5}) {
    SCOPED_TRACE(count);
    const std::vector<Start> starts = unevenStarts(count);
    // Whether the second thread starts in time is the scheduler's choice: of up to twenty
    // tries, at least one must see it help. Every try must end every run as alone.
    bool helped = false;
    for (int attempt = 0; attempt < 20 && !helped; ++attempt) {
      std::vector<NelderMeadRun> runs = runsFrom(starts);
      std::atomic<int> calls[2] = {{0}, {0}};
      std::atomic<int> busy[2] = {{0}, {0}}; // one slot is never called concurrently
      const int requests = pcl_mi::core::runOnTwoEvaluators(
          runs, [&](int slot, const Eigen::VectorXd& x) {
            EXPECT_EQ(busy[slot]++, 0);
            ++calls[slot];
            const double value = slowRuggedCost(x);
            --busy[slot];
            return value;
          });
      int alone_requests = 0, evaluations = 0;
      for (std::size_t k = 0; k < starts.size(); ++k) {
        SCOPED_TRACE(k);
        alone_requests += expectEndsAsAlone(runs[k], starts[k]);
        evaluations += runs[k].result().evaluations;
      }
      EXPECT_GE(calls[0] + calls[1], evaluations);
      EXPECT_LE(requests, alone_requests);
      // Helped: both evaluators worked, and the spares used cut the requests.
      helped = calls[0] > 0 && calls[1] > 0 && requests < alone_requests;
    }
    EXPECT_TRUE(helped);
  }
}

TEST(TwoEvaluators, AFailingEvaluationIsRethrownAndNothingWaitsForever)
{
  // An evaluation fails early (in a first simplex, which the evaluators may share) or
  // later, in a lone run or in one of several, on whichever evaluator made it; the failure
  // comes out of the call, which returns.
  for (const int failing_call : {3, 40})
    for (const int count : {1, 4}) {
      SCOPED_TRACE(failing_call * 10 + count);
      std::vector<NelderMeadRun> runs = runsFrom(unevenStarts(count));
      std::atomic<int> calls{0};
      EXPECT_THROW(pcl_mi::core::runOnTwoEvaluators(runs,
                                                    [&](int, const Eigen::VectorXd& x) {
                                                      if (++calls == failing_call)
                                                        throw std::runtime_error("failed");
                                                      return slowRuggedCost(x);
                                                    }),
                   std::runtime_error);
    }
}

TEST(TwoEvaluators, OnOneThreadEvaluatorZeroRunsThemInTurn)
{
  const std::vector<Start> starts = unevenStarts(4);
  std::vector<NelderMeadRun> runs = runsFrom(starts);
  int other_slot = 0;
  const int requests = pcl_mi::core::runOnTwoEvaluators(
      runs,
      [&](int slot, const Eigen::VectorXd& x) {
        other_slot += slot != 0;
        return ruggedCost(x);
      },
      1);
  EXPECT_EQ(other_slot, 0);
  int alone_requests = 0;
  for (std::size_t k = 0; k < starts.size(); ++k) {
    SCOPED_TRACE(k);
    alone_requests += expectEndsAsAlone(runs[k], starts[k]);
  }
  EXPECT_EQ(requests, alone_requests);
}
