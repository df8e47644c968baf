/*
 * The verdict names the test that refused a result (Verification::refusal), in the order the
 * reason gives them, on the evidence of a real KITTI pair changed one test at a time.
 */
#include "verify/verification.h"
#include "test_data.h"

#include <pcl_mi/registration_core.h>

#include <gtest/gtest.h>

#include <cmath>

using pcl_mi::Refusal;
using pcl_mi::Verification;

namespace {

/** The evidence at the result of the bundled pair (scan 9 onto scan 0), which passes. */
Verification
passingEvidence()
{
  pcl_mi::RegistrationCore core;
  core.setTarget(test_data::pointList(*test_data::loadScan("00", 0)));
  core.setSource(test_data::pointList(*test_data::loadScan("00", 9)));
  const pcl_mi::AlignmentResult result = core.align(Eigen::Matrix4d::Identity(), 2000);
  EXPECT_TRUE(result.converged) << result.verification.reason;
  return result.verification;
}

/** \a v judged again: its refusal, with the reason checked to agree. */
Refusal
judged(Verification v)
{
  pcl_mi::core::judge(v);
  EXPECT_EQ(v.refusal == Refusal::None, v.reason.empty()) << v.reason;
  return v.refusal;
}

} // namespace

TEST(VerdictRefusal, EachTestNamesItsRefusal)
{
  const Verification passing = passingEvidence();
  EXPECT_EQ(passing.refusal, Refusal::None);
  EXPECT_EQ(judged(passing), Refusal::None);

  Verification v = passing;
  v.inliers = 0;
  EXPECT_EQ(judged(v), Refusal::LittleSharedSurface);

  v = passing;
  v.free_direction_contrast[0] = 0.0;
  EXPECT_EQ(judged(v), Refusal::Degenerate);

  v = passing;
  v.lead = -0.1;
  EXPECT_EQ(judged(v), Refusal::SecondOptimum);

  v = passing;
  v.inlier_fraction = 0.05;
  v.peak_contrast = v.weakest_contrast = 0.0;
  EXPECT_EQ(judged(v), Refusal::WeakEvidence);

  // The first test that fails names the refusal, as it leads the reason.
  v = passing;
  v.inliers = 0;
  v.free_direction_contrast[0] = 0.0;
  EXPECT_EQ(judged(v), Refusal::LittleSharedSurface);

  EXPECT_STREQ(pcl_mi::refusalName(Refusal::Degenerate), "degenerate");
  EXPECT_STREQ(pcl_mi::refusalName(Refusal::WeakEvidence), "weak evidence");
}

TEST(VerdictRefusal, HeldTurnsDoNotCountAsFreeButShiftsStillDo)
{
  const Verification passing = passingEvidence();
  Eigen::Matrix<double, 6, 1> roll = Eigen::Matrix<double, 6, 1>::Zero();
  roll[3] = 1.0;
  Eigen::Matrix<double, 6, 1> shift = Eigen::Matrix<double, 6, 1>::Zero();
  shift[0] = 1.0;

  Verification v = passing;
  v.observability_directions.col(0) = roll;
  v.free_direction_contrast[0] = 0.0;
  EXPECT_TRUE(pcl_mi::core::onlyTurnsFree(v));
  EXPECT_EQ(judged(v), Refusal::Degenerate);
  v.free_turns_held = true;
  EXPECT_EQ(judged(v), Refusal::None);
  EXPECT_FALSE(pcl_mi::core::onlyTurnsFree(v)); // nothing is free now

  // A shift beside the turn stays free, held turns or not.
  v.observability_directions.col(1) = shift;
  v.free_direction_contrast[1] = 0.0;
  EXPECT_EQ(judged(v), Refusal::Degenerate);
  v.free_turns_held = false;
  EXPECT_FALSE(pcl_mi::core::onlyTurnsFree(v));

  v = passing;
  v.observability_directions.col(0) = shift;
  v.free_direction_contrast[0] = 0.0;
  v.free_turns_held = true;
  EXPECT_FALSE(pcl_mi::core::onlyTurnsFree(v));
  EXPECT_EQ(judged(v), Refusal::Degenerate);
}

TEST(VerdictRefusal, ADegenerateResultWithTheSensorsInPlaceTakesTheirShareOfRightOnes)
{
  const Verification passing = passingEvidence();
  Eigen::Matrix<double, 6, 1> along = Eigen::Matrix<double, 6, 1>::Zero();
  along[0] = 1.0;

  // Passing in place (a sensor that stood still): the evidence's confidence stands.
  Verification v = passing;
  v.sensors_in_place = true;
  pcl_mi::core::judge(v);
  EXPECT_EQ(v.refusal, Refusal::None);
  EXPECT_GE(v.confidence, pcl_mi::core::kReliableConfidence);

  // Free along x in place: the fixed share, and the reason says why.
  v.observability_directions.col(0) = along;
  v.free_direction_contrast[0] = 0.0;
  pcl_mi::core::judge(v);
  EXPECT_EQ(v.refusal, Refusal::Degenerate);
  EXPECT_DOUBLE_EQ(v.confidence, pcl_mi::core::kInPlaceDegenerateConfidence);
  EXPECT_NE(v.reason.find("leaves the sensors where they were"), std::string::npos) << v.reason;

  // The same apart keeps the evidence's confidence.
  v.sensors_in_place = false;
  pcl_mi::core::judge(v);
  EXPECT_EQ(v.refusal, Refusal::Degenerate);
  EXPECT_GT(v.confidence, pcl_mi::core::kInPlaceDegenerateConfidence);
  EXPECT_EQ(v.reason.find("sensors"), std::string::npos) << v.reason;
}
