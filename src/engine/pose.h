/*
 * pcl_mi: the six search parameters and the rigid transformations they stand for.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>

namespace pcl_mi {
namespace core {

using Vector6d = Eigen::Matrix<double, 6, 1>;

/** \brief R = Rz(yaw) * Ry(pitch) * Rx(roll). */
Eigen::Matrix3d
rotationFromRollPitchYaw(double roll, double pitch, double yaw);

/** \brief (roll, pitch, yaw) of \a r, the inverse of rotationFromRollPitchYaw() for pitch
 * within +-90 degrees. */
Eigen::Vector3d
rollPitchYawFromRotation(const Eigen::Matrix3d& r);

/** \brief Source-to-target transformation for search parameters
 * x = [tx, ty, tz, roll, pitch, yaw] relative to \a guess:
 *
 *     T(x) = Translate(t) * Translate(pivot) * R(roll, pitch, yaw) * Translate(-pivot) * guess
 *
 * The rotation turns the guessed source about \a pivot (the source centroid placed by the
 * guess, or, for a narrow field of view, its sensor), so rotation and translation
 * parameters barely interact and a far-from-origin scan is not swung around the world
 * origin. Translation and yaw are in the target frame,
 * the frame in which wheeled robots move mostly in x, y and yaw. */
Eigen::Matrix4d
transformFromParameters(const Vector6d& x,
                        const Eigen::Matrix4d& guess,
                        const Eigen::Vector3d& pivot);

} // namespace core
} // namespace pcl_mi
