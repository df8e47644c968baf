/*
 * The OpenCL backend against the CPU backend: identical joint histograms and MI at many
 * poses of real KITTI pairs, identical alignments, and the fallback when no device exists.
 * Runs wherever an OpenCL device is available (PoCL on the CPU in CI); skips otherwise.
 */
#include "test_data.h"

#include <pcl_mi/mutual_information_registration.h>
#include <pcl_mi/registration_core.h>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cstdlib>
#include <random>

using pcl_mi::Backend;

namespace {

pcl_mi::PointList
points(const pcl::PointCloud<pcl::PointXYZ>& cloud)
{
  pcl_mi::PointList list;
  for (const auto& p : cloud)
    list.emplace_back(p.x, p.y, p.z);
  return list;
}

bool
requireOpenCl()
{
  std::string why;
  if (pcl_mi::openClAvailable(&why))
    return true;
  // CI installs PoCL: there, a missing device is a failure, not a skip.
  if (std::getenv("PCL_MI_REQUIRE_OPENCL"))
    ADD_FAILURE() << "PCL_MI_REQUIRE_OPENCL is set but OpenCL is unavailable: " << why;
  return false;
}

pcl_mi::RegistrationCore
makeCore(Backend backend, pcl_mi::Feature feature, int levels, int subdivision,
         const pcl_mi::PointList& source, const pcl_mi::PointList& target)
{
  pcl_mi::RegistrationCore core;
  pcl_mi::Parameters p;
  p.backend.type = backend;
  p.grid.feature = feature;
  p.grid.pyramid_levels = levels;
  p.sampling.source_subdivision = subdivision;
  EXPECT_EQ(core.setParameters(p), "");
  core.setSource(source);
  core.setTarget(target);
  return core;
}

} // namespace

class OpenClParity : public testing::TestWithParam<std::tuple<pcl_mi::Feature, int>> {};

