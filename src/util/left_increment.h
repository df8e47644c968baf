/*
 * pcl_mi: a small rigid motion applied on the left of a pose, the increment both the
 * refinement's steps and the verification's probes take, and the cross-product matrix that
 * carries such increments from one frame to another.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace pcl_mi {
namespace core {

/** \brief The cross-product matrix [\a v]x, with [v]x u = v x u for every u. */
template <typename Scalar>
inline Eigen::Matrix<Scalar, 3, 3>
crossMatrix(const Eigen::Matrix<Scalar, 3, 1>& v)
{
  Eigen::Matrix<Scalar, 3, 3> m;
  m << Scalar(0), -v.z(), v.y(), //
      v.z(), Scalar(0), -v.x(),  //
      -v.y(), v.x(), Scalar(0);
  return m;
}

/** \brief The map of a left increment [delta, omega] about one point onto the same motion as
 * an increment about the point \a offset from it: [delta + omega x offset, omega]. It carries
 * an increment's covariance C to M C M^T. */
inline Eigen::Matrix<double, 6, 6>
incrementMovedBy(const Eigen::Vector3d& offset)
{
  Eigen::Matrix<double, 6, 6> m = Eigen::Matrix<double, 6, 6>::Identity();
  m.topRightCorner<3, 3>() = -crossMatrix(offset);
  return m;
}

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
