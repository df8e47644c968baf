/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "core/source_samples.h"

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

/** Cell coordinates of \a positions (cubes of edge \a cell_size from \a min), packed into
 * keys ordered z, then y, then x with as few bits per axis as the extent needs, and
 * sorted. Coordinates are capped at 2^21 - 1 cells per axis. */
template <typename PositionOf>
std::vector<KeyedIndex>
sortedCellKeys(std::size_t count,
               const PositionOf& position_of,
               const Eigen::Vector3f& min,
               double cell_size)
{
  const double inv = 1.0 / cell_size;
  constexpr std::uint64_t kMask = (std::uint64_t{1} << 21) - 1;
  auto cellOf = [&](std::size_t i) {
    const Eigen::Vector3d c =
        ((position_of(i) - min).template cast<double>() * inv).array().floor().max(0.0);
    Eigen::Matrix<std::uint64_t, 3, 1> cell;
    for (int a = 0; a < 3; ++a)
      cell[a] = std::min<std::uint64_t>(static_cast<std::uint64_t>(c[a]), kMask);
    return cell;
  };
  // Two passes (extent, then keys) rather than storing every cell: memory stays at the
  // keys alone, which matters for clouds of tens of millions of points.
  Eigen::Matrix<std::uint64_t, 3, 1> max_cell = Eigen::Matrix<std::uint64_t, 3, 1>::Zero();
  for (std::size_t i = 0; i < count; ++i)
    max_cell = max_cell.cwiseMax(cellOf(i));
  const int bx = bitsFor(max_cell.x()), by = bitsFor(max_cell.y()), bz = bitsFor(max_cell.z());
  std::vector<KeyedIndex> keyed(count);
  for (std::size_t i = 0; i < count; ++i) {
    const auto cell = cellOf(i);
    keyed[i] = {(cell.z() << (bx + by)) | (cell.y() << bx) | cell.x(),
                static_cast<std::uint32_t>(i)};
  }
  radixSortByKey(keyed, bx + by + bz);
  return keyed;
}

/** Appends the sample of \a n points whose offsets from \a anchor sum to \a sum and whose
 * outer products sum to \a sum_outer (relative to the anchor, for accuracy). */
void
appendSummary(SourceSamples& out,
              const Eigen::Vector3d& anchor,
              double n,
              const Eigen::Vector3d& sum,
              const Eigen::Matrix3d& sum_outer)
{
  const Eigen::Vector3d mean = sum / n;
  const Eigen::Matrix3d cov = sum_outer / n - mean * mean.transpose();
  SourceSample s;
  s.position = (anchor + mean).cast<float>();
  s.count = static_cast<std::uint32_t>(n);
  const double c[6] = {cov(0, 0), cov(0, 1), cov(0, 2), cov(1, 1), cov(1, 2), cov(2, 2)};
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
  Eigen::Vector3f min = points.front();
  for (const auto& p : points)
    min = min.cwiseMin(p);
  const std::vector<KeyedIndex> keyed = sortedCellKeys(
      points.size(), [&](std::size_t i) -> const Eigen::Vector3f& { return points[i]; }, min,
      cell_size);

  for (std::size_t begin = 0; begin < keyed.size();) {
    std::size_t end = begin + 1;
    while (end < keyed.size() && keyed[end].first == keyed[begin].first)
      ++end;
    // Mean and covariance relative to the first point, in double, for accuracy.
    const Eigen::Vector3d anchor = points[keyed[begin].second].cast<double>();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d sum_outer = Eigen::Matrix3d::Zero();
    for (std::size_t k = begin; k < end; ++k) {
      const Eigen::Vector3d d = points[keyed[k].second].cast<double>() - anchor;
      sum += d;
      sum_outer += d * d.transpose();
    }
    appendSummary(out, anchor, static_cast<double>(end - begin), sum, sum_outer);
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
  Eigen::Vector3f min = points.front();
  for (const auto& p : points)
    min = min.cwiseMin(p);
  for (int k = 1; k <= coarser; ++k) {
    const SourceSamples& fine = pyramid.back();
    SourceSamples out;
    out.cell_size = fine.cell_size * 2.0;
    out.point_count = fine.point_count;
    // The same cells as makeSourceSamples at the coarser size, for the finer centroids.
    const std::vector<KeyedIndex> keyed = sortedCellKeys(
        fine.samples.size(),
        [&](std::size_t i) -> const Eigen::Vector3f& { return fine.samples[i].position; }, min,
        out.cell_size);
    for (std::size_t begin = 0; begin < keyed.size();) {
      std::size_t end = begin + 1;
      while (end < keyed.size() && keyed[end].first == keyed[begin].first)
        ++end;
      // Merge by the parallel-axis rule, relative to the first centroid, in double.
      const Eigen::Vector3d anchor = fine.samples[keyed[begin].second].position.cast<double>();
      double n = 0.0;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      Eigen::Matrix3d sum_outer = Eigen::Matrix3d::Zero();
      for (std::size_t k2 = begin; k2 < end; ++k2) {
        const SourceSample& f = fine.samples[keyed[k2].second];
        const double m = f.count;
        const Eigen::Vector3d d = f.position.cast<double>() - anchor;
        const float* c = f.covariance;
        Eigen::Matrix3d cov;
        cov << c[0], c[1], c[2], c[1], c[3], c[4], c[2], c[4], c[5];
        n += m;
        sum += m * d;
        sum_outer += m * (cov + d * d.transpose());
      }
      appendSummary(out, anchor, n, sum, sum_outer);
      begin = end;
    }
    pyramid.push_back(std::move(out));
  }
  return pyramid;
}

} // namespace core
} // namespace pcl_mi
