/*
 * The look for a second optimum along the least constrained direction, on a real KITTI pair:
 * none at the reference pose, and from a pose moved off it along that direction, a probe
 * that scores higher and lies closer to the reference.
 */
#include "engine/prepared_problem.h"
#include "engine/second_optimum.h"
#include "test_data.h"

#include <gtest/gtest.h>

#include <cmath>

namespace {

/** A covariance whose least certain translation is along x. */
Eigen::Matrix<double, 6, 6>
uncertainAlongX()
{
  Eigen::Matrix<double, 6, 6> c = Eigen::Matrix<double, 6, 6>::Identity() * 1e-6;
  c(0, 0) = 1e-2;
  return c;
}

} // namespace

TEST(SecondOptimum, NoneAtTheReferenceAndAHigherProbeNearerToItFromAPoseMovedOff)
{
  pcl_mi::core::PreparedProblem problem;
  problem.setParameters(pcl_mi::Parameters());
  problem.setTarget(test_data::pointList(*test_data::loadScan("00", 0)));
  problem.setSource(test_data::pointList(*test_data::loadScan("00", 9)));
  std::string error;
  ASSERT_TRUE(problem.prepare(error)) << error;
  const Eigen::Matrix4d reference = test_data::referenceTransform("00", 0, 9);
  pcl_mi::JointHistogram histogram;
  const auto at = [&](const Eigen::Matrix4d& pose) {
    return problem.mutualInformation(pose, histogram);
  };

  EXPECT_FALSE(pcl_mi::core::higherAlongLeastConstrained(problem, reference, at(reference),
                                                         uncertainAlongX()));

  const double voxel = problem.levelResolution(0);
  Eigen::Matrix4d moved = reference;
  moved(0, 3) += 2.0 * voxel;
  const auto higher =
      pcl_mi::core::higherAlongLeastConstrained(problem, moved, at(moved), uncertainAlongX());
  ASSERT_TRUE(higher);
  EXPECT_GT(at(*higher), at(moved));
  // Probes move along x only, and the best one goes back towards the reference.
  const Eigen::Vector3d shift = (*higher - moved).topRightCorner<3, 1>();
  EXPECT_NEAR(shift.tail<2>().norm(), 0.0, 1e-9);
  EXPECT_LT(std::abs((*higher)(0, 3) - reference(0, 3)), voxel);

  // Without a covariance (a degenerate or refused result) there is no direction to probe.
  EXPECT_FALSE(pcl_mi::core::higherAlongLeastConstrained(
      problem, moved, at(moved), Eigen::Matrix<double, 6, 6>::Zero()));
}
