/*
 * Bad input gets a clear error (PCL_ERROR, getLastError()), hasConverged() == false, no
 * exception and no crash; input that can be cleaned (NaN points, a far outlier) aligns.
 */
#include "test_data.h"

#include <pcl_mi/mutual_information_registration.h>

#include <gtest/gtest.h>

#include <limits>

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Registration = pcl::MutualInformationRegistration<pcl::PointXYZ>;

namespace {

Cloud::Ptr
cloudOf(std::initializer_list<Eigen::Vector3f> points)
{
  auto cloud = pcl::make_shared<Cloud>();
  for (const auto& p : points)
    cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  return cloud;
}

class BadInput : public ::testing::Test {
protected:
  static void
  SetUpTestSuite()
  {
    source_ = test_data::loadScan("00", 9);
    target_ = test_data::loadScan("00", 0);
    reference_ = test_data::referenceTransform("00", 0, 9);
  }
  static Cloud::Ptr source_, target_;
  static Eigen::Matrix4d reference_;
};
Cloud::Ptr BadInput::source_, BadInput::target_;
Eigen::Matrix4d BadInput::reference_;

} // namespace

TEST_F(BadInput, EmptySource)
{
  Registration reg;
  reg.setInputSource(pcl::make_shared<Cloud>());
  reg.setInputTarget(target_);
  test_data::expectRefused(reg, "source has 0 usable points");
}

TEST_F(BadInput, EmptyTarget)
{
  Registration reg;
  reg.setInputSource(source_);
  reg.setInputTarget(pcl::make_shared<Cloud>());
  test_data::expectRefused(reg, "target has 0 usable points");
}

TEST_F(BadInput, NoTargetGiven)
{
  Registration reg;
  reg.setInputSource(source_);
  Cloud output;
  EXPECT_NO_THROW(reg.align(output)); // PCL's base class reports the missing target
  EXPECT_FALSE(reg.hasConverged());
}

TEST_F(BadInput, SinglePoint)
{
  Registration reg;
  reg.setInputSource(cloudOf({{1, 2, 3}}));
  reg.setInputTarget(target_);
  test_data::expectRefused(reg, "source has 1 usable points");
}

TEST_F(BadInput, NanOnlyCloud)
{
  const float nan = std::numeric_limits<float>::quiet_NaN();
  Registration reg;
  reg.setInputSource(source_);
  reg.setInputTarget(cloudOf({{nan, 0, 0}, {0, nan, 0}, {nan, nan, nan}, {0, 0, nan}}));
  test_data::expectRefused(reg, "4 non-finite");
}

TEST_F(BadInput, NoReturnOnlyCloud)
{
  // A scan whose every beam came back empty, written as (0, 0, 0) by the driver.
  Registration reg;
  reg.setInputSource(source_);
  reg.setInputTarget(cloudOf({{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {1, 2, 3}}));
  test_data::expectRefused(reg, "target has 1 usable points (0 non-finite, 3 at (0, 0, 0)");
}

TEST_F(BadInput, NanAndInfPointsAreSkipped)
{
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  auto source = pcl::make_shared<Cloud>(*source_);
  auto target = pcl::make_shared<Cloud>(*target_);
  for (int i = 0; i < 1000; ++i) {
    source->push_back(pcl::PointXYZ(i % 2 ? nan : inf, 0, 0));
    target->push_back(pcl::PointXYZ(0, -inf, i % 3 ? nan : 1.0f));
  }
  source->is_dense = target->is_dense = false;
  Registration reg;
  reg.setInputSource(source);
  reg.setInputTarget(target);
  Cloud output;
  EXPECT_NO_THROW(reg.align(output));
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference_);
  EXPECT_EQ(reg.core().droppedSourcePoints(), 1000u);
  EXPECT_EQ(reg.core().droppedTargetPoints(), 1000u);
}

TEST_F(BadInput, NoOverlapAtTheGuess)
{
  Registration reg;
  reg.setInputSource(source_);
  reg.setInputTarget(target_);
  Eigen::Matrix4f far = Eigen::Matrix4f::Identity();
  far(0, 3) = 5000.0f;
  test_data::expectRefused(reg, "do not overlap", far);
  // Beyond the range of int in voxels, on either side of the grid (found by fuzz_align:
  // the overlap box's integer cast overflowed; the sanitizer build checks for it).
  for (const float offset : {-1e10f, 1e10f}) {
    SCOPED_TRACE(offset);
    far(0, 3) = offset;
    far(2, 3) = -offset;
    test_data::expectRefused(reg, "do not overlap", far);
  }
}

TEST_F(BadInput, NonFiniteGuess)
{
  Registration reg;
  reg.setInputSource(source_);
  reg.setInputTarget(target_);
  Eigen::Matrix4f guess = Eigen::Matrix4f::Identity();
  guess(1, 3) = std::numeric_limits<float>::quiet_NaN();
  Cloud output;
  EXPECT_NO_THROW(reg.align(output, guess));
  EXPECT_FALSE(reg.hasConverged());
  EXPECT_NE(reg.getLastError().find("not finite"), std::string::npos);
}

