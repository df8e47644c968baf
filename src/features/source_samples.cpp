/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "features/source_samples.h"

#include "util/bounding_box.h"
#include "util/parallel.h"

#include <algorithm>
#include <cmath>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace pcl_mi {
namespace core {

namespace {

/** Widest radix digit: 4096 buckets keep a pass's offsets in the first-level caches. */
constexpr int kMaxDigitBits = 12;

/** Sorts \a items by key(item) (keys below 2^bits) with a stable LSD radix sort in as few
 * passes of at most kMaxDigitBits as the bits need; every pass's bucket sizes are counted in
 * one read before the first. Linear, instead of a comparison sort. */
template <typename Item, typename KeyOf>
void
radixSort(std::vector<Item>& items, int bits, const KeyOf& key)
{
  const int passes = std::max(1, (bits + kMaxDigitBits - 1) / kMaxDigitBits);
  const int digit_bits = std::max(1, (bits + passes - 1) / passes);
  const std::size_t buckets = std::size_t{1} << digit_bits;
  const std::uint64_t digit_mask = buckets - 1;
  std::vector<std::size_t> offsets(static_cast<std::size_t>(passes) * buckets, 0);
  for (const Item& item : items) {
    const std::uint64_t k = key(item);
    for (int pass = 0; pass < passes; ++pass)
      ++offsets[pass * buckets + ((k >> (pass * digit_bits)) & digit_mask)];
  }
  std::vector<Item> buffer(items.size());
  for (int pass = 0; pass < passes; ++pass) {
    std::size_t* offset = offsets.data() + pass * buckets;
    std::size_t sum = 0;
    for (std::size_t b = 0; b < buckets; ++b) {
      const std::size_t count = offset[b];
      offset[b] = sum;
      sum += count;
    }
    const int shift = pass * digit_bits;
    for (const Item& item : items)
      buffer[offset[(key(item) >> shift) & digit_mask]++] = item;
    items.swap(buffer);
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

/** Indices of positions in the order of their cells' keys (stable), with the keys. Keys of
 * up to 32 bits share one 64-bit word with their index, which halves what the sort moves;
 * wider ones (very fine cells over a large extent) are kept beside it. */
class SortedCells {
public:
  /** Sorts the indices 0 .. count - 1 by keys(index), keys below 2^bits; keys.packFour(i,
   * out) writes key << 32 | index for indices i .. i + 3 as keys(index) gives them. */
  template <typename Keys>
  SortedCells(std::size_t count, int bits, const Keys& keys)
  {
    if (bits <= 32) {
      packed_.resize(count);
      std::size_t i = 0;
      for (; i + 4 <= count; i += 4)
        keys.packFour(i, packed_.data() + i);
      for (; i < count; ++i)
        packed_[i] = keys(i) << 32 | static_cast<std::uint64_t>(i);
      radixSort(packed_, bits, [](std::uint64_t v) { return v >> 32; });
      return;
    }
    wide_.resize(count);
    for (std::size_t i = 0; i < count; ++i)
      wide_[i] = {keys(i), static_cast<std::uint32_t>(i)};
    radixSort(wide_, bits, [](const std::pair<std::uint64_t, std::uint32_t>& v) { return v.first; });
  }

  /** Sorts \a packed (key << 32 | index, keys below 2^bits, at most 32 bits) by key, stably. */
  SortedCells(std::vector<std::uint64_t>&& packed, int bits) : packed_(std::move(packed))
  {
    radixSort(packed_, bits, [](std::uint64_t v) { return v >> 32; });
  }

  std::size_t
  size() const
  {
    return packed_.empty() ? wide_.size() : packed_.size();
  }
  std::uint64_t
  key(std::size_t i) const
  {
    return packed_.empty() ? wide_[i].first : packed_[i] >> 32;
  }
  std::uint32_t
  index(std::size_t i) const
  {
    return packed_.empty() ? wide_[i].second : static_cast<std::uint32_t>(packed_[i]);
  }

private:
  std::vector<std::uint64_t> packed_;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> wide_;
};

/** The keys of the cells of positions (cubes of edge 1 / inv_cell from min), ordered z, then
 * y, then x with as few bits per axis as the extent needs. Coordinates are capped at
 * 2^21 - 1 cells per axis. The cells are cellCoordinates()'s, the same as
 * TargetDistributions'. */
template <typename PositionOf>
class CellKeys {
public:
  /** \a max bounds the positions. */
  CellKeys(const PositionOf& position_of,
           const Eigen::Vector3f& min,
           const Eigen::Vector3f& max,
           double cell_size)
  : position_of_(position_of), min_(min), inv_cell_(static_cast<float>(1.0 / cell_size))
  {
    // Cells grow monotonically with the position: the box's far corner has the largest.
    const Eigen::Matrix<std::uint64_t, 3, 1> max_cell = cellOf(max);
    shift_y_ = bitsFor(max_cell.x());
    shift_z_ = shift_y_ + bitsFor(max_cell.y());
    bits_ = shift_z_ + bitsFor(max_cell.z());
  }

  /** Bits the keys need. */
  int
  bits() const
  {
    return bits_;
  }

  std::uint64_t
  operator()(std::size_t i) const
  {
    const auto cell = cellOf(position_of_(i));
    return (cell.z() << shift_z_) | (cell.y() << shift_y_) | cell.x();
  }

  /** key(i + k) << 32 | (i + k) into \a out[k] for k = 0 .. 3, keys of at most 32 bits. Where
   * SSE2 is there, the four cells are computed at once, each lane rounding as cellOf() does. */
  void
  packFour(std::size_t i, std::uint64_t* out) const
  {
#if defined(__SSE2__)
    const Eigen::Vector3f* p[4] = {&position_of_(i), &position_of_(i + 1), &position_of_(i + 2),
                                   &position_of_(i + 3)};
    const __m128 zero = _mm_setzero_ps(), cap = _mm_set1_ps(kCap);
    const __m128 inv = _mm_set1_ps(inv_cell_);
    __m128i cell[3];
    for (int a = 0; a < 3; ++a) {
      const __m128 v = _mm_setr_ps((*p[0])[a], (*p[1])[a], (*p[2])[a], (*p[3])[a]);
      const __m128 c = _mm_mul_ps(_mm_sub_ps(v, _mm_set1_ps(min_[a])), inv);
      cell[a] = _mm_cvttps_epi32(_mm_min_ps(_mm_max_ps(c, zero), cap));
    }
    const __m128i key = _mm_or_si128(
        _mm_or_si128(_mm_sll_epi32(cell[2], _mm_cvtsi32_si128(shift_z_)),
                     _mm_sll_epi32(cell[1], _mm_cvtsi32_si128(shift_y_))),
        cell[0]);
    // The indices' low 32 bits, as the scalar packing keeps them.
    const auto first = static_cast<std::uint32_t>(i);
    const __m128i index =
        _mm_setr_epi32(static_cast<int>(first), static_cast<int>(first + 1u),
                       static_cast<int>(first + 2u), static_cast<int>(first + 3u));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out), _mm_unpacklo_epi32(index, key));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + 2), _mm_unpackhi_epi32(index, key));
#else
    for (std::size_t k = 0; k < 4; ++k)
      out[k] = (*this)(i + k) << 32 | static_cast<std::uint64_t>(i + k);
#endif
  }

private:
  static constexpr float kCap = static_cast<float>((1 << 21) - 1);

