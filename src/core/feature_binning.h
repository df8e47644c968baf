/*
 * pcl_mi: per-voxel feature values and their histogram bins. Every backend uses these
 * functions (or mirrors them exactly), so that all backends bin identically.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_mi/parameters.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace pcl_mi {
namespace core {

/** Levels a point's height inside its voxel is quantised to. Integer moments make the
 * voxel features independent of summation order (threads, devices). */
constexpr int kHeightLevels = 256;

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
  const int q = static_cast<int>((z_cells - static_cast<float>(iz)) * kHeightLevels);
  return std::min(std::max(q, 0), kHeightLevels - 1);
}

/** \brief Feature value of an occupied voxel (see pcl_mi::FeatureBinning for units). */
inline double
featureValue(Feature feature, const VoxelMoments& m)
{
  if (feature == Feature::PointCount)
    return static_cast<double>(m.count);
  // var(z) / R_v^2 = (n * S2 - S1^2) / (n^2 * L^2), exact in integers up to large n.
  const double n = static_cast<double>(m.count);
  const double s1 = static_cast<double>(m.sum_q);
  const double s2 = static_cast<double>(m.sum_q2);
  const double numerator = std::max(0.0, n * s2 - s1 * s1);
  return numerator / (n * n * static_cast<double>(kHeightLevels) * kHeightLevels);
}

/** \brief Histogram bin of a feature value: 1 + min(B - 1, floor(B * v / max)). */
inline int
binOfValue(const FeatureBinning& binning, double value)
{
  const double scaled = binning.num_bins * value / binning.max_value;
  if (!(scaled > 0.0))
    return 1;
  if (scaled >= binning.num_bins)
    return binning.num_bins;
  return 1 + static_cast<int>(scaled);
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
