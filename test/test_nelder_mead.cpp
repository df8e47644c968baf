/*
 * Nelder-Mead on known 6-D functions from the paper's anisotropic simplex.
 */
#include "search/nelder_mead.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

using pcl_mi::core::minimizeNelderMead;
using pcl_mi::core::NelderMeadOptions;

namespace {

Eigen::VectorXd
paperSteps()
{
  Eigen::VectorXd s(6);
  s << 8, 8, 1, 0.1, 0.1, 0.8;
  return s;
}

NelderMeadOptions
tightOptions(int max_iterations = 2000)
{
  NelderMeadOptions o;
  o.max_iterations = max_iterations;
  o.tolerance = Eigen::VectorXd::Constant(6, 1e-6);
  return o;
}

} // namespace

TEST(NelderMead, AnisotropicQuadraticIn6D)
{
  Eigen::VectorXd minimum(6);
  minimum << 3.0, -5.0, 0.5, 0.05, -0.03, 0.4;
  Eigen::VectorXd scale(6);
  scale << 1.0, 1.0, 4.0, 100.0, 100.0, 10.0; // curvature like metres vs radians
  auto f = [&](const Eigen::VectorXd& x) {
    return (scale.array() * (x - minimum).array().square()).sum() + 7.0;
  };
  const auto r = minimizeNelderMead(f, Eigen::VectorXd::Zero(6), paperSteps(), tightOptions());
  EXPECT_TRUE(r.converged);
  EXPECT_LT((r.x - minimum).cwiseAbs().maxCoeff(), 1e-4);
  EXPECT_NEAR(r.value, 7.0, 1e-8);
  EXPECT_GT(r.evaluations, r.iterations);
}

TEST(NelderMead, MinimumBehindTheNegativeSteps)
{
  // The minimum lies opposite to the positive steps; the simplex must travel backwards.
  Eigen::VectorXd minimum(6);
  minimum << -9.0, -4.0, -0.5, -0.04, 0.02, -0.6;
  auto f = [&](const Eigen::VectorXd& x) { return (x - minimum).squaredNorm(); };
  const auto r = minimizeNelderMead(f, Eigen::VectorXd::Zero(6), paperSteps(), tightOptions());
  EXPECT_TRUE(r.converged);
  EXPECT_LT((r.x - minimum).cwiseAbs().maxCoeff(), 1e-4);
}

TEST(NelderMead, RotatedValleyIn6D)
{
  // Coupled parameters (a rotated, ill-conditioned valley).
  auto f = [](const Eigen::VectorXd& x) {
    double s = 0;
    for (int i = 0; i < 5; ++i)
      s += 100.0 * std::pow(x[i + 1] - x[i], 2) + std::pow(1.0 - x[i], 2);
    return s;
  };
  Eigen::VectorXd steps = Eigen::VectorXd::Constant(6, 0.5);
  const auto r = minimizeNelderMead(f, Eigen::VectorXd::Zero(6), steps, tightOptions(20000));
  EXPECT_TRUE(r.converged);
  EXPECT_LT((r.x - Eigen::VectorXd::Ones(6)).cwiseAbs().maxCoeff(), 1e-2);
}

TEST(NelderMead, IterationCapIsNotConvergence)
{
  auto f = [](const Eigen::VectorXd& x) { return x.squaredNorm(); };
  const auto r = minimizeNelderMead(f, Eigen::VectorXd::Constant(6, 5.0), paperSteps(),
                                    tightOptions(5));
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.iterations, 5);
}

TEST(NelderMead, StartingAtTheMinimumConvergesThere)
{
  auto f = [](const Eigen::VectorXd& x) { return x.squaredNorm(); };
  const auto r = minimizeNelderMead(f, Eigen::VectorXd::Zero(6), paperSteps(), tightOptions());
  EXPECT_TRUE(r.converged);
  EXPECT_LT(r.x.cwiseAbs().maxCoeff(), 1e-5);
}

namespace {

/** A quantised, anisotropic cost with plateaus (as MI on a voxel grid): from the origin
 * it needs every kind of step, reflections, expansions, contractions and shrinks. */
double
plateauCost(const Eigen::VectorXd& x)
{
  Eigen::VectorXd minimum(6);
  minimum << 4.0, -7.0, 0.3, 0.08, -0.02, 0.5;
  const double d = (x - minimum).cwiseProduct(Eigen::VectorXd::LinSpaced(6, 1.0, 6.0)).norm();
  return std::floor(50.0 * d) / 50.0 + 0.01 * std::sin(3.0 * x[0]);
}

void
expectSameRun(const pcl_mi::core::NelderMeadResult& a, const pcl_mi::core::NelderMeadResult& b)
{
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.value, b.value);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.evaluations, b.evaluations);
  EXPECT_EQ(a.converged, b.converged);
}

} // namespace