  Eigen::Matrix<std::uint64_t, 3, 1>
  cellOf(const Eigen::Vector3f& p) const
  {
    const Eigen::Vector3f c = cellCoordinates(p, min_, inv_cell_).cwiseMax(0.0f).cwiseMin(kCap);
    return Eigen::Matrix<std::uint64_t, 3, 1>(static_cast<std::uint64_t>(c.x()),
                                              static_cast<std::uint64_t>(c.y()),
                                              static_cast<std::uint64_t>(c.z()));
  }

  const PositionOf& position_of_;
  Eigen::Vector3f min_;
  float inv_cell_;
  int shift_y_ = 0, shift_z_ = 0, bits_ = 0;
};

/** Indices 0 .. count - 1 sorted by the keys of the cells (cubes of edge \a cell_size from
 * \a min; \a max bounds the positions) of position_of(index): see CellKeys. */
template <typename PositionOf>
SortedCells
sortedCellKeys(std::size_t count,
               const PositionOf& position_of,
               const Eigen::Vector3f& min,
               const Eigen::Vector3f& max,
               double cell_size)
{
  const CellKeys<PositionOf> keys(position_of, min, max, cell_size);
  return SortedCells(count, keys.bits(), keys);
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

/** Appends to \a out one summary per run of equal keys in \a keyed, of the points it indexes. */
void
summariseRuns(const PointList& points, const SortedCells& keyed, SourceSamples& out)
{
  for (std::size_t begin = 0; begin < keyed.size();) {
    std::size_t end = begin + 1;
    while (end < keyed.size() && keyed.key(end) == keyed.key(begin))
      ++end;
    // Relative to the cell's first point, for accuracy.
    const Eigen::Vector3d anchor = points[keyed.index(begin)].cast<double>();
    OffsetSums sums;
    for (std::size_t k = begin; k < end; ++k) {
      const Eigen::Vector3f& p = points[keyed.index(k)];
      sums.add(p.x() - anchor.x(), p.y() - anchor.y(), p.z() - anchor.z());
    }
    appendSummary(out, anchor, sums);
    begin = end;
  }
}

/** Fewest points worth splitting the summaries over two threads. */
constexpr std::size_t kSplitPoints = 16384;

/** The position of point i, for CellKeys. */
struct PointAt {
  const PointList& points;
  const Eigen::Vector3f&
  operator()(std::size_t i) const
  {
    return points[i];
  }
};

/** summariseCells() on two threads: the cells split at a key near the median, each thread
 * sorting and summarising the cells on its side. Each cell is summed by one thread, from
 * its points in their order, so the samples are those of one thread to the bit. False
 * (nothing done) where the keys need more than 32 bits. */
bool
summariseCellsOnTwoThreads(const PointList& points,
                           const CellKeys<PointAt>& keys,
                           SourceSamples& out)
{
  if (keys.bits() > 32)
    return false;
  const std::size_t count = points.size();
  // The cut: the median key of an even sample of the points.
  std::vector<std::uint64_t> sample;
  const std::size_t stride = std::max<std::size_t>(1, count / 1024);
  for (std::size_t i = 0; i < count; i += stride)
    sample.push_back(keys(i));
  std::nth_element(sample.begin(), sample.begin() + sample.size() / 2, sample.end());
  const std::uint64_t cut = sample[sample.size() / 2];
  // Each thread packs the keys of half of the points, into the two sides, in index order.
  const std::size_t middle = count / 2 / 4 * 4;
  std::vector<std::uint64_t> packed[2][2]; // [half][side]
  parallelFor(2, 2, [&](int half) {
    // Filled in the thread's own vectors: the shared array's neighbouring ends would bounce
    // one cache line between the threads at every point.
    std::vector<std::uint64_t> side[2];
    const std::size_t begin = half == 0 ? 0 : middle, end = half == 0 ? middle : count;
    side[0].reserve((end - begin) * 5 / 8);
    side[1].reserve((end - begin) * 5 / 8);
    std::uint64_t four[4];
    std::size_t i = begin;
    for (; i + 4 <= end; i += 4) {
      keys.packFour(i, four);
      for (const std::uint64_t v : four)
        side[(v >> 32) >= cut].push_back(v);
    }
    for (; i < end; ++i) {
      const std::uint64_t v = keys(i) << 32 | static_cast<std::uint64_t>(i);
      side[(v >> 32) >= cut].push_back(v);
    }
    packed[half][0] = std::move(side[0]);
    packed[half][1] = std::move(side[1]);
  });
  SourceSamples sides[2];
  parallelFor(2, 2, [&](int side) {
    std::vector<std::uint64_t> mine = std::move(packed[0][side]);
    mine.insert(mine.end(), packed[1][side].begin(), packed[1][side].end());
    SourceSamples summaries; // the thread's own, as above
    summariseRuns(points, SortedCells(std::move(mine), keys.bits()), summaries);
    sides[side] = std::move(summaries);
  });
  out.has_covariance = sides[0].has_covariance || sides[1].has_covariance;
  out.samples = std::move(sides[0].samples);
  out.samples.insert(out.samples.end(), sides[1].samples.begin(), sides[1].samples.end());
  return true;
}

/** makeSourceSamples() for \a points (non-empty) whose bounding box is [\a min, \a max], on
 * up to \a threads threads. */
SourceSamples
summariseCells(const PointList& points,
               double cell_size,
               const Eigen::Vector3f& min,
               const Eigen::Vector3f& max,
               int threads = 1)
{
  SourceSamples out;
  out.cell_size = cell_size;
  out.point_count = points.size();
  out.grid_origin = min;
  // Sort points by their cell (z slowest), then summarise runs of equal cells.
  const PointAt position_of{points};
  if (threads >= 2 && points.size() >= kSplitPoints &&
      summariseCellsOnTwoThreads(points, CellKeys<PointAt>(position_of, min, max, cell_size), out))
    return out;
  summariseRuns(points, sortedCellKeys(points.size(), position_of, min, max, cell_size), out);
  return out;
}

} // namespace

