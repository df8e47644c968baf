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

using pcl_mi::core::PreparedProblem;
using pcl_mi::core::TargetDistributions;

pcl_mi::PointList
bundledLivoxScan(const std::string& name)
{
  pcl::PointCloud<pcl::PointXYZI> cloud;
  EXPECT_EQ(pcl_mi::io::loadKittiBin(std::string(PCL_MI_DATA_DIR) +
                                         "/foreign_lidar/livox_avia_quickshack/scans/" + name,
                                     cloud),
            "");
  return test_data::pointList(cloud);
}

/** \a problem given \a target and \a source with the defaults, and prepared. */
void
prepare(PreparedProblem& problem, pcl_mi::PointList target, pcl_mi::PointList source)
{
  problem.setParameters(pcl_mi::Parameters());
  problem.setTarget(std::move(target));
  problem.setSource(std::move(source));
  std::string error;
  EXPECT_TRUE(problem.prepare(error)) << error;
}

/** The fewest points of any of \a cubes. */
std::uint32_t
fewestPoints(const TargetDistributions& cubes)
{
  std::uint32_t fewest = ~std::uint32_t{0};
  for (std::size_t i = 0; i < cubes.size(); ++i)
    fewest = std::min(fewest, cubes[static_cast<int>(i)].points);
  return fewest;
}

} // namespace

TEST(PreparedProblem, ASparseTargetRefinesOnCubesOfTwoPointsADenseOneOnFour)
{
  PreparedProblem livox;
  prepare(livox, bundledLivoxScan("000087.bin"), bundledLivoxScan("000090.bin"));
  ASSERT_GT(livox.distributions(0).size(), 100u);
  EXPECT_EQ(fewestPoints(livox.distributions(0)), 2u);
  // The coarser stages of the narrow view keep four in the sparse target too.
  ASSERT_TRUE(livox.narrowView());
  ASSERT_GT(livox.distributions(1).size(), 10u);
  EXPECT_EQ(fewestPoints(livox.distributions(1)), 4u);

  PreparedProblem kitti;
  prepare(kitti, test_data::pointList(*test_data::loadScan("00", 0)),
          test_data::pointList(*test_data::loadScan("00", 9)));
  ASSERT_GT(kitti.distributions(0).size(), 100u);
  EXPECT_EQ(fewestPoints(kitti.distributions(0)), 4u);
}