TEST_P(OpenClParity, JointHistogramsAndMiAreIdenticalAtManyPoses)
{
  if (!requireOpenCl())
    GTEST_SKIP() << "no OpenCL device";
  const auto [feature, subdivision] = GetParam();
  const auto source = points(*test_data::loadScan("02", 6));
  const auto target = points(*test_data::loadScan("02", 0));
  const Eigen::Matrix4d reference = test_data::referenceTransform("02", 0, 6);
  auto cpu = makeCore(Backend::Cpu, feature, 1, subdivision, source, target);
  auto gpu = makeCore(Backend::OpenCL, feature, 1, subdivision, source, target);
  std::mt19937 random(42);
  std::uniform_real_distribution<double> shift(-6.0, 6.0), turn(-0.3, 0.3), tilt(-0.05, 0.05);
  int compared = 0;
  for (int k = 0; k < 60; ++k) {
    // Around the reference and far from it, some poses with almost no overlap.
    Eigen::Affine3d offset = Eigen::Translation3d(shift(random) * (k % 3), shift(random) * (k % 3),
                                                  tilt(random) * 10) *
                             Eigen::AngleAxisd(turn(random), Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(tilt(random), Eigen::Vector3d::UnitX());
    if (k == 59)
      offset = Eigen::Translation3d(500.0, 0.0, 0.0); // no overlap at all
    const Eigen::Matrix4d pose = offset.matrix() * reference;
    pcl_mi::JointHistogram a, b;
    std::string error;
    ASSERT_TRUE(cpu.jointHistogram(pose, a, &error)) << error;
    ASSERT_TRUE(gpu.jointHistogram(pose, b, &error)) << error;
    ASSERT_EQ(a.num_bins, b.num_bins);
    EXPECT_EQ(a.overlap_voxels, b.overlap_voxels) << "pose " << k;
    EXPECT_EQ(a.counts, b.counts) << "pose " << k;
    EXPECT_EQ(cpu.evaluate(pose), gpu.evaluate(pose)) << "pose " << k;
    compared += a.overlap_voxels > 0;
  }
  EXPECT_GT(compared, 50);
  EXPECT_NE(gpu.backendName().find("opencl"), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(Backends,
                         OpenClParity,
                         testing::Combine(testing::Values(pcl_mi::Feature::VarianceZ,
                                                          pcl_mi::Feature::PointCount),
                                          testing::Values(0, 2)));

TEST(OpenClAlignment, SamePoseAsTheCpuOnTheBundledPairs)
{
  if (!requireOpenCl())
    GTEST_SKIP() << "no OpenCL device";
  for (const auto& [sequence, earlier, later] :
       {std::make_tuple("00", 0, 9), std::make_tuple("02", 0, 6)})
    for (const bool backward : {false, true}) {
      const int target_frame = backward ? later : earlier;
      const int source_frame = backward ? earlier : later;
      SCOPED_TRACE(testing::Message() << sequence << " " << source_frame << "->" << target_frame);
      const auto source = test_data::loadScan(sequence, source_frame);
      const auto target = test_data::loadScan(sequence, target_frame);
      Eigen::Matrix4f result[2];
      for (const Backend backend : {Backend::Cpu, Backend::OpenCL}) {
        pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
        reg.setBackend(backend);
        reg.setInputSource(source);
        reg.setInputTarget(target);
        pcl::PointCloud<pcl::PointXYZ> aligned;
        reg.align(aligned);
        ASSERT_TRUE(reg.hasConverged()) << reg.getLastError();
        result[backend == Backend::OpenCL] = reg.getFinalTransformation();
        EXPECT_POSE_NEAR(result[backend == Backend::OpenCL].cast<double>(),
                         test_data::referenceTransform(sequence, target_frame, source_frame));
      }
      EXPECT_LT((result[0] - result[1]).cwiseAbs().maxCoeff(), 1e-5f);
    }
}

TEST(OpenClAuto, TakesOpenClOnlyWhereItIsFaster)
{
  if (!requireOpenCl())
    GTEST_SKIP() << "no OpenCL device";
  const auto source = points(*test_data::loadScan("02", 6));
  const auto target = points(*test_data::loadScan("02", 0));
  const Eigen::Matrix4d pose = test_data::referenceTransform("02", 0, 6);
  // Light evaluations (the defaults' samples): the CPU backend, and no fallback warning.
  auto light = makeCore(Backend::Auto, pcl_mi::Feature::VarianceZ, 3, 2, source, target);
  EXPECT_GT(light.evaluate(pose), 0.0);
  EXPECT_EQ(light.backendName(), "cpu");
  EXPECT_EQ(light.backendWarning(), "");
  // Every point: the OpenCL device if it is a GPU or accelerator, else (PoCL on the CPU)
  // the CPU backend; never a warning, since a device exists.
  auto every = makeCore(Backend::Auto, pcl_mi::Feature::VarianceZ, 1, 0, source, target);
  auto opencl = makeCore(Backend::OpenCL, pcl_mi::Feature::VarianceZ, 1, 0, source, target);
  EXPECT_DOUBLE_EQ(every.evaluate(pose), opencl.evaluate(pose));
  EXPECT_TRUE(every.backendName() == "cpu" || every.backendName() == opencl.backendName())
      << every.backendName();
  EXPECT_EQ(every.backendWarning(), "");
}

TEST(OpenClProfile, ReportsThePapersStages)
{
  if (!requireOpenCl())
    GTEST_SKIP() << "no OpenCL device";
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setBackend(Backend::OpenCL);
  reg.setInputSource(test_data::loadScan("00", 9));
  reg.setInputTarget(test_data::loadScan("00", 0));
  pcl::PointCloud<pcl::PointXYZ> aligned;
  // Without device profiling (the default) only the host-side stages are timed.
  reg.align(aligned);
  const Eigen::Matrix4f unprofiled = reg.getFinalTransformation();
  for (const auto& s : reg.getBackendProfile())
    EXPECT_EQ(s.name.rfind("device:", 0), std::string::npos) << s.name;

  reg.setDeviceProfiling(true);
  reg.align(aligned);
  EXPECT_EQ(reg.getFinalTransformation(), unprofiled); // events time, they do not change
  const auto stages = reg.getBackendProfile();
  auto find = [&](const std::string& name) {
    for (const auto& s : stages)
      if (s.name == name)
        return s;
    return pcl_mi::StageTiming{};
  };
  // Every search evaluation, plus the overlap check at the guess and the MI of the final
  // (refined) pose.
  const int evaluations = reg.getNumberOfEvaluations() + 2;
  EXPECT_EQ(find("device: voxel mapping").calls, evaluations);
  EXPECT_EQ(find("device: find overlap").calls, evaluations);
  EXPECT_EQ(find("device: feature histogram").calls, 2 * evaluations);
  EXPECT_GT(find("device: voxel mapping").total_ms, 0.0);
  EXPECT_GT(find("host: memory allocation").calls, 0);
  EXPECT_GT(find("host: copy to device").calls, 0);
}
