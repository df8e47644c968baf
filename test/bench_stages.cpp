/*
 * pcl_mi: a Google Benchmark per stage of one alignment, on the bundled KITTI pair (scan 9
 * of sequence 00 onto scan 0, about 120k points each) with the defaults. Run with
 * `cmake --build build --target bench` or directly (`--benchmark_filter=...`). A benchmark,
 * not a test: the figures depend on the machine and its load.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/derived_defaults.h"
#include "engine/input_checks.h"
#include "engine/prepared_problem.h"
#include "engine/refine_optimum.h"
#include "engine/search_space.h"
#include "features/local_cloud.h"
#include "features/source_samples.h"
#include "features/voxel_grid.h"
#include "refine/refinement.h"
#include "verify/verification.h"

#include <pcl_mi/io.h>
#include <pcl_mi/kitti.h>
#include <pcl_mi/mutual_information_registration.h>
#include <pcl_mi/registration_core.h>

#include <pcl/point_types.h>

#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZI>;

/** The bundled pair, its points and the defaults resolved for its target, loaded once. */
struct Pair {
  Cloud::Ptr source = std::make_shared<Cloud>(), target = std::make_shared<Cloud>();
  pcl_mi::PointList source_points, target_points;
  pcl_mi::Parameters parameters; // resolved: derived resolution and steps
  pcl_mi::core::LocalCloud source_local, target_local;

  Pair()
  {
    const std::string root = std::string(PCL_MI_DATA_DIR) + "/kitti";
    for (const auto& [cloud, frame] : {std::make_pair(source, 9), std::make_pair(target, 0)}) {
      const std::string error =
          pcl_mi::io::loadCloud(pcl_mi::kitti::scanPath(root, "00", frame), *cloud);
      if (!error.empty())
        throw std::runtime_error(error);
    }
    for (const auto& p : *source)
      source_points.emplace_back(p.x, p.y, p.z);
    for (const auto& p : *target)
      target_points.emplace_back(p.x, p.y, p.z);
    parameters = pcl_mi::core::resolveParameters(
        pcl_mi::Parameters(), pcl_mi::core::deriveResolution(target_points));
    const double gap = pcl_mi::core::kOutlierGapVoxels * resolution();
    source_local = pcl_mi::core::makeLocalCloud(source_points, gap);
    target_local = pcl_mi::core::makeLocalCloud(target_points, gap);
  }

  double
  resolution() const
  {
    return parameters.grid.resolution;
  }
};

const Pair&
pair()
{
  static const Pair p;
  return p;
}

/** A problem prepared on the pair, for the stages that run on a prepared problem. */
pcl_mi::core::PreparedProblem&
prepared()
{
  static pcl_mi::core::PreparedProblem problem = [] {
    pcl_mi::core::PreparedProblem p;
    p.setParameters(pcl_mi::Parameters());
    p.setTarget(pair().target_points);
    p.setSource(pair().source_points);
    std::string error;
    if (!p.prepare(error))
      throw std::runtime_error(error);
    return p;
  }();
  return problem;
}