TEST(NelderMead, SpeculativeRequestsChooseTheSameVertices)
{
  for (const int cap : {3, 40, 2000}) {
    SCOPED_TRACE(cap);
    const auto one = minimizeNelderMead(plateauCost, Eigen::VectorXd::Zero(6), paperSteps(),
                                        tightOptions(cap));
    NelderMeadOptions o = tightOptions(cap);
    o.speculative = true;
    std::vector<pcl_mi::core::NelderMeadRun> runs{
        pcl_mi::core::NelderMeadRun(Eigen::VectorXd::Zero(6), paperSteps(), o)};
    int points = 0;
    const int rounds = pcl_mi::core::runTogether(
        runs, [&](const std::vector<Eigen::VectorXd>& xs, std::vector<double>& values) {
          points += static_cast<int>(xs.size());
          for (std::size_t i = 0; i < xs.size(); ++i)
            values[i] = plateauCost(xs[i]);
        });
    const auto batched = runs.front().result();
    expectSameRun(batched, one);
    // One request for the first simplex, one per iteration and one per shrink: fewer
    // than one at a time needs, with more points evaluated.
    EXPECT_EQ(rounds, batched.requests);
    EXPECT_LT(batched.requests, one.requests);
    EXPECT_LE(batched.requests, 1 + 2 * batched.iterations);
    EXPECT_GE(points, batched.evaluations);
    if (cap == 2000) {
      EXPECT_TRUE(batched.converged);
      EXPECT_GT(points, batched.evaluations); // speculation evaluated unused candidates
    }
  }
}

TEST(NelderMead, RunsInLockstepEndAsEachAlone)
{
  // Runs of different starts, steps, caps and modes share every round; each still ends
  // exactly where it ends alone, and the rounds are those of the longest run.
  struct Case {
    Eigen::VectorXd x0, steps;
    int cap;
    bool speculative;
  };
  std::vector<Case> cases;
  for (int k = 0; k < 6; ++k)
    cases.push_back({Eigen::VectorXd::Constant(6, 0.5 * k), (k % 2 ? -1.0 : 1.0) * paperSteps(),
                     k == 3 ? 5 : 300 + 100 * k, k % 3 != 0});
  std::vector<pcl_mi::core::NelderMeadRun> runs;
  for (const Case& c : cases) {
    NelderMeadOptions o = tightOptions(c.cap);
    o.speculative = c.speculative;
    runs.emplace_back(c.x0, c.steps, o);
  }
  int largest_batch = 0;
  const int rounds = pcl_mi::core::runTogether(
      runs, [&](const std::vector<Eigen::VectorXd>& xs, std::vector<double>& values) {
        largest_batch = std::max(largest_batch, static_cast<int>(xs.size()));
        for (std::size_t i = 0; i < xs.size(); ++i)
          values[i] = plateauCost(xs[i]);
      });
  int longest = 0;
  for (std::size_t k = 0; k < cases.size(); ++k) {
    SCOPED_TRACE(k);
    const auto alone = minimizeNelderMead(plateauCost, cases[k].x0, cases[k].steps,
                                          tightOptions(cases[k].cap));
    expectSameRun(runs[k].result(), alone);
    EXPECT_TRUE(runs[k].finished());
    longest = std::max(longest, runs[k].result().requests);
  }
  EXPECT_EQ(rounds, longest);
  EXPECT_EQ(largest_batch, 6 * 7); // the six first simplices in one round
}

TEST(NelderMead, SparesOfferedLeaveTheRunAsAlone)
{
  // Each spare's value handed over before the reply: the run ends exactly where it ends
  // alone, with fewer requests wherever it used a spare (an inside contraction).
  for (const int cap : {3, 40, 2000}) {
    SCOPED_TRACE(cap);
    const auto alone = minimizeNelderMead(plateauCost, Eigen::VectorXd::Zero(6), paperSteps(),
                                          tightOptions(cap));
    pcl_mi::core::NelderMeadRun run(Eigen::VectorXd::Zero(6), paperSteps(), tightOptions(cap));
    int offered = 0;
    std::vector<double> values;
    while (!run.finished()) {
      if (const Eigen::VectorXd* spare = run.spare()) {
        ASSERT_EQ(run.request().size(), 1u); // beside a reflection asked alone
        run.offerSpare(plateauCost(*spare));
        ++offered;
      }
      values.clear();
      for (const Eigen::VectorXd& x : run.request())
        values.push_back(plateauCost(x));
      run.reply(values);
    }
    const auto helped = run.result();
    expectSameRun(helped, alone);
    EXPECT_GT(offered, 0);
    if (cap == 2000) {
      EXPECT_TRUE(helped.converged);
      EXPECT_LT(helped.requests, alone.requests);
    }
  }
}
