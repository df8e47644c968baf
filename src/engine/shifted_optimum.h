/*
 * pcl_mi: the look for a higher optimum a few voxels across, at the result's rotation.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "engine/prepared_problem.h"

#include <Eigen/Core>

#include <optional>

namespace pcl_mi {
namespace core {

/** \brief An optimum of the translation at a kept rotation. */
struct ShiftedOptimum {
  Eigen::Matrix4d pose;
  bool converged = false; ///< its search met the tolerance
  /** How far its MI leads the highest of the other optima found more than a voxel from it,
   * as a share of its own MI: negative where one of them scores higher, 1 where none was
   * found. */
  double lead = 0.0;
};

/** \brief What the searches across found. */
struct ShiftedOptima {
  /** The lead (ShiftedOptimum::lead) of the optimum of the search from the pose. */
  double lead = 0.0;
  /** The best optimum of the starts in the eight directions, where it lies more than a voxel
   * from that of the search from the pose and has a higher MI. */
  std::optional<ShiftedOptimum> higher;
};

/** \brief Translation-only Nelder-Mead searches on the finest grid, the rotation of \a pose
 * kept: one from \a pose, one from each of kShiftedStarts starts 2, 4 and 6 voxels away in
 * eight directions square to \a up (input frame), and one from each of six starts 8, 10 and
 * 12 voxels either way along the axis of view (the source's centroid seen from its sensor,
 * square to \a up).
 *
 * A narrow view of a facade with a row of windows or pillars has optima a bay apart whose
 * rotations agree: the coarser grids the search ranks on cannot tell them apart, the
 * finest grid can, but its optima are too narrow for a simplex to walk from one to the next.
 * Along a road or a corridor ahead, a narrow view has optima a whole motion apart. Where
 * none of them comes close, the result is the one place nearby where the clouds agree: the
 * lead is evidence for the verdict (verify/verification.h). Only the eight directions'
 * optima are candidates for ShiftedOptima::higher; those along the axis count in the leads.
 * \a evaluations counts the MI evaluations. With \a num_threads of 2 or more the searches
 * run on two evaluators (runOnTwoEvaluators()); the result does not depend on the threads. */
ShiftedOptima
shiftedOptima(PreparedProblem& problem,
              const Eigen::Matrix4d& pose,
              const Eigen::Vector3d& up,
              int num_threads,
              int& evaluations);

/** \brief Starts of shiftedOptima() in the eight directions (three distances each), which
 * come first after the pose; the six along the axis of view follow them. */
constexpr int kShiftedStarts = 24;

} // namespace core
} // namespace pcl_mi