SourceSamples
makeSourceSamples(const PointList& points, double cell_size, const Box* box)
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
  const Box found = box ? *box : boundingBox(points);
  return summariseCells(points, cell_size, found.min, found.max);
}

std::vector<SourceSamples>
makeSourceSamplePyramid(const PointList& points,
                        double cell_size,
                        int coarser,
                        int threads,
                        const Box* box)
{
  std::vector<SourceSamples> pyramid;
  if (points.empty() || !(cell_size > 0.0)) {
    pyramid.push_back(makeSourceSamples(points, cell_size));
    return pyramid;
  }
  // One bounding box for every level: coarse cells nest fine ones from the same corner.
  const Box found = box ? *box : boundingBox(points);
  const Eigen::Vector3f &min = found.min, &max = found.max;
  pyramid.push_back(summariseCells(points, cell_size, min, max, threads));
  for (int k = 1; k <= coarser; ++k) {
    const SourceSamples& fine = pyramid.back();
    SourceSamples out;
    out.cell_size = fine.cell_size * 2.0;
    out.point_count = fine.point_count;
    out.grid_origin = min; // the same corner at every level: coarse cells nest fine ones
    // The same cells as makeSourceSamples at the coarser size, for the finer centroids.
    const SortedCells keyed = sortedCellKeys(
        fine.samples.size(),
        [&](std::size_t i) -> const Eigen::Vector3f& { return fine.samples[i].position; }, min,
        max, out.cell_size);
    for (std::size_t begin = 0; begin < keyed.size();) {
      std::size_t end = begin + 1;
      while (end < keyed.size() && keyed.key(end) == keyed.key(begin))
        ++end;
      // Merge by the parallel-axis rule, relative to the first centroid.
      const Eigen::Vector3d anchor = fine.samples[keyed.index(begin)].position.cast<double>();
      OffsetSums sums;
      for (std::size_t k2 = begin; k2 < end; ++k2) {
        const SourceSample& f = fine.samples[keyed.index(k2)];
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
