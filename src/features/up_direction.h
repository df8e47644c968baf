/*
 * pcl_mi: a cloud's up direction, read from its horizontal surfaces (ground, floor,
 * ceiling), for sensors that are carried tilted.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "features/source_samples.h"

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include <cstdint>
#include <optional>
#include <vector>

namespace pcl_mi {
namespace core {

/** \brief Fewest points that give a cell a normal. */
constexpr std::uint32_t kUpMinimumCellPoints = 5;

/** \brief The normal shared by the most planar cells of \a cells (a makeSourceSamples()
 * summary with covariances; at most 8192 of them, evenly spread, are looked at) among the
 * normals within 75 degrees of the frame's +z, refined
 * as the principal direction of those within 10 degrees of it; pointing to +z. Nothing
 * where fewer than 20 planar cells lie in that cone.
 *
 * A scan's largest family of parallel planes within that cone is its ground, or its floor
 * and ceiling, for a sensor tilted by up to about 70 degrees. Each wall orientation is a
 * family of its own, which a tilt of more than 15 degrees brings into the cone, but the
 * normal counts once per cell, so surfaces weigh by their area, not by how densely the
 * sensor sampled them, and the ground outweighs each. The cells' normals are found on up to
 * \a threads threads, with the same result on any number. */
std::optional<Eigen::Vector3d>
estimateUpDirection(const SourceSamples& cells, int threads = 1);

/** \brief The same from principal axes found elsewhere: a caller that decomposes the cells'
 * covariances anyway hands over each one with look() and reads estimate(). It must hand
 * over every cell that wanted() names (all have kUpMinimumCellPoints or more points), in
 * their order; the result is then estimateUpDirection()'s to the bit. */
class UpDirectionFromAxes {
public:
  explicit UpDirectionFromAxes(const SourceSamples& cells);

  /** \brief True where estimateUpDirection() looks at cell \a i. */
  bool
  wanted(std::size_t i) const;

  /** \brief Cell \a i's principal axes (ascending), as computeDirect() gives them on its
   * covariance in double. */
  void
  look(std::size_t i, const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>& axes);

  std::optional<Eigen::Vector3d>
  estimate() const;

private:
  const SourceSamples& cells_;
  std::size_t stride_;
  std::vector<Eigen::Vector3d> normals_;
};

} // namespace core
} // namespace pcl_mi
