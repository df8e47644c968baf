/*
 * pcl_mi: the target's voxel feature grid and the grid geometry every backend shares.
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
