/*
 * pcl_mi: the source as weighted samples, the unit every backend transforms and voxelises.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "util/bounding_box.h"

#include <pcl_mi/types.h>

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace pcl_mi {
namespace core {

/** \brief Points that fall into one small cell, summarised: their count, centroid and
 * covariance. Moving the summary instead of the points gives the same voxel count and a
 * close z variance as long as the cell is well inside a voxel. */
struct SourceSample {
  Eigen::Vector3f position;   ///< centroid, source local frame
  std::uint32_t count = 1;    ///< points summarised
  float covariance[6] = {0};  ///< xx, xy, xz, yy, yz, zz of the points (m^2)
};

/** \brief The source as the backends consume it. With cell_size 0 every point is its own
 * sample (count 1, no covariance): the paper's exact per-point evaluation. */
struct SourceSamples {
  std::vector<SourceSample> samples;
  double cell_size = 0.0;        ///< 0: one sample per point
  /** Corner of cell (0, 0, 0): the cells are cellCoordinates(p, grid_origin,
   * 1 / cell_size)'s integer parts (the points' minimum; zero when cell_size is 0). */
  Eigen::Vector3f grid_origin = Eigen::Vector3f::Zero();
  bool has_covariance = false;   ///< false when every covariance is zero
  std::size_t point_count = 0;   ///< points represented
};

/** \brief Continuous cell coordinates of \a p on the grid of cubes of edge 1 / \a inv_cell
 * whose corner is \a min: the cube is their integer part. The one rule for every summary
 * grid, so the source's samples and the refinement's target cubes agree. */
inline Eigen::Vector3f
cellCoordinates(const Eigen::Vector3f& p, const Eigen::Vector3f& min, float inv_cell)
{
  return (p - min) * inv_cell;
}

/** \brief Summarises \a points per cube of edge \a cell_size (0 keeps every point). Cells
 * are ordered by their position in space, which keeps the backends' memory access
 * coherent. \a box, where given, is the points' bounding box, which is then not looked for
 * again. */
SourceSamples
makeSourceSamples(const PointList& points, double cell_size, const Box* box = nullptr);

/** \brief Summarises \a points per cube of edge \a cell_size and then per cube of edge
 * cell_size * 2^k for k = 1 .. \a coarser, merging the finer summaries (same count, centroid
 * and covariance as summarising the points directly, up to rounding), so the points are
 * sorted once however many levels there are. Element k has cell size cell_size * 2^k. The
 * finest level is summarised on up to \a threads threads, with the same result on any number.
 * \a box as for makeSourceSamples(). */
std::vector<SourceSamples>
makeSourceSamplePyramid(const PointList& points,
                        double cell_size,
                        int coarser,
                        int threads = 1,
                        const Box* box = nullptr);

} // namespace core
} // namespace pcl_mi
