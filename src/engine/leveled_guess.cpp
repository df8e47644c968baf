/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/leveled_guess.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace pcl_mi {
namespace core {

bool
levelingApplies(const Parameters& parameters)
{
  return parameters.search.leveling && parameters.search.searched().all();
}

bool
apartBeyondLeveling(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
  return std::acos(std::clamp(a.dot(b), -1.0, 1.0)) > kLevelingDegrees * M_PI / 180.0;
}

bool
guessKeepsUp(const std::optional<Eigen::Vector3d>& source_up,
             const std::optional<Eigen::Vector3d>& target_up,
             const Eigen::Matrix4d& guess)
{
  return source_up && target_up &&
         !apartBeyondLeveling(guess.topLeftCorner<3, 3>() * *source_up, *target_up);
}

Eigen::Matrix3d
levelAxes(const Eigen::Vector3d& up)
{
  Eigen::Vector3d x = Eigen::Vector3d::UnitX() - up.x() * up;
  if (x.norm() < 0.5)
    x = Eigen::Vector3d::UnitY() - up.y() * up;
  x.normalize();
  Eigen::Matrix3d axes;
  axes.col(0) = x;
  axes.col(1) = up.cross(x);
  axes.col(2) = up;
  return axes;
}

std::optional<Leveling>
levelGuess(const std::optional<Eigen::Vector3d>& source_up,
           const std::optional<Eigen::Vector3d>& target_up,
           const Eigen::Matrix4d& guess,
           const Eigen::Vector3d& pivot)
{
  if (!source_up || !target_up)
    return std::nullopt;
  const Eigen::Vector3d& up = *target_up;
  Leveling leveling;
  if (guessKeepsUp(source_up, target_up, guess)) {
    // Agreeing ups need no turn, but a sensor mounted tilted still moves along the ground
    // and turns about up, not along and about its own axes.
    if (!apartBeyondLeveling(up, Eigen::Vector3d::UnitZ()))
      return std::nullopt;
    leveling.guess = guess;
    leveling.axes = levelAxes(up);
    return leveling;
  }
  Eigen::Matrix4d turn = Eigen::Matrix4d::Identity();
  const Eigen::Vector3d moved = guess.topLeftCorner<3, 3>() * *source_up;
  turn.topLeftCorner<3, 3>() = Eigen::Quaterniond::FromTwoVectors(moved, up).toRotationMatrix();
  turn.topRightCorner<3, 1>() = pivot - turn.topLeftCorner<3, 3>() * pivot;
  leveling.guess = turn * guess;
  leveling.axes = levelAxes(up);
  return leveling;
}

} // namespace core
} // namespace pcl_mi
