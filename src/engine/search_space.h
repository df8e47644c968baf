/*
 * pcl_mi: the search vector of one alignment: the parameters of [tx, ty, tz, roll, pitch,
 * yaw] with a non-zero simplex step, relative to the guess, and the pose each stands for.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "search/coarse_to_fine.h"

#include <pcl_mi/parameters.h>

#include <Eigen/Core>

#include <optional>
#include <vector>

namespace pcl_mi {
namespace core {

class SearchSpace {
public:
  /** \brief The space around \a guess whose rotations turn the guessed source about
   * \a pivot; only parameters with a non-zero step are searched (a zero step pins one). */
  SearchSpace(const Parameters& parameters, const Eigen::Matrix4d& guess, const Eigen::Vector3d& pivot);

  /** \brief The same, with the translations and rotations taken along the columns of
   * \a axes (a rotation, target frame) instead of the target's axes: yaw turns about the
   * third column, and tz moves along it. */
  SearchSpace(const Parameters& parameters,
              const Eigen::Matrix4d& guess,
              const Eigen::Vector3d& pivot,
              const Eigen::Matrix3d& axes);

  /** \brief Source-to-target transformation of the search vector \a x. */
  Eigen::Matrix4d
  pose(const Eigen::VectorXd& x) const;

  /** \brief The search vector of \a pose: pose(vector(pose)) is \a pose where the pinned
   * parameters of its move from the guess are zero. */
  Eigen::VectorXd
  vector(const Eigen::Matrix4d& pose) const;

  /** \brief Where parameter 0..5 sits in the search vector; -1 when pinned. */
  Eigen::Index
  index(int parameter) const;

  /** \brief Which of the six parameters are searched. */
  Eigen::Matrix<bool, 6, 1>
  searched() const;

  /** \brief Options for searchCoarseToFine() with the steps, tolerances and starts of
   * \a parameters; every value but first_level, position_starts and max_iterations. */
  CoarseToFineOptions
  searchOptions(const Parameters& parameters) const;

private:
  std::vector<int> active_; // the searched parameters, in order
  Eigen::Matrix4d guess_;
  Eigen::Vector3d pivot_;
  std::optional<Eigen::Matrix3d> axes_; // none: the target's axes
};

} // namespace core
} // namespace pcl_mi