TEST_F(BadInput, FarOutlierIsDroppedAndMemoryStaysBounded)
{
  // One point 1e5 m away would stretch a dense 1 m grid over 1e5 x 80 x 10 voxels (80 GB
  // of accumulators). It is dropped as an outlier and the pair still aligns.
  auto source = pcl::make_shared<Cloud>(*source_);
  auto target = pcl::make_shared<Cloud>(*target_);
  source->push_back(pcl::PointXYZ(1e5f, 0, 0));
  target->push_back(pcl::PointXYZ(0, -1e5f, 3));
  Registration reg;
  reg.setInputSource(source);
  reg.setInputTarget(target);
  Cloud output;
  reg.align(output);
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference_);
  EXPECT_EQ(reg.core().droppedSourcePoints(), 1u);
  EXPECT_EQ(reg.core().droppedTargetPoints(), 1u);
}

TEST_F(BadInput, ExtentTooLargeForTheGridIsRefused)
{
  // A gap-free lattice 300 m x 300 m x 20 m at 0.1 m voxels needs 1.8e9 cells: the grid is
  // refused with a reason instead of allocating without bound.
  auto lattice = pcl::make_shared<Cloud>();
  for (int i = 0; i <= 60; ++i)
    for (int j = 0; j <= 60; ++j)
      for (int k = 0; k <= 4; ++k)
        lattice->push_back(pcl::PointXYZ(5.0f * i, 5.0f * j, 5.0f * k));
  Registration reg;
  reg.setResolution(0.1);
  reg.setInputSource(lattice);
  reg.setInputTarget(lattice);
  test_data::expectRefused(reg, "coarser resolution");
}

