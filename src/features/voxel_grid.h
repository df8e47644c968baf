/*
 * pcl_mi: cloud preparation (finite points, far-outlier removal, local frame) and the
 * target's voxel feature grid.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "features/feature_binning.h"
#include "util/bounding_box.h"

#include <pcl_mi/types.h>

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace pcl_mi {
namespace core {

/** Largest dense grid accepted (cells). Bounds memory to 16 bytes per cell for a backend's
 * source accumulators plus 1 byte per cell for the target bins (~285 MB at the cap), and
 * 4 bytes per row of cells for the target's row index. */
constexpr std::size_t kMaxGridCells = std::size_t{1} << 24;

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

/** \brief Axis-aligned voxel grid: cell (ix, iy, iz) covers
 * origin + resolution * [ix, ix + 1) x [iy, iy + 1) x [iz, iz + 1). */
struct GridGeometry {
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();
  float resolution = 1.0f;
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();

  std::size_t
  cellCount() const
  {
    return static_cast<std::size_t>(dims.x()) * dims.y() * dims.z();
  }
  std::size_t
  cellIndex(int ix, int iy, int iz) const
  {
    return (static_cast<std::size_t>(iz) * dims.y() + iy) * dims.x() + ix;
  }
};

/** \brief A source-to-target pose in a grid's units, as every backend applies it: a local
 * source point p lies in cell floor(rotation * p + translation). The backends must agree
 * bit for bit, so they all take it from gridPose(). */
struct GridPose {
  Eigen::Matrix3f rotation;    ///< R / resolution
  Eigen::Vector3f translation; ///< (t - origin) / resolution
  /** R's z row: a sample with covariance C has z variance rotation_z^T C rotation_z. */
  Eigen::Vector3f rotation_z;
  /** From a z variance in m^2 to quantisation levels squared (see kHeightLevels). */
  float variance_scale;
};

/** \brief The pose (rotation, translation) from the source's local frame to the target's in
 * the units of grid \a g. */
inline GridPose
gridPose(const GridGeometry& g, const Eigen::Matrix3f& rotation, const Eigen::Vector3f& translation)
{
  const float inv_res = 1.0f / g.resolution;
  GridPose pose;
  pose.rotation = rotation * inv_res;
  pose.translation = (translation - g.origin) * inv_res;
  pose.rotation_z = rotation.row(2).transpose();
  pose.variance_scale = static_cast<float>(kHeightLevels) * kHeightLevels * inv_res * inv_res;
  return pose;
}

/** \brief An occupied target voxel: its cell coordinates and feature bin. */
struct OccupiedVoxel {
  std::uint32_t cell;
  std::int32_t ix, iy, iz;
  std::uint8_t bin;
};

/** \brief The target's features, computed once per target: a dense grid of bins over the
 * target's bounding box (0 = unoccupied) and the list of occupied voxels. */
struct TargetGrid {
  GridGeometry geometry;
  Feature feature = Feature::VarianceZ;
  FeatureBinning binning;
  std::vector<std::uint8_t> bins;
  /** In the order of their cell index (z, then y, then x). */
  std::vector<OccupiedVoxel> occupied;
  /** Where each row of cells (iz * dims.y + iy) starts in occupied, and one past the last:
   * the occupied voxels of a box are found row by row without a look at the others. */
  std::vector<std::uint32_t> row_starts;
};

/** \brief The grid covering \a points at \a resolution. False (with \a error) when the
 * cloud is empty or the grid would need more than kMaxGridCells voxels. \a box, where
 * given, is the points' bounding box, which is then not looked for again. */
bool
makeGridGeometry(const PointList& points,
                 double resolution,
                 GridGeometry& geometry,
                 std::string& error,
                 const Box* box = nullptr);

/** \brief Builds the target grid from local points. False (with \a error) when the cloud
 * is empty or its extent needs more than kMaxGridCells voxels at this resolution. With
 * binning.range_quantile > 0, grid.binning.max_value is the grid's own quantile (see
 * FeatureBinning); backends bin the source with grid.binning. \a box as for
 * makeGridGeometry(). */
bool
buildTargetGrid(const PointList& points,
                double resolution,
                Feature feature,
                const FeatureBinning& binning,
                TargetGrid& grid,
                std::string& error,
                const Box* box = nullptr);

} // namespace core
} // namespace pcl_mi
