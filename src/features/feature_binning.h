/*
 * pcl_mi: per-voxel feature values and their histogram bins, as C++ over the arithmetic
 * that kernels/voxel_math.h holds once for both backends.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "kernels/voxel_math.h"

#include <pcl_mi/types.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace pcl_mi {
namespace core {

/** Levels a point's height inside its voxel is quantised to. Integer moments make the
 * voxel features independent of summation order (threads, devices). */
constexpr int kHeightLevels = PCL_MI_HEIGHT_LEVELS;

/** \brief Integer moments of the points in one voxel: count and the sums of the quantised
 * in-voxel heights q in [0, kHeightLevels) and of q^2. */
struct VoxelMoments {
  std::uint32_t count = 0;
  std::uint32_t sum_q = 0;  // <= 255 * count: exact up to 2^24 points in one voxel
  std::uint64_t sum_q2 = 0;

  /** Adds one point at quantised height \a q. */
  void
  add(int q)
  {
    ++count;
    sum_q += static_cast<std::uint32_t>(q);
    sum_q2 += static_cast<std::uint64_t>(q) * static_cast<std::uint64_t>(q);
  }

  /** Adds \a n points whose heights have mean \a q and variance \a variance_q (both in
   * quantisation levels): sum q_i^2 = n * (q^2 + variance_q). */
  void
  add(int q, std::uint32_t n, std::uint32_t variance_q)
  {
    count += n;
    sum_q += n * static_cast<std::uint32_t>(q);
    sum_q2 += static_cast<std::uint64_t>(n) *
              (static_cast<std::uint64_t>(q) * static_cast<std::uint64_t>(q) + variance_q);
  }
};

/** \brief Quantised height of a point inside its voxel. \a z_cells is the point's z in
 * voxel units relative to the grid origin, \a iz its voxel index (floor(z_cells)). */
inline int
quantiseHeight(float z_cells, int iz)
{
  return voxel::pcl_mi_quantise_height(z_cells, iz);
}

/** \brief Feature value of an occupied voxel (see pcl_mi::FeatureBinning for units). */
inline double
featureValue(Feature feature, const VoxelMoments& m)
{
  if (feature == Feature::PointCount)
    return static_cast<double>(m.count);
  return voxel::pcl_mi_variance_z_value(static_cast<double>(m.count),
                                        static_cast<double>(m.sum_q),
                                        static_cast<double>(m.sum_q2));
}

/** \brief Histogram bin of a feature value: 1 + min(B - 1, floor(B * v / max)). */
inline int
binOfValue(const FeatureBinning& binning, double value)
{
  return voxel::pcl_mi_bin_of_value(binning.num_bins, binning.max_value, value);
}

/** \brief Histogram bin of a voxel: 0 when unoccupied, else the bin of its feature. */
inline int
voxelBin(Feature feature, const FeatureBinning& binning, const VoxelMoments& m)
{
  if (m.count == 0)
    return 0;
  return binOfValue(binning, featureValue(feature, m));
}

} // namespace core
} // namespace pcl_mi
