/*
 * The OpenCL backend against the CPU backend: identical joint histograms and MI at many
 * poses of real KITTI pairs, one at a time and in batches, identical alignments, and the
 * fallback when no device exists.
 * Runs wherever an OpenCL device is available (PoCL on the CPU in CI); skips otherwise.
 */
#include "test_data.h"

#include <pcl_mi/mutual_information_registration.h>
#include <pcl_mi/registration_core.h>

#include "backend/scoring_backend.h"
#include "engine/second_optimum.h"
#ifdef PCL_MI_WITH_OPENCL
#include "backend/opencl_backend.h"
#endif

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cstdlib>
#include <random>

using pcl_mi::Backend;

namespace {

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
  const auto source = test_data::pointList(*test_data::loadScan("02", 6));
  const auto target = test_data::pointList(*test_data::loadScan("02", 0));
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

TEST(OpenClBatches, EachPoseOfABatchGetsTheCpuHistogram)
{
  if (!requireOpenCl())
    GTEST_SKIP() << "no OpenCL device";
#ifdef PCL_MI_WITH_OPENCL
  using namespace pcl_mi::core;
  const auto source = test_data::pointList(*test_data::loadScan("02", 6));
  const auto target = test_data::pointList(*test_data::loadScan("02", 0));
  std::string error;
  auto device = pcl_mi::backend::openClDevice(-1, -1, error);
  ASSERT_TRUE(device) << error;
  for (const pcl_mi::Feature feature : {pcl_mi::Feature::VarianceZ, pcl_mi::Feature::PointCount}) {
    auto grid = std::make_shared<TargetGrid>();
    ASSERT_TRUE(buildTargetGrid(target, 2.0, feature, {16, feature == pcl_mi::Feature::PointCount
                                                               ? 400.0
                                                               : 1.0 / 12},
                                *grid, error))
        << error;
    auto samples = std::make_shared<const SourceSamples>(makeSourceSamples(source, 0.5));
    auto cpu = pcl_mi::backend::makeCpuBackend();
    auto gpu = pcl_mi::backend::makeOpenClBackend(device, false, true);
    for (auto* b : {cpu.get(), gpu.get()}) {
      b->setTarget(grid);
      b->setSource(samples);
    }
    EXPECT_FALSE(cpu->prefersBatches());
    EXPECT_TRUE(gpu->prefersBatches());
    std::mt19937 random(7);
    std::uniform_real_distribution<float> shift(-8.0f, 8.0f), turn(-0.4f, 0.4f);
    // Batches that grow (new scratch), shrink (scratch kept) and hold poses without
    // overlap, so that no pose's scratch leaks into the next batch's.
    for (const std::size_t size : {1u, 4u, 7u, 3u, 12u, 6u, 1u}) {
      std::vector<Eigen::Matrix3f> rotations;
      std::vector<Eigen::Vector3f> translations;
      for (std::size_t k = 0; k < size; ++k) {
        rotations.push_back(Eigen::AngleAxisf(turn(random), Eigen::Vector3f::UnitZ()) *
                            Eigen::AngleAxisf(0.1f * turn(random), Eigen::Vector3f::UnitX())
                                .toRotationMatrix());
        translations.emplace_back(shift(random), shift(random), 0.1f * shift(random));
        if (k == 2)
          translations.back() = Eigen::Vector3f(900.0f, 0.0f, 0.0f);
      }
      std::vector<pcl_mi::JointHistogram> batch;
      gpu->jointHistograms(rotations, translations, batch);
      ASSERT_EQ(batch.size(), size);
      for (std::size_t k = 0; k < size; ++k) {
        SCOPED_TRACE(testing::Message() << "batch of " << size << ", pose " << k);
        pcl_mi::JointHistogram single;
        cpu->jointHistogram(rotations[k], translations[k], single);
        EXPECT_EQ(batch[k].num_bins, single.num_bins);
        EXPECT_EQ(batch[k].overlap_voxels, single.overlap_voxels);
        EXPECT_EQ(batch[k].counts, single.counts);
        EXPECT_EQ(single.overlap_voxels == 0, k == 2);
      }
    }
  }
#endif
}

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
      // The CPU; OpenCL one pose per round trip; OpenCL in lockstep batches.
      Eigen::Matrix4f result[3];
      int evaluations[3];
      for (int run = 0; run < 3; ++run) {
        pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
        reg.setBackend(run == 0 ? Backend::Cpu : Backend::OpenCL);
        reg.setBatching(run == 2 ? pcl_mi::Batching::On : pcl_mi::Batching::Off);
        reg.setInputSource(source);
        reg.setInputTarget(target);
        pcl::PointCloud<pcl::PointXYZ> aligned;
        reg.align(aligned);
        ASSERT_TRUE(reg.hasConverged()) << reg.getLastError();
        result[run] = reg.getFinalTransformation();
        evaluations[run] = reg.getNumberOfEvaluations();
        EXPECT_POSE_NEAR(result[run].cast<double>(),
                         test_data::referenceTransform(sequence, target_frame, source_frame));
      }
      EXPECT_LT((result[0] - result[1]).cwiseAbs().maxCoeff(), 1e-5f);
      EXPECT_EQ(result[2], result[1]);
      EXPECT_EQ(evaluations[2], evaluations[1]);
      EXPECT_EQ(evaluations[1], evaluations[0]);
    }
}

