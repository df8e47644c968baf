/*
 * The search space's map from search vectors to poses and back.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/search_space.h"

#include <pcl_mi/parameters.h>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <random>

using pcl_mi::core::SearchSpace;

// vector() inverts pose(), with the target's axes and with turned ones, and leaves a pinned
// parameter out: a pose found by another search is taken up by this one where it stands.
TEST(SearchSpace, VectorInvertsPose)
{
  pcl_mi::Parameters p;
  Eigen::Matrix4d guess = Eigen::Matrix4d::Identity();
  guess.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
  guess.topRightCorner<3, 1>() = Eigen::Vector3d(5.0, -2.0, 1.0);
  const Eigen::Vector3d pivot(3.0, 1.0, 0.5);
  const Eigen::Matrix3d axes = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()).toRotationMatrix();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> turn(-0.8, 0.8), shift(-4.0, 4.0);
  for (const bool turned_axes : {false, true}) {
    const SearchSpace space =
        turned_axes ? SearchSpace(p, guess, pivot, axes) : SearchSpace(p, guess, pivot);
    for (int trial = 0; trial < 20; ++trial) {
      Eigen::VectorXd x(6);
      x << shift(rng), shift(rng), shift(rng), turn(rng), turn(rng), turn(rng);
      EXPECT_LT((space.vector(space.pose(x)) - x).norm(), 1e-9) << x.transpose();
    }
  }
  p.search.simplex_steps[2] = p.search.simplex_steps[3] = p.search.simplex_steps[4] = 0.0;
  const SearchSpace planar(p, guess, pivot);
  const Eigen::Vector3d x(1.5, -2.0, 0.3);
  EXPECT_LT((planar.vector(planar.pose(x)) - Eigen::VectorXd(x)).norm(), 1e-9);
}

// A zero step pins its parameter: the parameters and the space built from them agree on
// which are searched, and the search vector holds those alone.
TEST(SearchSpace, AZeroStepPinsItsParameter)
{
  pcl_mi::Parameters p;
  EXPECT_TRUE(p.search.searched().all());
  p.search.simplex_steps[2] = p.search.simplex_steps[4] = 0.0;
  Eigen::Matrix<bool, 6, 1> expected;
  expected << true, true, false, true, false, true;
  EXPECT_EQ(p.search.searched(), expected);
  const SearchSpace space(p, Eigen::Matrix4d::Identity(), Eigen::Vector3d::Zero());
  EXPECT_EQ(space.searched(), expected);
  EXPECT_EQ(space.index(2), -1);
  EXPECT_EQ(space.index(4), -1);
  EXPECT_EQ(space.index(5), 3);
}
