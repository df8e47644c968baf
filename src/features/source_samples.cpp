/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "features/source_samples.h"

#include <algorithm>
#include <cmath>

namespace pcl_mi {
namespace core {

namespace {

using KeyedIndex = std::pair<std::uint64_t, std::uint32_t>;

/** Sorts by key (keys below 2^bits) with a stable LSD radix sort in 11-bit digits: three
 * linear passes for a KITTI scan's cells instead of a comparison sort. */
void
radixSortByKey(std::vector<KeyedIndex>& keyed, int bits)
{
  constexpr int kDigitBits = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kDigitBits;
  std::vector<KeyedIndex> buffer(keyed.size());
  std::vector<std::size_t> offsets(kBuckets);
  for (int shift = 0; shift < bits; shift += kDigitBits) {
    std::fill(offsets.begin(), offsets.end(), 0);
    for (const auto& k : keyed)
      ++offsets[(k.first >> shift) & (kBuckets - 1)];
    std::size_t sum = 0;
    for (auto& o : offsets) {
      const std::size_t count = o;
      o = sum;
      sum += count;
    }
    for (const auto& k : keyed)
      buffer[offsets[(k.first >> shift) & (kBuckets - 1)]++] = k;
    keyed.swap(buffer);
  }
}

/** Bits needed for values up to \a max_value. */
int
bitsFor(std::uint64_t max_value)
{
  int bits = 0;
  while (bits < 64 && (max_value >> bits) != 0)
    ++bits;
  return bits;
}

/** Cell coordinates of \a count positions (cubes of edge \a cell_size from \a min; \a max
 * bounds the positions), packed into keys ordered z, then y, then x with as few bits per
 * axis as the extent needs, and sorted. Coordinates are capped at 2^21 - 1 cells per
 * axis. The cells are cellCoordinates()'s, the same as TargetDistributions'. */
template <typename PositionOf>
std::vector<KeyedIndex>
sortedCellKeys(std::size_t count,
               const PositionOf& position_of,
               const Eigen::Vector3f& min,
               const Eigen::Vector3f& max,
               double cell_size)
{
  const float inv_cell = static_cast<float>(1.0 / cell_size);
  constexpr float kCap = static_cast<float>((1 << 21) - 1);
  auto cellOf = [&](const Eigen::Vector3f& p) {
    const Eigen::Vector3f c = cellCoordinates(p, min, inv_cell).cwiseMax(0.0f).cwiseMin(kCap);
    return Eigen::Matrix<std::uint64_t, 3, 1>(static_cast<std::uint64_t>(c.x()),
                                              static_cast<std::uint64_t>(c.y()),
                                              static_cast<std::uint64_t>(c.z()));
  };
  // Cells grow monotonically with the position: the box's far corner has the largest.
  const Eigen::Matrix<std::uint64_t, 3, 1> max_cell = cellOf(max);
  const int bx = bitsFor(max_cell.x()), by = bitsFor(max_cell.y()), bz = bitsFor(max_cell.z());
  std::vector<KeyedIndex> keyed(count);
  for (std::size_t i = 0; i < count; ++i) {
    const auto cell = cellOf(position_of(i));
    keyed[i] = {(cell.z() << (bx + by)) | (cell.y() << bx) | cell.x(),
                static_cast<std::uint32_t>(i)};
  }
  radixSortByKey(keyed, bx + by + bz);
  return keyed;
}

/** Bounding box of the \a count > 0 positions. */
template <typename PositionOf>
void
boundingBox(std::size_t count,
            const PositionOf& position_of,
            Eigen::Vector3f& min,
            Eigen::Vector3f& max)
{
  min = max = position_of(0);
  for (std::size_t i = 1; i < count; ++i) {
    min = min.cwiseMin(position_of(i));
    max = max.cwiseMax(position_of(i));
  }
}

/** Sums of the offsets d of points (or weighted samples) from an anchor and of their
 * outer products d d^T, in double. Spelled out as scalars: Eigen's outer-product
 * temporaries went through the stack and made the summaries twice as slow. */
struct OffsetSums {
  double n = 0.0;
  double x = 0.0, y = 0.0, z = 0.0;
  double xx = 0.0, xy = 0.0, xz = 0.0, yy = 0.0, yz = 0.0, zz = 0.0;

