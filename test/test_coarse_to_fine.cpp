/*
 * The coarse-to-fine search on synthetic costs: no clouds, only functions with known
 * minima, so each property of the search is checked on its own.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "search/coarse_to_fine.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>

namespace {

using pcl_mi::core::CoarseToFineOptions;
using pcl_mi::core::CoarseToFineResult;

/** A cost per level from one function of (level, x); counts the calls per level. */
class SyntheticCosts : public pcl_mi::core::LevelCosts {
public:
  SyntheticCosts(int levels, std::function<double(int, const Eigen::VectorXd&)> f)
  : levels_(levels), f_(std::move(f)), calls_(static_cast<std::size_t>(levels))
  {}
  int
  levels() const override
  {
    return levels_;
  }
  double
  resolution(int level) const override
  {
    return std::ldexp(1.0, level);
  }
  double
  cost(int level, int, const Eigen::VectorXd& x) override
  {
    ++calls_[static_cast<std::size_t>(level)];
    return f_(level, x);
  }
  int
  calls(int level) const
  {
    return calls_[static_cast<std::size_t>(level)];
  }

private:
  int levels_;
  std::function<double(int, const Eigen::VectorXd&)> f_;
  std::vector<std::atomic<int>> calls_;
};

/** x, y, yaw options with the paper's steps. */
CoarseToFineOptions
planarOptions()
{
  CoarseToFineOptions o;
  o.steps = Eigen::Vector3d(8.0, 8.0, 0.8);
  o.tolerance = Eigen::Vector3d(0.005, 0.005, 0.0005);
  o.translational = {true, true, false};
  o.x_index = 0;
  o.y_index = 1;
  o.yaw_index = 2;
  return o;
}

double
bowl(const Eigen::VectorXd& x, const Eigen::Vector3d& centre)
{
  return (x - centre).squaredNorm();
}

/** Searches \a f with \a o on one thread and on two, and expects the same result of
 * both: the best, the counts, and the runners-up. */
void
expectTheSameOnOneThreadOrTwo(const std::function<double(int, const Eigen::VectorXd&)>& f,
                              CoarseToFineOptions o)
{
  o.num_threads = 1;
  SyntheticCosts serial(3, f);
  const CoarseToFineResult a = pcl_mi::core::searchCoarseToFine(serial, o);
  o.num_threads = 2;
  SyntheticCosts parallel(3, f);
  const CoarseToFineResult b = pcl_mi::core::searchCoarseToFine(parallel, o);
  EXPECT_EQ(a.best.x, b.best.x);
  EXPECT_EQ(a.evaluations, b.evaluations);
  EXPECT_EQ(a.iterations, b.iterations);
  ASSERT_EQ(a.alternatives.size(), b.alternatives.size());
  for (std::size_t i = 0; i < a.alternatives.size(); ++i)
    EXPECT_EQ(a.alternatives[i].x, b.alternatives[i].x) << i;
}

} // namespace

TEST(CoarseToFine, FindsTheMinimumOfABowlOnEveryLevel)
{
  const Eigen::Vector3d centre(3.0, -2.0, 0.3);
  SyntheticCosts costs(3, [&](int, const Eigen::VectorXd& x) { return bowl(x, centre); });
  const CoarseToFineResult r = pcl_mi::core::searchCoarseToFine(costs, planarOptions());
  EXPECT_TRUE(r.best.converged);
  EXPECT_LT((r.best.x - centre).cwiseAbs().maxCoeff(), 0.01);
  // Each level ran and is a stage of its own.
  for (int level = 0; level < 3; ++level)
    EXPECT_GT(costs.calls(level), 0) << level;
  ASSERT_EQ(r.stages.size(), 3u);
  EXPECT_EQ(r.stages[0].name, "search 4 m");
  EXPECT_EQ(r.stages[2].name, "search 1 m");
  int evaluations = 0;
  for (const auto& s : r.stages)
    evaluations += s.calls;
  EXPECT_EQ(evaluations, r.evaluations);
}

