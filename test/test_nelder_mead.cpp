/*
 * Nelder-Mead on known 6-D functions from the paper's anisotropic simplex.
 */
#include "search/nelder_mead.h"

#include <gtest/gtest.h>

#include <cmath>

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
