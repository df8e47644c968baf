/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/shifted_optimum.h"

#include "search/nelder_mead.h"
#include "search/two_evaluators.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace pcl_mi {
namespace core {

namespace {

/** Spacing of the starts, in voxels of the finest grid: a bay of a facade is a few. */
constexpr double kShiftedStartVoxels = 2.0;

/** The starts along the axis of view lie this many spacings away, either way: beyond the
 * reach of the starts in eight directions (three spacings), within a first simplex's
 * translation steps (16 voxels). */
constexpr int kAxisStartFirst = 4;
constexpr int kAxisStartLast = 6;

/** Iteration cap of each search: from a start a bay away it has a voxel or two to go. A
 * search that needs more has not found a clear optimum, and its result says so
 * (search_converged false). */
constexpr int kShiftedIterations = 15;

/** Tolerance of each search, in voxels: the refinement takes the result on from there. */
constexpr double kShiftedToleranceVoxels = 0.1;

/** The lead of \a found[j] over the optima more than \a voxel from it (values are minus the
 * MI). */
double
leadOf(const std::vector<NelderMeadResult>& found, std::size_t j, double voxel)
{
  const double mi = -found[j].value;
  if (!(mi > 0.0))
    return -1.0;
  double other = -1.0; // none yet
  for (std::size_t i = 0; i < found.size(); ++i)
    if ((found[i].x - found[j].x).norm() > voxel)
      other = std::max(other, -found[i].value);
  return other < 0.0 ? 1.0 : (mi - other) / mi;
}

} // namespace

ShiftedOptima
shiftedOptima(PreparedProblem& problem,
              const Eigen::Matrix4d& pose,
              const Eigen::Vector3d& up,
              int num_threads,
              int& evaluations)
{
  const double voxel = problem.levelResolution(0);
  // Two unit vectors square to up, and to each other.
  const Eigen::Vector3d u = up.unitOrthogonal();
  const Eigen::Vector3d v = up.normalized().cross(u);
  const Eigen::Vector3d at = pose.topRightCorner<3, 1>();
  std::vector<Eigen::Vector3d> starts{at};
  for (int ring = 1; ring <= kShiftedStarts / 8; ++ring)
    for (int k = 0; k < 8; ++k) {
      const double angle = k * M_PI / 4.0;
      const Eigen::Vector3d direction = std::cos(angle) * u + std::sin(angle) * v;
      starts.push_back(at + ring * kShiftedStartVoxels * voxel * direction);
    }
  // The pose and the eight directions' starts: the searches whose optima may be taken.
  const std::size_t takeable = starts.size();
  // The axis of view, from the sensor (the source frame's origin) to the source's centroid,
  // square to up: along a road or a corridor ahead a narrow view sees nearly the same
  // surfaces a whole motion further on.
  const Eigen::Vector3d unit_up = up.normalized();
  Eigen::Vector3d axis = pose.topLeftCorner<3, 3>() * problem.source().centroid;
  axis -= axis.dot(unit_up) * unit_up;
  if (axis.norm() > 0.0) {
    axis.normalize();
    for (int ring = kAxisStartFirst; ring <= kAxisStartLast; ++ring)
      for (const double sign : {1.0, -1.0})
        starts.push_back(at + sign * ring * kShiftedStartVoxels * voxel * axis);
  }

  NelderMeadOptions options;
  options.max_iterations = kShiftedIterations;
  options.tolerance = Eigen::Vector3d::Constant(kShiftedToleranceVoxels * voxel);
  const Eigen::VectorXd steps = Eigen::Vector3d::Constant(voxel);
  std::vector<NelderMeadRun> runs;
  for (const Eigen::Vector3d& start : starts)
    runs.emplace_back(start, steps, options);
  JointHistogram histograms[2]; // one per evaluator
  const SlotCost cost = [&](int slot, const Eigen::VectorXd& t) {
    Eigen::Matrix4d shifted = pose;
    shifted.topRightCorner<3, 1>() = t;
    return -problem.mutualInformation(shifted, histograms[slot], 0, slot);
  };
  // The searches are independent, so the results do not depend on the threads.
  runOnTwoEvaluators(runs, cost, num_threads);
  std::vector<NelderMeadResult> found;
  for (const NelderMeadRun& run : runs)
    found.push_back(run.result());

  // Only the eight directions' optima may be taken; those along the axis count against the
  // lead alone: taken, they turned right results from far-off guesses wrong
  // (docs/benchmarks.md, "Shifted optima along the axis of view").
  std::size_t best = 0;
  for (std::size_t i = 0; i < found.size(); ++i) {
    evaluations += found[i].evaluations;
    if (i > 0 && i < takeable && (found[i].x - found[0].x).norm() > voxel &&
        (best == 0 || found[i].value < found[best].value))
      best = i;
  }
  // Values are minus the MI. The caller judges the optimum again after its refinement, by
  // the normalised MI and the shared surface, as a runner-up: a margin here only lost
  // right results (docs/benchmarks.md).
  ShiftedOptima optima;
  optima.lead = leadOf(found, 0, voxel);
  if (best == 0 || !(found[best].value < found[0].value))
    return optima;
  ShiftedOptimum shifted{pose, found[best].converged, leadOf(found, best, voxel)};
  shifted.pose.topRightCorner<3, 1>() = found[best].x;
  optima.higher = shifted;
  return optima;
}

} // namespace core
} // namespace pcl_mi
