/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/search_space.h"

#include "engine/pose.h"

#include <Eigen/LU>

#include <algorithm>

namespace pcl_mi {
namespace core {

SearchSpace::SearchSpace(const Parameters& parameters,
                         const Eigen::Matrix4d& guess,
                         const Eigen::Vector3d& pivot)
: guess_(guess), pivot_(pivot)
{
  const Eigen::Matrix<bool, 6, 1> searched = parameters.search.searched();
  for (int i = 0; i < 6; ++i)
    if (searched[i])
      active_.push_back(i);
}

SearchSpace::SearchSpace(const Parameters& parameters,
                         const Eigen::Matrix4d& guess,
                         const Eigen::Vector3d& pivot,
                         const Eigen::Matrix3d& axes)
: SearchSpace(parameters, guess, pivot)
{
  axes_ = axes;
}

Eigen::Matrix4d
SearchSpace::pose(const Eigen::VectorXd& x) const
{
  Vector6d full = Vector6d::Zero();
  for (std::size_t i = 0; i < active_.size(); ++i)
    full[active_[i]] = x[static_cast<Eigen::Index>(i)];
  if (!axes_)
    return transformFromParameters(full, guess_, pivot_);
  // transformFromParameters() with its translation and rotation expressed in the axes.
  const Eigen::Matrix3d& a = *axes_;
  const Eigen::Matrix3d r = a * rotationFromRollPitchYaw(full[3], full[4], full[5]) * a.transpose();
  Eigen::Matrix4d move = Eigen::Matrix4d::Identity();
  move.topLeftCorner<3, 3>() = r;
  move.topRightCorner<3, 1>() = a * full.head<3>() + pivot_ - r * pivot_;
  return move * guess_;
}

Eigen::VectorXd
SearchSpace::vector(const Eigen::Matrix4d& pose) const
{
  // pose() inverted: the move from the guess, its rotation and translation in the axes.
  const Eigen::Matrix4d move = pose * guess_.inverse();
  const Eigen::Matrix3d a = axes_ ? *axes_ : Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d r = move.topLeftCorner<3, 3>();
  Vector6d full;
  full.head<3>() = a.transpose() * (move.topRightCorner<3, 1>() - pivot_ + r * pivot_);
  full.tail<3>() = rollPitchYawFromRotation(a.transpose() * r * a);
  Eigen::VectorXd x(static_cast<Eigen::Index>(active_.size()));
  for (std::size_t i = 0; i < active_.size(); ++i)
    x[static_cast<Eigen::Index>(i)] = full[active_[i]];
  return x;
}

Eigen::Index
SearchSpace::index(int parameter) const
{
  const auto it = std::find(active_.begin(), active_.end(), parameter);
  return it == active_.end() ? -1 : static_cast<Eigen::Index>(it - active_.begin());
}

Eigen::Matrix<bool, 6, 1>
SearchSpace::searched() const
{
  Eigen::Matrix<bool, 6, 1> searched = Eigen::Matrix<bool, 6, 1>::Constant(false);
  for (const int i : active_)
    searched[i] = true;
  return searched;
}

CoarseToFineOptions
SearchSpace::searchOptions(const Parameters& parameters) const
{
  const SearchParameters& s = parameters.search;
  const Eigen::Index n = static_cast<Eigen::Index>(active_.size());
  CoarseToFineOptions o;
  o.steps.resize(n);
  o.tolerance.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const int parameter = active_[static_cast<std::size_t>(i)];
    o.steps[i] = s.simplex_steps[parameter];
    o.tolerance[i] =
        parameter < 3 ? parameters.effectiveTranslationTolerance() : s.rotation_tolerance;
    o.translational.push_back(parameter < 3);
  }
  o.x_index = index(0);
  o.y_index = index(1);
  o.roll_index = index(3);
  o.pitch_index = index(4);
  o.yaw_index = index(5);
  o.heading_starts = s.heading_starts;
  o.symmetric_start = s.symmetric_start;
  o.restarts = s.restarts;
  o.restart_scale = s.restart_scale;
  o.num_threads = parameters.num_threads;
  return o;
}

} // namespace core
} // namespace pcl_mi