TEST(OpenClAuto, TakesOpenClOnlyWhereItIsFaster)
{
  if (!requireOpenCl())
    GTEST_SKIP() << "no OpenCL device";
  const auto source = test_data::pointList(*test_data::loadScan("02", 6));
  const auto target = test_data::pointList(*test_data::loadScan("02", 0));
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
  reg.setBatching(pcl_mi::Batching::Off);
  // One thread: on two, an evaluator with no search left evaluates spare points for the
  // other's (the same pose), which the counts below would include.
  pcl_mi::Parameters one_thread = reg.getParameters();
  one_thread.num_threads = 1;
  reg.setParameters(one_thread);
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
  // Every kernel runs once per round trip: here one per search evaluation, plus the
  // overlap check at the guess, the MI of the final (refined) pose and, since that passed,
  // the probes for a second optimum.
  ASSERT_TRUE(reg.hasConverged());
  const int evaluations =
      reg.getNumberOfEvaluations() + 2 + pcl_mi::core::kSecondOptimumProbes;
  EXPECT_EQ(find("host: round trips").calls, evaluations);
  EXPECT_EQ(find("device: voxel mapping").calls, evaluations);
  EXPECT_EQ(find("device: find overlap").calls, evaluations);
  EXPECT_EQ(find("device: feature histogram").calls, 2 * evaluations);
  EXPECT_GT(find("device: voxel mapping").total_ms, 0.0);
  EXPECT_GT(find("host: memory allocation").calls, 0);
  EXPECT_GT(find("host: copy to device").calls, 0);

  // In batches the same evaluations, and speculative ones besides, take a fraction of the
  // round trips, and the pose is the same.
  reg.setBatching(pcl_mi::Batching::On);
  reg.align(aligned);
  EXPECT_EQ(reg.getFinalTransformation(), unprofiled);
  EXPECT_EQ(reg.getNumberOfEvaluations() + 2 + pcl_mi::core::kSecondOptimumProbes,
            evaluations);
  const auto batched = reg.getBackendProfile();
  int round_trips = 0, mapped = 0;
  for (const auto& s : batched) {
    round_trips += s.name == "host: round trips" ? s.calls : 0;
    mapped += s.name == "device: voxel mapping" ? s.calls : 0;
  }
  EXPECT_GT(round_trips, 2);
  EXPECT_LT(2 * round_trips, evaluations);
  EXPECT_EQ(mapped, round_trips);

  // On two threads one at a time again: the same pose, with the spare points besides.
  reg.setBatching(pcl_mi::Batching::Off);
  pcl_mi::Parameters two_threads = reg.getParameters();
  two_threads.num_threads = 2;
  reg.setParameters(two_threads);
  reg.align(aligned);
  EXPECT_EQ(reg.getFinalTransformation(), unprofiled);
  int helped_round_trips = 0;
  for (const auto& s : reg.getBackendProfile())
    helped_round_trips += s.name == "host: round trips" ? s.calls : 0;
  EXPECT_GE(helped_round_trips, evaluations);
}
