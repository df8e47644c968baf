/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/pose.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace pcl_mi {
namespace core {

Eigen::Matrix3d
rotationFromRollPitchYaw(double roll, double pitch, double yaw)
{
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Vector3d
rollPitchYawFromRotation(const Eigen::Matrix3d& r)
{
  return {std::atan2(r(2, 1), r(2, 2)), std::asin(std::clamp(-r(2, 0), -1.0, 1.0)),
          std::atan2(r(1, 0), r(0, 0))};
}

Eigen::Matrix4d
transformFromParameters(const Vector6d& x,
                        const Eigen::Matrix4d& guess,
                        const Eigen::Vector3d& pivot)
{
  const Eigen::Matrix3d r = rotationFromRollPitchYaw(x[3], x[4], x[5]);
  Eigen::Matrix4d delta = Eigen::Matrix4d::Identity();
  delta.topLeftCorner<3, 3>() = r;
  delta.topRightCorner<3, 1>() = x.head<3>() + pivot - r * pivot;
  return delta * guess;
}

} // namespace core
} // namespace pcl_mi