void
BM_LocalCloud(benchmark::State& state)
{
  const Pair& p = pair();
  const int threads = static_cast<int>(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(pcl_mi::core::makeLocalCloud(
        p.target_points, pcl_mi::core::kOutlierGapVoxels * p.resolution(), threads));
}
// On one thread as a target beside a new source; on two as a new source alone (scan to map).
BENCHMARK(BM_LocalCloud)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

void
BM_InputChecks(benchmark::State& state)
{
  const Pair& p = pair();
  for (auto _ : state) {
    benchmark::DoNotOptimize(pcl_mi::core::resolutionError(p.target_points, p.resolution(), "target"));
    benchmark::DoNotOptimize(pcl_mi::core::structureError(p.target_local, p.resolution(), "target"));
  }
}
BENCHMARK(BM_InputChecks)->Unit(benchmark::kMillisecond);

void
BM_SourceSamplePyramid(benchmark::State& state)
{
  const Pair& p = pair();
  const int levels = p.parameters.grid.pyramid_levels;
  const double cell = p.resolution() / p.parameters.sampling.source_subdivision;
  for (auto _ : state)
    benchmark::DoNotOptimize(
        pcl_mi::core::makeSourceSamplePyramid(p.source_local.points, cell, levels - 1,
                                              static_cast<int>(state.range(0))));
}
BENCHMARK(BM_SourceSamplePyramid)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void
BM_TargetGrid(benchmark::State& state)
{
  const Pair& p = pair();
  const double resolution = p.resolution() * (1 << state.range(0));
  for (auto _ : state) {
    pcl_mi::core::TargetGrid grid;
    std::string error;
    pcl_mi::core::buildTargetGrid(p.target_local.points, resolution, p.parameters.grid.feature,
                                  p.parameters.grid.binning(), grid, error);
    benchmark::DoNotOptimize(grid.bins.data());
  }
}
BENCHMARK(BM_TargetGrid)->DenseRange(0, 2)->Unit(benchmark::kMillisecond);

void
BM_TargetDistributions(benchmark::State& state)
{
  const Pair& p = pair();
  for (auto _ : state)
    benchmark::DoNotOptimize(pcl_mi::core::TargetDistributions(
        p.target_local.points, p.parameters.effectiveRefinementResolution(), 4,
        0.05 * p.resolution()));
}
BENCHMARK(BM_TargetDistributions)->Unit(benchmark::kMillisecond);

/** prepare() from new clouds, as an alignment runs it: one core is given both clouds anew
 * each time (/0), or the source alone against a target it keeps, as a scan against a map
 * (/1), and aligns them; only its "prepare" stage is timed. An alignment leaves the grids it
 * touched zero again, so the next one takes their memory as it is; a problem prepared and
 * dropped without an alignment maps them afresh, and how much of that memory the allocator
 * keeps from one such problem to the next varies between processes. */
void
BM_Prepare(benchmark::State& state)
{
  const Pair& p = pair();
  const bool source_alone = state.range(0) == 1;
  pcl_mi::RegistrationCore core;
  core.setTarget(p.target_points);
  core.setSource(p.source_points);
  core.align(Eigen::Matrix4d::Identity()); // prepares the target a source alone finds kept
  for (auto _ : state) {
    if (!source_alone)
      core.setTarget(p.target_points);
    core.setSource(p.source_points);
    const pcl_mi::AlignmentResult result = core.align(Eigen::Matrix4d::Identity());
    if (!result.error.empty())
      state.SkipWithError(result.error.c_str());
    double ms = 0.0;
    for (const pcl_mi::StageTiming& stage : result.stages)
      if (stage.name == "prepare")
        ms += stage.total_ms;
    state.SetIterationTime(ms * 1e-3);
  }
}
BENCHMARK(BM_Prepare)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseManualTime();

/** One MI evaluation (transform, voxelise, joint histogram, MI) on pyramid level N. */
void
BM_Evaluation(benchmark::State& state)
{
  pcl_mi::core::PreparedProblem& problem = prepared();
  const int level = static_cast<int>(state.range(0));
  pcl_mi::JointHistogram histogram;
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  pose(0, 3) = 6.7; // near the pair's motion
  for (auto _ : state)
    benchmark::DoNotOptimize(problem.mutualInformation(pose, histogram, level));
}
BENCHMARK(BM_Evaluation)->DenseRange(0, 2)->Unit(benchmark::kMicrosecond);

void
BM_Refinement(benchmark::State& state)
{
  pcl_mi::core::PreparedProblem& problem = prepared();
  Eigen::Matrix4d guess = Eigen::Matrix4d::Identity();
  guess(0, 3) = 6.6;
  const Eigen::Vector3d pivot = (guess * problem.source().centroid.homogeneous()).head<3>();
  const pcl_mi::core::SearchSpace space(problem.parameters(), guess, pivot);
  for (auto _ : state)
    benchmark::DoNotOptimize(pcl_mi::core::refineOptimum(problem, space, guess, 0));
}
BENCHMARK(BM_Refinement)->Unit(benchmark::kMillisecond);

void
BM_Verification(benchmark::State& state)
{
  pcl_mi::core::PreparedProblem& problem = prepared();
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  pose(0, 3) = 6.7;
  pcl_mi::JointHistogram histogram;
  problem.mutualInformation(pose, histogram);
  const pcl_mi::core::LocalPose at = problem.toLocal(pose);
  for (auto _ : state)
    benchmark::DoNotOptimize(pcl_mi::core::verifyPose(
        problem.distributions(), problem.refinementSamples(), at.rotation, at.translation,
        problem.levelResolution(0), histogram, problem.target().centroid,
        problem.targetAxes(), pcl_mi::core::SensorPlacement::kApart,
        problem.parameters().num_threads));
}
BENCHMARK(BM_Verification)->Unit(benchmark::kMillisecond);

/** The first covarianceScale() after an alignment, as getCovariance() asks for it: the
 * target's cubes and the source's samples half a cell further on, a refinement and the
 * evidence there. Against a new target each time (/0), or a kept one whose shifted cubes
 * the first call built (/1); only the call is timed. */
void
BM_CovarianceScale(benchmark::State& state)
{
  const Pair& p = pair();
  const bool kept_target = state.range(0) == 1;
  pcl_mi::RegistrationCore core;
  core.setTarget(p.target_points);
  core.setSource(p.source_points);
  core.align(Eigen::Matrix4d::Identity());
  core.covarianceScale();
  for (auto _ : state) {
    if (!kept_target)
      core.setTarget(p.target_points);
    core.setSource(p.source_points);
    core.align(Eigen::Matrix4d::Identity());
    const auto start = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(core.covarianceScale());
    state.SetIterationTime(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
}
BENCHMARK(BM_CovarianceScale)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseManualTime();

/** Hands both clouds of \a p to \a reg as PCL clouds and aligns them. */
void
alignPclPair(pcl::MutualInformationRegistration<pcl::PointXYZI>& reg,
             const Pair& p,
             Cloud& output,
             benchmark::State& state)
{
  reg.setInputSource(p.source);
  reg.setInputTarget(p.target);
  reg.align(output);
  if (!reg.hasConverged())
    state.SkipWithError("not converged");
}

/** The whole alignment through the PCL adapter, both clouds handed over as PCL clouds. */
void
BM_AlignPcl(benchmark::State& state)
{
  const Pair& p = pair();
  Cloud output;
  for (auto _ : state) {
    pcl::MutualInformationRegistration<pcl::PointXYZI> reg;
    alignPclPair(reg, p, output, state);
  }
}
BENCHMARK(BM_AlignPcl)->Unit(benchmark::kMillisecond)->UseRealTime();

/** The engine alone (pcl_mi::RegistrationCore), a new one per alignment, from point lists. */
void
BM_AlignCoreFresh(benchmark::State& state)
{
  const Pair& p = pair();
  for (auto _ : state) {
    pcl_mi::RegistrationCore core;
    core.setTarget(p.target_points);
    core.setSource(p.source_points);
    if (!core.align(Eigen::Matrix4d::Identity()).converged)
      state.SkipWithError("not converged");
  }
}
BENCHMARK(BM_AlignCoreFresh)->Unit(benchmark::kMillisecond)->UseRealTime();

/** One object for a sequence of pairs: both clouds are set anew before every alignment. */
void
BM_AlignReusedObject(benchmark::State& state)
{
  const Pair& p = pair();
  Cloud output;
  pcl::MutualInformationRegistration<pcl::PointXYZI> reg;
  for (auto _ : state)
    alignPclPair(reg, p, output, state);
}
BENCHMARK(BM_AlignReusedObject)->Unit(benchmark::kMillisecond)->UseRealTime();

/** Scan to map: the target is set once and reused; only the source changes. */
void
BM_AlignReusedTarget(benchmark::State& state)
{
  const Pair& p = pair();
  pcl_mi::RegistrationCore core;
  core.setTarget(p.target_points);
  core.setSource(p.source_points);
  core.align(Eigen::Matrix4d::Identity()); // prepares the target
  for (auto _ : state) {
    core.setSource(p.source_points);
    if (!core.align(Eigen::Matrix4d::Identity()).converged)
      state.SkipWithError("not converged");
  }
}
BENCHMARK(BM_AlignReusedTarget)->Unit(benchmark::kMillisecond)->UseRealTime();

} // namespace

BENCHMARK_MAIN();