TEST(CoarseToFine, FirstLevelSkipsTheFinerLevels)
{
  SyntheticCosts costs(3, [](int, const Eigen::VectorXd& x) { return x.squaredNorm(); });
  CoarseToFineOptions o = planarOptions();
  o.first_level = 1;
  pcl_mi::core::searchCoarseToFine(costs, o);
  EXPECT_EQ(costs.calls(0), 0);
  EXPECT_GT(costs.calls(1), 0);
}

TEST(CoarseToFine, MirroredStartFindsMotionAgainstTheSteps)
{
  // A minimum far along the negative steps, behind a ridge at the origin's positive side:
  // the forward simplex alone walks away from it.
  const Eigen::Vector3d centre(-6.0, -6.0, -0.5);
  auto f = [&](int, const Eigen::VectorXd& x) {
    return std::min(bowl(x, centre), 20.0 + bowl(x, Eigen::Vector3d(6.0, 6.0, 0.5)));
  };
  CoarseToFineOptions o = planarOptions();
  SyntheticCosts mirrored(1, f);
  const auto with = pcl_mi::core::searchCoarseToFine(mirrored, o);
  EXPECT_LT((with.best.x - centre).norm(), 0.05);
  o.symmetric_start = false;
  SyntheticCosts forward(1, f);
  const auto without = pcl_mi::core::searchCoarseToFine(forward, o);
  EXPECT_GT(without.best.value, with.best.value);
}

