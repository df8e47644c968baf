/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/refine_optimum.h"

#include "refine/refinement.h"

#include <Eigen/Geometry>

#include <cmath>

namespace pcl_mi {
namespace core {

namespace {

/** A refinement that moves the pose further than this (times the voxel size of the finest
 * level the MI search ran on, and degrees) left the MI basin and is discarded. The MI
 * optimum is quantised by that level's voxels, so it can be up to about one voxel off.
 * Each coarser stage, whose cubes reach twice as far, adds as much again. */
constexpr double kRefinementMaxShift = 1.0;
constexpr double kRefinementMaxTurnDeg = 5.0;

} // namespace

RefinementOptions
refinementOptions(const Parameters& parameters, const Eigen::Matrix<bool, 6, 1>& active)
{
  RefinementOptions options;
  options.max_iterations = parameters.refinement.max_iterations;
  options.num_threads = parameters.num_threads;
  options.active = active;
  // Its two lengths are in metres; everything else it uses follows the resolution.
  options.translation_epsilon *= parameters.units_per_metre;
  options.lever_arm *= parameters.units_per_metre;
  return options;
}

int
coarserRefinementStages(const PreparedProblem& problem)
{
  return problem.narrowView() ? problem.parameters().refinement.narrow_view_stages : 0;
}

RefinedOptimum
refineOptimum(PreparedProblem& problem,
              const SearchSpace& space,
              const Eigen::Matrix4d& optimum,
              int coarser_stages)
{
  const Parameters& p = problem.parameters();
  const LocalPose start = problem.toLocal(optimum);
  const RefinementOptions options = refinementOptions(p, space.searched());
  RefinedOptimum result;
  RefinementResult refined;
  refined.rotation = start.rotation;
  refined.translation = start.translation;
  for (int stage = coarser_stages; stage >= 0; --stage) {
    refined = refineToDistributions(problem.distributions(stage), problem.refinementSamples(stage),
                                    refined.rotation, refined.translation, options);
    result.iterations += refined.iterations;
  }

  const double reach = 1.0 + coarser_stages;
  const double turn_deg =
      Eigen::AngleAxisd(refined.rotation * start.rotation.transpose()).angle() * 180.0 / M_PI;
  const double searched_resolution = problem.levelResolution(problem.firstSearchedLevel());
  result.accepted = (refined.translation - start.translation).norm() <=
                        reach * kRefinementMaxShift * searched_resolution &&
                    turn_deg <= reach * kRefinementMaxTurnDeg;
  if (result.accepted)
    result.transformation = problem.fromLocal({refined.rotation, refined.translation});
  return result;
}

} // namespace core
} // namespace pcl_mi
