/*
 * Run with OCL_ICD_VENDORS pointing at an empty directory (see test/CMakeLists.txt): no
 * OpenCL platform exists. Auto must use the CPU and still align (warning where it wanted a
 * device); OpenCL requested explicitly must fail with a clear error, not crash.
 */
#include "test_data.h"

#include <pcl_mi/mutual_information_registration.h>
#include <pcl_mi/registration_core.h>

#include <gtest/gtest.h>

TEST(NoOpenClDevice, AutoFallsBackToTheCpuAndExplicitOpenClFailsClearly)
{
  std::string why;
  ASSERT_FALSE(pcl_mi::openClAvailable(&why)) << "this test needs an environment without "
                                                 "OpenCL platforms";
  EXPECT_FALSE(why.empty());

  const auto source = test_data::loadScan("00", 9);
  const auto target = test_data::loadScan("00", 0);
  pcl::PointCloud<pcl::PointXYZ> aligned;

  pcl::MutualInformationRegistration<pcl::PointXYZ> automatic;
  automatic.setBackend(pcl_mi::Backend::Auto);
  automatic.setInputSource(source);
  automatic.setInputTarget(target);
  automatic.align(aligned);
  EXPECT_TRUE(automatic.hasConverged()) << automatic.getLastError();
  EXPECT_EQ(automatic.core().backendName(), "cpu");
  // The defaults' light evaluations run on the CPU by choice: Auto does not look for a
  // device, so there is nothing to warn about.
  EXPECT_EQ(automatic.core().backendWarning(), "");
  EXPECT_POSE_NEAR(automatic.getFinalTransformation().cast<double>(),
                   test_data::referenceTransform("00", 0, 9));

  // With every point in every evaluation Auto wants a GPU, finds no platform and warns.
  pcl::MutualInformationRegistration<pcl::PointXYZ> every_point;
  pcl_mi::Parameters paper = pcl_mi::Parameters::paper();
  paper.backend.type = pcl_mi::Backend::Auto;
  every_point.setParameters(paper);
  every_point.setInputSource(source);
  every_point.setInputTarget(target);
  every_point.align(aligned);
  EXPECT_TRUE(every_point.hasConverged()) << every_point.getLastError();
  EXPECT_EQ(every_point.core().backendName(), "cpu");
  EXPECT_NE(every_point.core().backendWarning(), "");

  pcl::MutualInformationRegistration<pcl::PointXYZ> explicit_opencl;
  explicit_opencl.setBackend(pcl_mi::Backend::OpenCL);
  explicit_opencl.setInputSource(source);
  explicit_opencl.setInputTarget(target);
  explicit_opencl.align(aligned);
  EXPECT_FALSE(explicit_opencl.hasConverged());
  EXPECT_NE(explicit_opencl.getLastError().find("OpenCL backend was requested but is unavailable"),
            std::string::npos)
      << explicit_opencl.getLastError();
}
