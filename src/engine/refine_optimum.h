/*
 * pcl_mi: the refinement of the MI optimum against the target's distributions, and the
 * test that keeps it inside the MI basin.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "engine/prepared_problem.h"
#include "engine/search_space.h"
#include "refine/refinement.h"

#include <Eigen/Core>

namespace pcl_mi {
namespace core {

/** \brief A refined pose and whether it stays inside the MI basin. */
struct RefinedOptimum {
  Eigen::Matrix4d transformation = Eigen::Matrix4d::Identity(); ///< source to target
  int iterations = 0;    ///< Gauss-Newton iterations, summed over the stages
  /** Within (1 + coarser_stages) searched voxels and 5 * (1 + coarser_stages) degrees of
   * the MI optimum. */
  bool accepted = false;
};

/** \brief The options a result's refinement runs with: \a parameters' iteration cap and
 * threads, and \a active, the parameters the search moves. A refinement that must end where
 * the result's did (covarianceScale()'s) takes the same. */
RefinementOptions
refinementOptions(const Parameters& parameters, const Eigen::Matrix<bool, 6, 1>& active);

/** \brief The coarser stages a result of \a problem is refined with:
 * RefinementParameters::narrow_view_stages for a narrow view, none otherwise. */
int
coarserRefinementStages(const PreparedProblem& problem);

/** \brief Refines \a optimum (source to target, input frames) in the parameters \a space
 * searches: \a coarser_stages stages on cubes 2^k times the refinement's (k = coarser_stages
 * down to 1), then the refinement's own. */
RefinedOptimum
refineOptimum(PreparedProblem& problem,
              const SearchSpace& space,
              const Eigen::Matrix4d& optimum,
              int coarser_stages);

} // namespace core
} // namespace pcl_mi
