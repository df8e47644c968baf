/*
 * pcl_mi: cloud preparation: finite points, far-outlier removal, the local frame.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "util/bounding_box.h"

#include <pcl_mi/types.h>

#include <Eigen/Core>

#include <cstddef>

namespace pcl_mi {
namespace core {

/** Gap, in voxels, that separates far outliers from the bulk of a cloud. */
constexpr double kOutlierGapVoxels = 64.0;

/** \brief A cloud in its own local frame: point = centroid + local point. */
struct LocalCloud {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero(); ///< in the input frame, double
  PointList points;                                   ///< finite inliers, local frame
  std::size_t non_finite = 0;                         ///< dropped: NaN/Inf coordinates
  std::size_t no_return = 0;                          ///< dropped: exactly (0, 0, 0)
  std::size_t outliers = 0;                           ///< dropped: far outliers
  double rms_radius = 0.0; ///< root mean square distance of the kept points from the centroid
  /** Covariance of the kept points (local frame), as they are stored. */
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  /** Degrees of azimuth about the input frame's z axis in which the kept points lie (see
   * azimuthCoverageDegrees()). */
  double azimuth_coverage_deg = 0.0;
  /** Bounding box of the kept points (local frame), found once for every grid and summary
   * built from them; zero where none are kept. */
  Box box;
};

/** \brief Azimuth coverage (degrees) below which a cloud has a narrow field of view: a
 * spinning LiDAR's scan covers 360, a solid-state sensor's its field of view. */
constexpr double kNarrowViewDegrees = 180.0;

/** \brief Degrees of azimuth, about the z axis through the origin of their frame, that
 * \a points cover: the sum of the 5-degree sectors
 * holding at least 5 % of an even share of the points. 360 for a spinning LiDAR's scan in its
 * own frame; about the field of view for a solid-state sensor's. A few thousand points
 * spread evenly through the cloud are looked at, so stray returns do not count. */
double
azimuthCoverageDegrees(const PointList& points);

/** \brief Drops non-finite points and points at exactly (0, 0, 0) (the no-return marker of
 * many drivers), then far outliers, and re-centres the rest on their centroid (computed in
 * double, so coordinates of 1e6 m keep their sub-millimetre detail relative to each other).
 *
 * Far outliers: along each axis the points fall into groups wherever two consecutive
 * coordinates are at least \a outlier_gap apart; a point outside the largest group of any
 * axis is dropped (as is one more than 2048 gaps from the axis's median). The input is read
 * on up to two of \a threads threads; the result is the same on any number. */
LocalCloud
makeLocalCloud(const PointView& points, double outlier_gap, int threads = 1);

/** \brief makeLocalCloud() into \a cloud, whose point storage it reuses where that is at
 * most twice the input's size: an object given new clouds for every pair then keeps writing
 * to memory it has touched, instead of to fresh pages while the old cloud still holds its
 * own. Everything else in \a cloud is replaced. */
void
makeLocalCloud(const PointView& points, double outlier_gap, int threads, LocalCloud& cloud);

} // namespace core
} // namespace pcl_mi
