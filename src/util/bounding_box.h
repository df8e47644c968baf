/*
 * pcl_mi: the axis-aligned bounding box of a set of positions.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cstddef>

namespace pcl_mi {
namespace core {

/** \brief Bounding box of the \a count > 0 positions position_of(0 .. count - 1). Kept in
 * six scalars: with Eigen vectors the compiler spilled one bound to the stack and every
 * point waited on the store. */
template <typename PositionOf>
void
boundingBox(std::size_t count, const PositionOf& position_of, Eigen::Vector3f& min, Eigen::Vector3f& max)
{
  const Eigen::Vector3f& first = position_of(0);
  float x0 = first.x(), y0 = first.y(), z0 = first.z();
  float x1 = x0, y1 = y0, z1 = z0;
  for (std::size_t i = 1; i < count; ++i) {
    const Eigen::Vector3f& p = position_of(i);
    x0 = std::min(x0, p.x());
    y0 = std::min(y0, p.y());
    z0 = std::min(z0, p.z());
    x1 = std::max(x1, p.x());
    y1 = std::max(y1, p.y());
    z1 = std::max(z1, p.z());
  }
  min = Eigen::Vector3f(x0, y0, z0);
  max = Eigen::Vector3f(x1, y1, z1);
}

} // namespace core
} // namespace pcl_mi