TEST(CoarseToFine, HeadingStartsReachAHeadingBehind)
{
  // The minimum at yaw 180 deg, a weaker one near the guess.
  auto f = [](int, const Eigen::VectorXd& x) {
    const double behind = std::remainder(x[2] - M_PI, 2.0 * M_PI);
    return std::min(x[0] * x[0] + x[1] * x[1] + behind * behind,
                    1.0 + x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
  };
  CoarseToFineOptions o = planarOptions();
  SyntheticCosts one(2, f);
  const auto single = pcl_mi::core::searchCoarseToFine(one, o);
  o.heading_starts = 4;
  SyntheticCosts four(2, f);
  const auto several = pcl_mi::core::searchCoarseToFine(four, o);
  EXPECT_GT(single.best.value, 0.5); // stuck at the weaker minimum
  EXPECT_LT(several.best.value, 1e-4);
  EXPECT_NEAR(std::abs(std::remainder(several.best.x[2], 2.0 * M_PI)), M_PI, 0.01);
}

TEST(CoarseToFine, YawStartsReachANarrowWellBesideTheGuess)
{
  // A narrow well at yaw +0.5 rad, which the simplex from the guess (yaw step 0.8) steps
  // over, on a bowl whose floor is at the guess.
  auto f = [](int, const Eigen::VectorXd& x) {
    const double xy = x[0] * x[0] + x[1] * x[1];
    const double well = (x[2] - 0.5) / 0.05;
    return 1.0 + xy + x[2] * x[2] - 2.0 * std::exp(-well * well - xy);
  };
  CoarseToFineOptions o = planarOptions();
  SyntheticCosts plain(2, f);
  const auto from_guess = pcl_mi::core::searchCoarseToFine(plain, o);
  o.yaw_starts = {0.5, -0.5};
  SyntheticCosts turned(2, f);
  const auto with_turns = pcl_mi::core::searchCoarseToFine(turned, o);
  EXPECT_GT(from_guess.best.value, 0.9); // the bowl's floor
  EXPECT_LT(with_turns.best.value, 0.0);
  EXPECT_NEAR(with_turns.best.x[2], 0.5, 0.02);
}

TEST(CoarseToFine, ScannedStartsReachAWellTurnedInYawAndPitch)
{
  // Search vector [x, y, pitch, yaw]: a narrow well at pitch -0.35 and yaw 0.7 rad, on a
  // bowl whose floor is at the guess. Neither the simplex from the guess nor the yaw
  // starts at +-0.5 rad reach it; the scan of turns scores it and starts there.
  auto f = [](int, const Eigen::VectorXd& x) {
    const double xy = x[0] * x[0] + x[1] * x[1];
    const double pitch = (x[2] + 0.35) / 0.05, yaw = (x[3] - 0.7) / 0.05;
    return 1.0 + xy + x[2] * x[2] + x[3] * x[3] - 2.0 * std::exp(-pitch * pitch - yaw * yaw - xy);
  };
  CoarseToFineOptions o;
  o.steps = Eigen::Vector4d(8.0, 8.0, 0.35, 0.8);
  o.tolerance = Eigen::Vector4d(0.005, 0.005, 0.0005, 0.0005);
  o.translational = {true, true, false, false};
  o.x_index = 0;
  o.y_index = 1;
  o.pitch_index = 2;
  o.yaw_index = 3;
  o.yaw_starts = {0.5, -0.5};
  SyntheticCosts plain(2, f);
  const auto without = pcl_mi::core::searchCoarseToFine(plain, o);
  EXPECT_TRUE(without.scanned_turns.empty());
  o.scanned_starts = 2;
  SyntheticCosts scanned(2, f);
  const auto with = pcl_mi::core::searchCoarseToFine(scanned, o);
  EXPECT_GT(without.best.value, 0.5);
  EXPECT_LT(with.best.value, 0.0);
  EXPECT_NEAR(with.best.x[2], -0.35, 0.02);
  EXPECT_NEAR(with.best.x[3], 0.7, 0.02);
  // Only the well's turn scores better than the guess: the bowl's other turns are no lead.
  ASSERT_EQ(with.scanned_turns.size(), 1u);
  EXPECT_NEAR(with.scanned_turns[0][0], 0.0, 1e-12); // no roll scanned
  EXPECT_NEAR(with.scanned_turns[0][1], -0.35, 1e-12);
  EXPECT_NEAR(with.scanned_turns[0][2], 0.7, 1e-12);
  // Where the guess scores best on the grid, no turn is a lead.
  SyntheticCosts bowl_only(2, [](int, const Eigen::VectorXd& x) { return x.squaredNorm(); });
  EXPECT_TRUE(pcl_mi::core::searchCoarseToFine(bowl_only, o).scanned_turns.empty());
  // The grid is scored in two halves, one per thread: the result does not depend on them.
  o.num_threads = 1;
  SyntheticCosts serial(2, f);
  const auto one_thread = pcl_mi::core::searchCoarseToFine(serial, o);
  EXPECT_EQ(one_thread.best.x, with.best.x);
  EXPECT_EQ(one_thread.evaluations, with.evaluations);
}

TEST(CoarseToFine, ScannedStartsReachAWellTurnedInRollWhereAsked)
{
  // Search vector [x, y, roll, pitch, yaw]: a narrow well at roll -0.525 and yaw 0.35 rad
  // (a sensor tilted sideways by 30 deg), on a bowl whose floor is at the guess. The turns
  // of yaw and pitch miss it; with scan_roll the grid also turns in roll and finds it.
  auto f = [](int, const Eigen::VectorXd& x) {
    const double xy = x[0] * x[0] + x[1] * x[1];
    const double roll = (x[2] + 0.525) / 0.05, pitch = x[3] / 0.05, yaw = (x[4] - 0.35) / 0.05;
    return 1.0 + xy + x.tail<3>().squaredNorm() -
           2.0 * std::exp(-roll * roll - pitch * pitch - yaw * yaw - xy);
  };
  CoarseToFineOptions o;
  o.steps = (Eigen::VectorXd(5) << 8.0, 8.0, 0.35, 0.35, 0.8).finished();
  o.tolerance = (Eigen::VectorXd(5) << 0.005, 0.005, 0.0005, 0.0005, 0.0005).finished();
  o.translational = {true, true, false, false, false};
  o.x_index = 0;
  o.y_index = 1;
  o.roll_index = 2;
  o.pitch_index = 3;
  o.yaw_index = 4;
  o.scanned_starts = 2;
  SyntheticCosts without_roll(2, f);
  EXPECT_GT(pcl_mi::core::searchCoarseToFine(without_roll, o).best.value, 0.5);
  o.scan_roll = true;
  SyntheticCosts with_roll(2, f);
  const auto found = pcl_mi::core::searchCoarseToFine(with_roll, o);
  EXPECT_LT(found.best.value, 0.0);
  EXPECT_NEAR(found.best.x[2], -0.525, 0.02);
  EXPECT_NEAR(found.best.x[4], 0.35, 0.02);
  ASSERT_EQ(found.scanned_turns.size(), 1u);
  EXPECT_NEAR(found.scanned_turns[0][0], -0.525, 1e-12);
  EXPECT_NEAR(found.scanned_turns[0][1], 0.0, 1e-12);
  EXPECT_NEAR(found.scanned_turns[0][2], 0.35, 1e-12);
}

TEST(CoarseToFine, TheBudgetCapsEveryIterationAndThreadsDoNotChangeTheResult)
{
  const Eigen::Vector3d centre(1.0, 2.0, 0.1);
  auto f = [&](int level, const Eigen::VectorXd& x) { return bowl(x, centre) + 0.01 * level; };
  CoarseToFineOptions o = planarOptions();
  o.max_iterations = 40;
  o.restarts = 3;
  SyntheticCosts capped(3, f);
  const auto r = pcl_mi::core::searchCoarseToFine(capped, o);
  EXPECT_LE(r.iterations, 40);
  EXPECT_FALSE(r.best.converged);
  o.max_iterations = 1000;
  expectTheSameOnOneThreadOrTwo(f, o);
}

TEST(CoarseToFine, ManyStartsOfUnevenLengthsGiveTheSameResultOnOneThreadOrTwo)
{
  // Sixteen starts on a rugged cost run for very different numbers of iterations; with two
  // threads each evaluator takes the next start when it is done, in whatever order the
  // threads finish, and every result must still be the one thread's.
  auto f = [](int level, const Eigen::VectorXd& x) {
    return 0.05 * x.squaredNorm() + std::cos(1.3 * x[0]) + std::cos(1.7 * x[1]) +
           std::cos(9.0 * x[2]) + 0.01 * level;
  };
  CoarseToFineOptions o = planarOptions();
  o.heading_starts = 6;
  o.position_starts = 10;
  expectTheSameOnOneThreadOrTwo(f, o);
}

TEST(CoarseToFine, TheBudgetHoldsWithManyCandidatesOnTheFinerLevels)
{
  // A rugged cost and many starts leave several distinct candidates for every finer level,
  // where the first gets half of what the coarsest level left and the others share the rest.
  SyntheticCosts costs(3, [](int level, const Eigen::VectorXd& x) {
    return 0.05 * x.squaredNorm() + std::cos(1.3 * x[0]) + std::cos(1.7 * x[1]) +
           std::cos(9.0 * x[2]) + 0.01 * level;
  });
  CoarseToFineOptions o = planarOptions();
  o.heading_starts = 6;
  o.position_starts = 8;
  for (int budget = 30; budget <= 900; budget += 15) {
    o.max_iterations = budget;
    const CoarseToFineResult r = pcl_mi::core::searchCoarseToFine(costs, o);
    EXPECT_LE(r.iterations, budget);
  }
}

namespace {

/** SyntheticCosts that asks for batches (as a GPU backend does) and records their sizes. */
class BatchedCosts : public SyntheticCosts {
public:
  using SyntheticCosts::SyntheticCosts;
  bool
  prefersBatches() const override
  {
    return true;
  }
  void
  costs(int level, int slot, const std::vector<Eigen::VectorXd>& xs, std::vector<double>& values)
      override
  {
    EXPECT_EQ(slot, 0); // lockstep runs on one evaluator
    largest = std::max(largest, xs.size());
    SyntheticCosts::costs(level, slot, xs, values);
  }
  std::size_t largest = 0;
};

} // namespace

TEST(CoarseToFine, BatchedLockstepSearchGivesTheSameResult)
{
  // Two basins, several heading and position starts, candidates on the finer levels and
  // restarts: every part of the search runs batched and must choose what it chose alone.
  const Eigen::Vector3d near(1.5, -0.5, 0.2), far(-6.0, 5.0, 2.5);
  auto f = [&](int level, const Eigen::VectorXd& x) {
    return std::min(bowl(x, near) + 0.3, 0.5 * bowl(x, far)) + 0.05 * std::sin(5.0 * x[0]) +
           0.01 * level;
  };
  CoarseToFineOptions o = planarOptions();
  o.heading_starts = 4;
  o.position_starts = 3;
  o.restarts = 2;
  for (const int budget : {60, 1000}) {
    SCOPED_TRACE(budget);
    o.max_iterations = budget;
    SyntheticCosts alone(3, f);
    BatchedCosts batched(3, f);
    const CoarseToFineResult a = pcl_mi::core::searchCoarseToFine(alone, o);
    const CoarseToFineResult b = pcl_mi::core::searchCoarseToFine(batched, o);
    EXPECT_EQ(a.best.x, b.best.x);
    EXPECT_EQ(a.best.value, b.best.value);
    EXPECT_EQ(a.best.converged, b.best.converged);
    EXPECT_EQ(a.iterations, b.iterations);
    EXPECT_EQ(a.evaluations, b.evaluations);
    // The 7 starts' 14 first simplices of 4 vertices go out in one batch, and the whole
    // search needs far fewer round trips than one point at a time.
    EXPECT_GE(batched.largest, 14u * 4u);
    EXPECT_LT(2 * b.batches, a.batches);
    if (budget == 1000) // the deeper, farther basin (the near one never scores below 0.25)
      EXPECT_LT(b.best.value, 0.2);
  }
}

TEST(CoarseToFine, AlternativesAreTheOtherCandidatesOptimaBestFirst)
{
  // Two basins and several starts: the finest searched level refines more than one
  // candidate, and every optimum but the winner's comes back as an alternative, ranked.
  const Eigen::Vector3d near(1.5, -0.5, 0.2), far(-6.0, 5.0, 2.5);
  SyntheticCosts costs(3, [&](int level, const Eigen::VectorXd& x) {
    return std::min(bowl(x, near) + 0.3, 0.5 * bowl(x, far)) + 0.01 * level;
  });
  CoarseToFineOptions o = planarOptions();
  o.heading_starts = 4;
  o.position_starts = 3;
  o.first_level = 1;
  const CoarseToFineResult r = pcl_mi::core::searchCoarseToFine(costs, o);
  ASSERT_GE(r.alternatives.size(), 2u);
  for (std::size_t i = 0; i < r.alternatives.size(); ++i) {
    EXPECT_GE(r.alternatives[i].value, r.best.value);
    EXPECT_NE(r.alternatives[i].x, r.best.x);
    if (i > 0)
      EXPECT_GE(r.alternatives[i].value, r.alternatives[i - 1].value);
  }
  // One start and a guess the coarse optimum did not leave: nothing else to offer.
  CoarseToFineOptions single = planarOptions();
  single.first_level = 1;
  const Eigen::Vector3d at_guess = Eigen::Vector3d::Zero();
  SyntheticCosts centred(3, [&](int, const Eigen::VectorXd& x) { return bowl(x, at_guess); });
  EXPECT_TRUE(pcl_mi::core::searchCoarseToFine(centred, single).alternatives.empty());
}