  /** Adds \a weight points at offset (dx, dy, dz) whose own covariance is \a c (6 entries,
   * or null for single points). */
  void
  add(double dx, double dy, double dz, double weight = 1.0, const float* c = nullptr)
  {
    n += weight;
    x += weight * dx;
    y += weight * dy;
    z += weight * dz;
    xx += weight * dx * dx;
    xy += weight * dx * dy;
    xz += weight * dx * dz;
    yy += weight * dy * dy;
    yz += weight * dy * dz;
    zz += weight * dz * dz;
    if (c) {
      xx += weight * c[0];
      xy += weight * c[1];
      xz += weight * c[2];
      yy += weight * c[3];
      yz += weight * c[4];
      zz += weight * c[5];
    }
  }
};

/** Appends the sample summarised by \a sums of offsets from \a anchor. */
void
appendSummary(SourceSamples& out, const Eigen::Vector3d& anchor, const OffsetSums& sums)
{
  const double n = sums.n;
  const Eigen::Vector3d mean(sums.x / n, sums.y / n, sums.z / n);
  SourceSample s;
  s.position = (anchor + mean).cast<float>();
  s.count = static_cast<std::uint32_t>(n);
  const double c[6] = {sums.xx / n - mean.x() * mean.x(), sums.xy / n - mean.x() * mean.y(),
                       sums.xz / n - mean.x() * mean.z(), sums.yy / n - mean.y() * mean.y(),
                       sums.yz / n - mean.y() * mean.z(), sums.zz / n - mean.z() * mean.z()};
  for (int i = 0; i < 6; ++i)
    s.covariance[i] = static_cast<float>(c[i]);
  out.has_covariance = out.has_covariance || s.count > 1;
  out.samples.push_back(s);
}

} // namespace

SourceSamples
makeSourceSamples(const PointList& points, double cell_size)
{
  SourceSamples out;
  out.cell_size = cell_size;
  out.point_count = points.size();
  if (points.empty())
    return out;
  if (!(cell_size > 0.0)) {
    out.samples.resize(points.size());
    for (std::size_t i = 0; i < points.size(); ++i)
      out.samples[i].position = points[i];
    return out;
  }

  // Sort points by their cell (z slowest), then summarise runs of equal cells.
  auto point = [&](std::size_t i) -> const Eigen::Vector3f& { return points[i]; };
  Eigen::Vector3f min, max;
  boundingBox(points.size(), point, min, max);
  out.grid_origin = min;
  const std::vector<KeyedIndex> keyed = sortedCellKeys(points.size(), point, min, max, cell_size);
  for (std::size_t begin = 0; begin < keyed.size();) {
    std::size_t end = begin + 1;
    while (end < keyed.size() && keyed[end].first == keyed[begin].first)
      ++end;
    // Relative to the cell's first point, for accuracy.
    const Eigen::Vector3d anchor = points[keyed[begin].second].cast<double>();
    OffsetSums sums;
    for (std::size_t k = begin; k < end; ++k) {
      const Eigen::Vector3f& p = points[keyed[k].second];
      sums.add(p.x() - anchor.x(), p.y() - anchor.y(), p.z() - anchor.z());
    }
    appendSummary(out, anchor, sums);
    begin = end;
  }
  return out;
}

std::vector<SourceSamples>
makeSourceSamplePyramid(const PointList& points, double cell_size, int coarser)
{
  std::vector<SourceSamples> pyramid;
  pyramid.push_back(makeSourceSamples(points, cell_size));
  if (points.empty() || !(cell_size > 0.0))
    return pyramid;
  Eigen::Vector3f min, max;
  boundingBox(points.size(), [&](std::size_t i) -> const Eigen::Vector3f& { return points[i]; },
              min, max);
  for (int k = 1; k <= coarser; ++k) {
    const SourceSamples& fine = pyramid.back();
    SourceSamples out;
    out.cell_size = fine.cell_size * 2.0;
    out.point_count = fine.point_count;
    out.grid_origin = min; // the same corner at every level: coarse cells nest fine ones
    // The same cells as makeSourceSamples at the coarser size, for the finer centroids.
    const std::vector<KeyedIndex> keyed = sortedCellKeys(
        fine.samples.size(),
        [&](std::size_t i) -> const Eigen::Vector3f& { return fine.samples[i].position; }, min,
        max, out.cell_size);
    for (std::size_t begin = 0; begin < keyed.size();) {
      std::size_t end = begin + 1;
      while (end < keyed.size() && keyed[end].first == keyed[begin].first)
        ++end;
      // Merge by the parallel-axis rule, relative to the first centroid.
      const Eigen::Vector3d anchor = fine.samples[keyed[begin].second].position.cast<double>();
      OffsetSums sums;
      for (std::size_t k2 = begin; k2 < end; ++k2) {
        const SourceSample& f = fine.samples[keyed[k2].second];
        sums.add(f.position.x() - anchor.x(), f.position.y() - anchor.y(),
                 f.position.z() - anchor.z(), f.count, f.covariance);
      }
      appendSummary(out, anchor, sums);
      begin = end;
    }
    pyramid.push_back(std::move(out));
  }
  return pyramid;
}

} // namespace core
} // namespace pcl_mi
