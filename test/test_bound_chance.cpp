/*
 * The chance that a result lies within the success bound follows its covariance, counts a
 * turn's lever on the translation, and holds back a sparse result only where it is wide.
 */
#include "verify/bound_chance.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

using pcl_mi::AlignmentResult;
using pcl_mi::Refusal;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
namespace core = pcl_mi::core;

namespace {

constexpr double kDeg = M_PI / 180.0;

/** Covariance with standard deviation \a sd on the one axis \a axis. */
Matrix6d
alongOneAxis(int axis, double sd)
{
  Matrix6d c = Matrix6d::Zero();
  c(axis, axis) = sd * sd;
  return c;
}

Eigen::Matrix4d
shiftedBy(double x)
{
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t(0, 3) = x;
  return t;
}

/** A result that converged on \a inliers inliers with covariance \a covariance. */
AlignmentResult
converged(std::size_t inliers, const Matrix6d& covariance)
{
  AlignmentResult r;
  r.search_converged = true;
  r.converged = true;
  r.verification.inliers = inliers;
  r.verification.confidence = 0.99;
  r.verification.covariance = covariance;
  return r;
}

} // namespace

TEST(BoundChance, FollowsAShiftsStandardDeviation)
{
  const Eigen::Matrix4d at = Eigen::Matrix4d::Identity();
  // P(|N(0, sd)| < 0.5): 0.954 at sd 0.25, 0.683 at sd 0.5.
  EXPECT_NEAR(core::chanceWithinBound(alongOneAxis(0, 0.25), at, 0.5, 2.0), 0.9545, 0.015);
  EXPECT_NEAR(core::chanceWithinBound(alongOneAxis(1, 0.5), at, 0.5, 2.0), 0.6827, 0.02);
  // The bound is in the clouds' units.
  EXPECT_NEAR(core::chanceWithinBound(alongOneAxis(2, 250.0), at, 500.0, 2.0), 0.9545, 0.015);
}

TEST(BoundChance, FollowsATurnsStandardDeviation)
{
  EXPECT_NEAR(core::chanceWithinBound(alongOneAxis(5, 1.0 * kDeg), Eigen::Matrix4d::Identity(),
                                      0.5, 2.0),
              0.9545, 0.015);
  EXPECT_NEAR(core::chanceWithinBound(alongOneAxis(3, 2.0 * kDeg), Eigen::Matrix4d::Identity(),
                                      0.5, 2.0),
              0.6827, 0.02);
}

TEST(BoundChance, CountsATurnsLeverOnTheTranslation)
{
  // Yaw with 0.01 rad of spread holds the turn (3.5 sd inside 2 deg) but, about the origin,
  // moves a pose 50 m out sideways by 50 * yaw: 0.5 m of spread there.
  const Matrix6d yaw = alongOneAxis(5, 0.01);
  EXPECT_GT(core::chanceWithinBound(yaw, Eigen::Matrix4d::Identity(), 0.5, 2.0), 0.99);
  EXPECT_NEAR(core::chanceWithinBound(yaw, shiftedBy(50.0), 0.5, 2.0), 0.6827, 0.02);
}

TEST(BoundChance, IsCertainWithoutACovarianceAndRepeats)
{
  EXPECT_EQ(core::chanceWithinBound(Matrix6d::Zero(), Eigen::Matrix4d::Identity(), 0.5, 2.0),
            1.0);
  const Matrix6d c = Matrix6d::Identity() * 0.04;
  EXPECT_EQ(core::chanceWithinBound(c, shiftedBy(3.0), 0.5, 2.0),
            core::chanceWithinBound(c, shiftedBy(3.0), 0.5, 2.0));
}

TEST(BoundChance, MattersOnlyForSparseResultsConvergedByTheirOwnTestsWithACovariance)
{
  const Matrix6d c = alongOneAxis(0, 0.3);
  EXPECT_TRUE(core::spreadMatters(converged(core::kSparseInliers - 1, c)));
  EXPECT_FALSE(core::spreadMatters(converged(core::kSparseInliers, c)));
  EXPECT_FALSE(core::spreadMatters(converged(10, Matrix6d::Zero())));
  AlignmentResult refused = converged(10, c);
  refused.converged = false;
  EXPECT_FALSE(core::spreadMatters(refused));
  // The clouds swapped ending within the agreement tolerance measured its spread.
  AlignmentResult confirmed = converged(10, c);
  confirmed.verification.reverse_confirmed = true;
  EXPECT_FALSE(core::spreadMatters(confirmed));
}

TEST(BoundChance, HoldsBackASparseResultSpreadWiderThanTheBound)
{
  // sd 0.3 m along x: a chance of 0.90, so 0.99 becomes 0.89.
  AlignmentResult wide = converged(40, alongOneAxis(0, 0.3));
  core::weighTheSpread(1.0, 1.0, wide);
  EXPECT_FALSE(wide.converged);
  EXPECT_EQ(wide.verification.refusal, Refusal::WeakEvidence);
  EXPECT_NEAR(wide.verification.confidence, 0.99 * 0.904, 0.015);
  EXPECT_NE(wide.verification.reason.find("the evidence is sparse (40 source samples"),
            std::string::npos)
      << wide.verification.reason;

  // The same covariance scaled down (as covarianceScale() of 1 leaves it) passes when tight,
  // and the scale widens it.
  AlignmentResult tight = converged(40, alongOneAxis(0, 0.05));
  core::weighTheSpread(1.0, 1.0, tight);
  EXPECT_TRUE(tight.converged);
  EXPECT_TRUE(tight.verification.reason.empty());
  EXPECT_NEAR(tight.verification.confidence, 0.99, 1e-9);
  AlignmentResult scaled = converged(40, alongOneAxis(0, 0.05));
  core::weighTheSpread(36.0, 1.0, scaled); // sd 0.3 m
  EXPECT_FALSE(scaled.converged);
}
