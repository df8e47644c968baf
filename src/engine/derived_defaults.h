/*
 * pcl_mi: the defaults that follow the data. A resolution of 0 is derived from the target's
 * extent, and translation steps given in voxels follow the resolution in use, so that one
 * default configuration fits a street, a room and a handheld scan.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_mi/parameters.h>
#include <pcl_mi/types.h>

namespace pcl_mi {
namespace core {

/** Voxels that the scene's extent spans at the derived resolution: about what 1 m voxels
 * give on a street scan (docs/method.md, "Defaults derived from the data"). */
constexpr double kExtentVoxels = 32.0;

/** \brief The resolution derived from \a points: the power of two nearest (in log scale) to
 * the scene's extent / kExtentVoxels, where the extent is the geometric mean of the two
 * largest 5-95 % ranges along x, y and z (the largest alone for points on a line). The
 * engine doubles it while the points that survive the outlier rule do not fit a grid
 * (PreparedProblem::prepare()). 0 when the usable points (finite, not at the
 * origin) of the sample all coincide or there are none. */
double
deriveResolution(const PointView& points);

/** \brief \a requested with every derived value made concrete: a resolution of 0 becomes
 * \a derived_resolution, and translation steps given in voxels (negative) become clouds'
 * units. With a zero \a derived_resolution (no target yet) a resolution of 0 stays 0. */
Parameters
resolveParameters(const Parameters& requested, double derived_resolution);

} // namespace core
} // namespace pcl_mi