TEST(BadParameters, SettersRefuseAndKeepTheOldValue)
{
  Registration reg;
  // The default resolution is derived from the target: unknown (0) until one is set.
  EXPECT_EQ(reg.getParameters().grid.resolution, 0.0);
  EXPECT_EQ(reg.getResolution(), 0.0);
  reg.setNumberOfRestarts(1); // another setter leaves it unknown
  EXPECT_EQ(reg.getResolution(), 0.0);
  EXPECT_EQ(reg.getSimplexSteps()[0], -16.0);
  reg.setNumberOfRestarts(0);
  reg.setResolution(0.5);
  reg.setResolution(-2.0);
  EXPECT_EQ(reg.getResolution(), 0.5);
  reg.setResolution(std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(reg.getResolution(), 0.5);
  reg.setResolution(std::numeric_limits<double>::infinity());
  EXPECT_EQ(reg.getResolution(), 0.5);

  reg.setFeatureBinning(pcl_mi::Feature::VarianceZ, 0, 0.1);
  EXPECT_EQ(reg.getFeatureBinning(pcl_mi::Feature::VarianceZ).num_bins, 16);
  reg.setFeatureBinning(pcl_mi::Feature::PointCount, -3, 10);
  EXPECT_EQ(reg.getFeatureBinning(pcl_mi::Feature::PointCount).num_bins, 16);
  reg.setFeatureBinning(pcl_mi::Feature::PointCount, 8, 0.0);
  EXPECT_EQ(reg.getFeatureBinning(pcl_mi::Feature::PointCount).max_value, 64.0);
  reg.setFeatureBinning(pcl_mi::Feature::PointCount, 256, 10.0); // bins must fit a byte
  EXPECT_EQ(reg.getFeatureBinning(pcl_mi::Feature::PointCount).num_bins, 16);

  reg.setSimplexSteps(Eigen::Matrix<double, 6, 1>::Zero());
  // The default translation steps are 16, 16 and 4 voxels: 8, 8 and 2 at 0.5 m.
  EXPECT_EQ(reg.getSimplexSteps()[0], 8.0);
  EXPECT_EQ(reg.getSimplexSteps()[2], 2.0);
  EXPECT_EQ(reg.getParameters().search.simplex_steps[0], -16.0);
  // Lengths tied to the grid follow the resolution (0.5 here) until they are set; 0
  // returns them to following it.
  EXPECT_EQ(reg.getTranslationTolerance(), 0.0025);
  reg.setTranslationTolerance(-0.01);
  EXPECT_EQ(reg.getTranslationTolerance(), 0.0025);
  reg.setTranslationTolerance(std::numeric_limits<double>::infinity());
  EXPECT_EQ(reg.getTranslationTolerance(), 0.0025);
  reg.setTranslationTolerance(0.01);
  EXPECT_EQ(reg.getTranslationTolerance(), 0.01);
  reg.setTranslationTolerance(0.0);
  EXPECT_EQ(reg.getTranslationTolerance(), 0.0025);
  EXPECT_EQ(reg.getRefinementResolution(), 0.35);
  reg.setRefinementResolution(-0.7);
  EXPECT_EQ(reg.getRefinementResolution(), 0.35);
  reg.setRefinementResolution(std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(reg.getRefinementResolution(), 0.35);
  reg.setRefinementResolution(0.9);
  EXPECT_EQ(reg.getRefinementResolution(), 0.9);
  reg.setResolution(2.0); // an explicit value stays
  EXPECT_EQ(reg.getRefinementResolution(), 0.9);
  reg.setRefinementResolution(0.0);
  EXPECT_EQ(reg.getRefinementResolution(), 1.4);
  reg.setResolution(0.5);
  reg.setNumberOfRestarts(-1);
  EXPECT_EQ(reg.getNumberOfRestarts(), pcl_mi::Parameters().search.restarts);
  reg.setNumberOfHeadingStarts(0);
  EXPECT_EQ(reg.getNumberOfHeadingStarts(), 1);
  reg.setNumberOfHeadingStarts(361);
  EXPECT_EQ(reg.getNumberOfHeadingStarts(), 1);
  reg.setNumberOfHeadingStarts(8);
  EXPECT_EQ(reg.getNumberOfHeadingStarts(), 8);
  reg.setNumberOfPositionStarts(-1);
  EXPECT_EQ(reg.getNumberOfPositionStarts(), 0);
  reg.setNumberOfPositionStarts(4);
  EXPECT_EQ(reg.getNumberOfPositionStarts(), 4);
  reg.setNarrowViewPositionStarts(-1);
  EXPECT_EQ(reg.getNarrowViewPositionStarts(), 8);
  reg.setNarrowViewPositionStarts(361);
  EXPECT_EQ(reg.getNarrowViewPositionStarts(), 8);
  reg.setNarrowViewPositionStarts(0);
  EXPECT_EQ(reg.getNarrowViewPositionStarts(), 0);

  pcl_mi::Parameters bad;
  bad.refinement.max_iterations = 0;
  EXPECT_FALSE(reg.setParameters(bad));
  EXPECT_EQ(reg.getParameters().refinement.max_iterations, 20);
}

TEST(BadParameters, BackendNamesParseStrictly)
{
  pcl_mi::Backend backend = pcl_mi::Backend::Auto;
  EXPECT_TRUE(pcl_mi::parseBackend("cpu", backend));
  EXPECT_EQ(backend, pcl_mi::Backend::Cpu);
  EXPECT_TRUE(pcl_mi::parseBackend("opencl", backend));
  EXPECT_EQ(backend, pcl_mi::Backend::OpenCL);
  EXPECT_TRUE(pcl_mi::parseBackend("auto", backend));
  EXPECT_EQ(backend, pcl_mi::Backend::Auto);
  for (const char* bad : {"", "CPU", "gpu", "opencl "}) {
    EXPECT_FALSE(pcl_mi::parseBackend(bad, backend)) << bad;
    EXPECT_EQ(backend, pcl_mi::Backend::Auto) << bad;
  }
}

TEST(BadParameters, BatchingNamesParseStrictly)
{
  pcl_mi::Batching batching = pcl_mi::Batching::Auto;
  EXPECT_TRUE(pcl_mi::parseBatching("on", batching));
  EXPECT_EQ(batching, pcl_mi::Batching::On);
  EXPECT_TRUE(pcl_mi::parseBatching("off", batching));
  EXPECT_EQ(batching, pcl_mi::Batching::Off);
  EXPECT_TRUE(pcl_mi::parseBatching("auto", batching));
  EXPECT_EQ(batching, pcl_mi::Batching::Auto);
  for (const char* bad : {"", "ON", "yes", "1"}) {
    EXPECT_FALSE(pcl_mi::parseBatching(bad, batching)) << bad;
    EXPECT_EQ(batching, pcl_mi::Batching::Auto) << bad;
  }
}

TEST_F(BadInput, BaseClassIterationCapZeroIsReported)
{
  // setMaximumIterations() is the base class's and cannot refuse; align() reports it.
  Registration reg;
  reg.setInputSource(source_);
  reg.setInputTarget(target_);
  reg.setMaximumIterations(0);
  test_data::expectRefused(reg, "invalid parameters");
}

TEST_F(BadInput, IterationCapIsNotConvergence)
{
  Registration reg;
  reg.setInputSource(source_);
  reg.setInputTarget(target_);
  reg.setMaximumIterations(5);
  Cloud output;
  reg.align(output);
  EXPECT_FALSE(reg.hasConverged());
  // Said in getLastError(), though not a failure: the pose is the best found, not the guess.
  EXPECT_NE(reg.getLastError().find("iteration cap (setMaximumIterations(5))"), std::string::npos)
      << reg.getLastError();
  EXPECT_TRUE(reg.getLastResult().error.empty());
  EXPECT_FALSE(reg.getFinalTransformation().isIdentity());
  EXPECT_LE(reg.getFinalNumIteration(), 5);
}
