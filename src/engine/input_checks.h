/*
 * pcl_mi: the checks that decide whether two clouds, a resolution and a guess can give a
 * meaningful alignment at all. The engine runs them for every caller (the PCL adapter,
 * the apps, direct users of RegistrationCore), so no path can skip them.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "features/local_cloud.h"

#include <Eigen/Core>

#include <string>

namespace pcl_mi {
namespace core {

/** Fewest usable points a cloud needs: MI over fewer occupied voxels says nothing. */
constexpr std::size_t kMinimumPoints = 3;

/** Spread (standard deviation along a principal axis), in voxels, that at least two of a
 * cloud's principal axes must reach: a uniform spread over two voxels has about 0.58. A
 * point, a line, or a cloud smaller than the voxels has no structure for MI to align. */
constexpr double kMinimumSpreadVoxels = 0.5;

/** \brief Empty when \a m is a rigid transformation (rotation with determinant +1 up to
 * \a tolerance per entry of R^T R - I, bottom row 0 0 0 1); otherwise why not. */
std::string
rigidTransformError(const Eigen::Matrix4d& m, double tolerance = 1e-4);

/** \brief The bulk of \a points: the 5-95 % range along x, y and z of an even sample of
 * 4096 of them, so far outliers do not count; false when the sample holds no finite point
 * (counting points at exactly (0, 0, 0) only unless \a skip_origin). */
bool
bulkExtent(const PointView& points, bool skip_origin, Eigen::Vector3d& extent);

/** \brief Empty when a grid at \a resolution can cover the bulk of \a points (the 5-95 %
 * range of a sample on every axis, so far outliers do not count); otherwise a message that
 * names the resolution as too fine and the coarsest one that would fit. Run before the
 * outlier removal, whose gap follows the resolution. */
std::string
resolutionError(const PointView& points, double resolution, const char* which);

/** \brief Empty when \a cloud has structure at \a resolution: at least two principal axes
 * spread kMinimumSpreadVoxels voxels or more; otherwise whether its points coincide, lie
 * on a line, or all fit in about one voxel. */
std::string
structureError(const LocalCloud& cloud, double resolution, const char* which);

} // namespace core
} // namespace pcl_mi
