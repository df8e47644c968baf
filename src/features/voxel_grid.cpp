/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "features/voxel_grid.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

namespace pcl_mi {
namespace core {

namespace {

/** Values of one axis sampled for its median: the median only anchors the cells in
 * bulkRange(), and a strided sample finds it without a selection over every point. */
constexpr std::size_t kMedianSamples = 4096;

/** Cells of half a gap on either side of the median that bulkRange() looks at: points
 * further out (2048 gaps: 131 km at 1 m voxels) are outliers whatever lies between. */
constexpr long kHalfGapCells = 4096;

/** [low, high] of axis \a axis: the values of the largest group of \a points, where groups
 * are split wherever two consecutive values (in sorted order) are at least \a gap apart.
 * Exact without sorting: values are put in cells of half a gap, which keep their count,
 * minimum and maximum; values in the same or neighbouring cells are less than a gap apart,
 * and across empty cells the gap is the next cell's minimum minus the last one's maximum. */
void
bulkRange(const PointList& points, int axis, double gap, double& low, double& high)
{
  const std::size_t stride = std::max<std::size_t>(1, points.size() / kMedianSamples);
  std::vector<float> sample;
  sample.reserve(points.size() / stride + 1);
  for (std::size_t i = 0; i < points.size(); i += stride)
    sample.push_back(points[i][axis]);
  auto mid = sample.begin() + sample.size() / 2;
  std::nth_element(sample.begin(), mid, sample.end());
  const double median = *mid;
  struct Cell {
    std::size_t count = 0;
    float min = 0.0f, max = 0.0f;
  };
  std::vector<Cell> cells(2 * kHalfGapCells + 1);
  const double inv_width = 2.0 / gap;
  for (const auto& p : points) {
    const double k = std::floor((p[axis] - median) * inv_width);
    if (!(std::abs(k) <= kHalfGapCells))
      continue;
    Cell& c = cells[static_cast<std::size_t>(k + kHalfGapCells)];
    c.min = c.count ? std::min(c.min, p[axis]) : p[axis];
    c.max = c.count ? std::max(c.max, p[axis]) : p[axis];
    ++c.count;
  }
  // The groups in order; the first of equally large ones wins.
  std::size_t best = 0, current = 0;
  double group_low = 0.0, last_max = 0.0;
  low = high = median;
  for (const Cell& c : cells) {
    if (c.count == 0)
      continue;
    if (current > 0 && static_cast<double>(c.min) - last_max >= gap)
      current = 0;
    if (current == 0)
      group_low = c.min;
    current += c.count;
    last_max = c.max;
    if (current > best) {
      best = current;
      low = group_low;
      high = last_max;
    }
  }
}

} // namespace

LocalCloud
makeLocalCloud(const PointList& points, double outlier_gap)
{
  // Built in place in the output, without an intermediate copy: clouds of tens of millions
  // of points are worth 12 bytes a point.
  LocalCloud cloud;
  PointList& kept = cloud.points;
  // Many drivers write a beam without a return as (0, 0, 0) rather than NaN. Piled into the
  // voxel at the sensor, they make a feature that agrees wherever the two sensors' piles
  // meet, which outscores the true alignment (docs/method.md).
  const auto usable = [](const Eigen::Vector3f& p) {
    return p.allFinite() && !(p.x() == 0.0f && p.y() == 0.0f && p.z() == 0.0f);
  };
  std::size_t finite = 0, kept_count = 0;
  for (const auto& p : points) {
    finite += p.allFinite();
    kept_count += usable(p);
  }
  cloud.non_finite = points.size() - finite;
  cloud.no_return = finite - kept_count;
  if (kept_count == 0)
    return cloud;
  kept.reserve(kept_count);
  for (const auto& p : points)
    if (usable(p))
      kept.push_back(p);

  Eigen::Vector3d low, high;
  for (int a = 0; a < 3; ++a)
    bulkRange(kept, a, outlier_gap, low[a], high[a]);

  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  std::size_t count = 0;
  for (const auto& p : kept) {
    const Eigen::Vector3d pd = p.cast<double>();
    if ((pd.array() < low.array()).any() || (pd.array() > high.array()).any())
      continue;
    kept[count++] = p;
    sum += pd;
  }
  cloud.outliers = kept_count - count;
  kept.resize(count);
  // Measured in the input frame, before re-centring, since the sensor sits at its origin.
  cloud.azimuth_coverage_deg = azimuthCoverageDegrees(kept);
  cloud.centroid = sum / static_cast<double>(count);
  for (auto& p : kept)
    p = (p.cast<double>() - cloud.centroid).cast<float>();
  return cloud;
}

double
azimuthCoverageDegrees(const PointList& points)
{
  constexpr int kSectors = 72;
  constexpr std::size_t kLooked = 8192;
  if (points.empty())
    return 0.0;
  const std::size_t stride = std::max<std::size_t>(1, points.size() / kLooked);
  std::array<std::size_t, kSectors> count{};
  std::size_t looked = 0;
  for (std::size_t i = 0; i < points.size(); i += stride) {
    const Eigen::Vector3d p = points[i].cast<double>();
    const double sector = (std::atan2(p.y(), p.x()) + M_PI) * (kSectors / (2.0 * M_PI));
    ++count[static_cast<std::size_t>(std::clamp(static_cast<int>(sector), 0, kSectors - 1))];
    ++looked;
  }
  // A small share of an even split: well below the emptiest sectors of a spinning scan,
  // well above a cut-off sector's stray returns (docs/method.md).
  const double threshold = 0.05 * static_cast<double>(looked) / kSectors;
  int covered = 0;
  for (const std::size_t c : count)
    covered += static_cast<double>(c) >= threshold;
  return covered * (360.0 / kSectors);
}

bool
makeGridGeometry(const PointList& points,
                 double resolution,
                 GridGeometry& g,
                 std::string& error)
{
  if (points.empty()) {
    error = "the target has no usable points";
    return false;
  }
  Eigen::Vector3f min = points.front(), max = points.front();
  for (const auto& p : points) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  g.resolution = static_cast<float>(resolution);
  const Eigen::Vector3d first = (min.cast<double>() / resolution).array().floor();
  const Eigen::Vector3d last = (max.cast<double>() / resolution).array().floor();
  const Eigen::Vector3d dims = last - first + Eigen::Vector3d::Ones();
  if (dims.prod() > static_cast<double>(kMaxGridCells)) {
    std::ostringstream s;
    s << "the target spans " << dims.x() << " x " << dims.y() << " x " << dims.z()
      << " voxels at resolution " << resolution << ", more than the " << kMaxGridCells
      << " a grid may hold; use a coarser resolution or crop the clouds";
    error = s.str();
    return false;
  }
  g.dims = dims.cast<int>();
  g.origin = (first * resolution).cast<float>();
  return true;
}

bool
buildTargetGrid(const PointList& points,
                double resolution,
                Feature feature,
                const FeatureBinning& binning,
                TargetGrid& grid,
                std::string& error)
{
  GridGeometry& g = grid.geometry;
  if (!makeGridGeometry(points, resolution, g, error))
    return false;
  grid.feature = feature;
  grid.binning = binning;

  std::vector<VoxelMoments> moments(g.cellCount());
  const float inv_res = 1.0f / g.resolution;
  for (const auto& p : points) {
    const Eigen::Vector3f f = (p - g.origin) * inv_res;
    const int ix = std::min(std::max(static_cast<int>(std::floor(f.x())), 0), g.dims.x() - 1);
    const int iy = std::min(std::max(static_cast<int>(std::floor(f.y())), 0), g.dims.y() - 1);
    const int iz = std::min(std::max(static_cast<int>(std::floor(f.z())), 0), g.dims.z() - 1);
    moments[g.cellIndex(ix, iy, iz)].add(quantiseHeight(f.z(), iz));
  }
  if (binning.range_quantile > 0.0) {
    std::vector<double> values;
    for (const auto& m : moments)
      if (m.count)
        values.push_back(featureValue(feature, m));
    if (!values.empty()) {
      const auto k = values.begin() + static_cast<std::ptrdiff_t>(
                                          binning.range_quantile * (values.size() - 1));
      std::nth_element(values.begin(), k, values.end());
      if (*k > 0.0)
        grid.binning.max_value = *k;
    }
  }
  grid.bins.assign(g.cellCount(), 0);
  grid.occupied.clear();
  for (int iz = 0; iz < g.dims.z(); ++iz)
    for (int iy = 0; iy < g.dims.y(); ++iy)
      for (int ix = 0; ix < g.dims.x(); ++ix) {
        const std::size_t cell = g.cellIndex(ix, iy, iz);
        if (moments[cell].count == 0)
          continue;
        const auto bin = static_cast<std::uint8_t>(voxelBin(feature, grid.binning, moments[cell]));
        grid.bins[cell] = bin;
        grid.occupied.push_back({static_cast<std::uint32_t>(cell), ix, iy, iz, bin});
      }
  return true;
}

} // namespace core
} // namespace pcl_mi
