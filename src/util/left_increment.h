/*
 * pcl_mi: a small rigid motion applied on the left of a pose, the increment both the
 * refinement's steps and the verification's probes take.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace pcl_mi {
namespace core {

/** \brief Moves the pose (\a rotation, \a translation) by the left increment [\a omega,
 * \a delta]: rotation' = exp(omega) rotation, translation' = exp(omega) translation + delta,
 * with exp(omega) the turn by |omega| about omega. */
inline void
applyLeftIncrement(const Eigen::Vector3d& omega,
                   const Eigen::Vector3d& delta,
                   Eigen::Matrix3d& rotation,
                   Eigen::Vector3d& translation)
{
  const double angle = omega.norm();
  const Eigen::Matrix3d turn = angle > 0.0
                                   ? Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix()
                                   : Eigen::Matrix3d::Identity();
  rotation = turn * rotation;
  translation = turn * translation + delta;
}

} // namespace core
} // namespace pcl_mi
