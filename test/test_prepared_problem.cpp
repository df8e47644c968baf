/*
 * What the prepared problem builds for the refinement from real targets: the finest cubes
 * of a sparse Livox scan include those of two or three points, a dense KITTI scan's do not.
 */
#include "engine/prepared_problem.h"
#include "test_data.h"

#include <pcl_mi/io.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <string>

namespace {

pcl_mi::PointList
bundledLivoxScan(const std::string& name)
{
  pcl::PointCloud<pcl::PointXYZI> cloud;
  EXPECT_EQ(pcl_mi::io::loadKittiBin(std::string(PCL_MI_DATA_DIR) +
                                         "/foreign_lidar/livox_avia_quickshack/scans/" + name,
                                     cloud),
            "");
  pcl_mi::PointList out;
  for (const auto& p : cloud.points)
    out.emplace_back(p.x, p.y, p.z);
  return out;
}

pcl_mi::PointList
points(const pcl::PointCloud<pcl::PointXYZ>& cloud)
{
  pcl_mi::PointList out;
  for (const auto& p : cloud.points)
    out.emplace_back(p.x, p.y, p.z);
  return out;
}

/** The fewest points of any cube of the finest refinement stage of \a target. */
std::uint32_t
fewestCubePoints(pcl_mi::PointList target, pcl_mi::PointList source)
{
  pcl_mi::core::PreparedProblem problem;
  problem.setParameters(pcl_mi::Parameters());
  problem.setTarget(std::move(target));
  problem.setSource(std::move(source));
  std::string error;
  EXPECT_TRUE(problem.prepare(error)) << error;
  const pcl_mi::core::TargetDistributions& cubes = problem.distributions(0);
  EXPECT_GT(cubes.size(), 100u);
  std::uint32_t fewest = ~std::uint32_t{0};
  for (std::size_t i = 0; i < cubes.size(); ++i)
    fewest = std::min(fewest, cubes[static_cast<int>(i)].points);
  return fewest;
}

} // namespace

TEST(PreparedProblem, ASparseTargetRefinesOnCubesOfTwoPointsADenseOneOnFour)
{
  EXPECT_EQ(fewestCubePoints(bundledLivoxScan("000087.bin"), bundledLivoxScan("000090.bin")), 2u);
  EXPECT_EQ(fewestCubePoints(points(*test_data::loadScan("00", 0)),
                             points(*test_data::loadScan("00", 9))),
            4u);
  // The coarser stages of the narrow view keep four in the sparse target too.
  pcl_mi::core::PreparedProblem problem;
  problem.setParameters(pcl_mi::Parameters());
  problem.setTarget(bundledLivoxScan("000087.bin"));
  problem.setSource(bundledLivoxScan("000090.bin"));
  std::string error;
  ASSERT_TRUE(problem.prepare(error)) << error;
  ASSERT_TRUE(problem.narrowView());
  const pcl_mi::core::TargetDistributions& coarser = problem.distributions(1);
  ASSERT_GT(coarser.size(), 10u);
  for (std::size_t i = 0; i < coarser.size(); ++i)
    EXPECT_GE(coarser[static_cast<int>(i)].points, 4u);
}
