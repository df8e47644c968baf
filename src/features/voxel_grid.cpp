/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "features/voxel_grid.h"

#include "util/bounding_box.h"
#include "util/zeroed_array.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace pcl_mi {
namespace core {

namespace {


/** Points per block of buildTargetGrid(): their cells and heights stay in L1. */
constexpr std::size_t kCellBlock = 256;

/** The cells (index into \a g) and quantised in-voxel heights of \a count points. Four at
 * a time where SSE2 is there: the lanes round each operation as the scalar code does, in
 * the same order, so both give the same cells. Truncation, clamped to the grid, gives
 * floor()'s cells for every value: the two differ only below 0, where both clamp to 0. */
void
cellsOfPoints(const GridGeometry& g,
              const Eigen::Vector3f* points,
              std::size_t count,
              std::uint32_t* cells,
              int* heights)
{
  const float inv_res = 1.0f / g.resolution;
  std::size_t i = 0;
#if defined(__SSE2__)
  // Cell indices are below kMaxGridCells = 2^24, so float holds them and their partial
  // sums exactly.
  static_assert(kMaxGridCells <= (std::size_t{1} << 24), "cell indices must fit a float");
  const __m128 origin[3] = {_mm_set1_ps(g.origin.x()), _mm_set1_ps(g.origin.y()),
                            _mm_set1_ps(g.origin.z())};
  const __m128 inv = _mm_set1_ps(inv_res);
  const __m128i zero = _mm_setzero_si128();
  const __m128i last[3] = {_mm_set1_epi32(g.dims.x() - 1), _mm_set1_epi32(g.dims.y() - 1),
                           _mm_set1_epi32(g.dims.z() - 1)};
  const __m128i top_height = _mm_set1_epi32(kHeightLevels - 1);
  const __m128 row = _mm_set1_ps(static_cast<float>(g.dims.x()));
  const __m128 slice = _mm_set1_ps(static_cast<float>(g.dims.x()) * static_cast<float>(g.dims.y()));
  const __m128 levels = _mm_set1_ps(static_cast<float>(kHeightLevels));
  // min(max(v, 0), hi) lane by lane (SSE2 has no integer min or max).
  const auto clamp = [zero](__m128i v, __m128i hi) {
    v = _mm_and_si128(v, _mm_cmpgt_epi32(v, zero));
    const __m128i above = _mm_cmpgt_epi32(v, hi);
    return _mm_or_si128(_mm_and_si128(above, hi), _mm_andnot_si128(above, v));
  };
  for (; i + 4 <= count; i += 4) {
    const Eigen::Vector3f* p = points + i;
    __m128i index[3];
    __m128 f[3];
    for (int a = 0; a < 3; ++a) {
      const __m128 v = _mm_setr_ps(p[0][a], p[1][a], p[2][a], p[3][a]);
      f[a] = _mm_mul_ps(_mm_sub_ps(v, origin[a]), inv);
      index[a] = clamp(_mm_cvttps_epi32(f[a]), last[a]);
    }
    const __m128 cell = _mm_add_ps(
        _mm_add_ps(_mm_mul_ps(_mm_cvtepi32_ps(index[2]), slice),
                   _mm_mul_ps(_mm_cvtepi32_ps(index[1]), row)),
        _mm_cvtepi32_ps(index[0]));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(cells + i), _mm_cvttps_epi32(cell));
    const __m128 within = _mm_mul_ps(_mm_sub_ps(f[2], _mm_cvtepi32_ps(index[2])), levels);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(heights + i),
                     clamp(_mm_cvttps_epi32(within), top_height));
  }
#endif
  for (; i < count; ++i) {
    const Eigen::Vector3f f = (points[i] - g.origin) * inv_res;
    const int ix = std::min(std::max(static_cast<int>(f.x()), 0), g.dims.x() - 1);
    const int iy = std::min(std::max(static_cast<int>(f.y()), 0), g.dims.y() - 1);
    const int iz = std::min(std::max(static_cast<int>(f.z()), 0), g.dims.z() - 1);
    cells[i] = static_cast<std::uint32_t>(g.cellIndex(ix, iy, iz));
    heights[i] = quantiseHeight(f.z(), iz);
  }
}

} // namespace

bool
makeGridGeometry(const PointList& points,
                 double resolution,
                 GridGeometry& g,
                 std::string& error,
                 const Box* box)
{
  if (points.empty()) {
    error = "the target has no usable points";
    return false;
  }
  const Box found = box ? *box : boundingBox(points);
  const Eigen::Vector3f &min = found.min, &max = found.max;
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
                std::string& error,
                const Box* box)
{
  GridGeometry& g = grid.geometry;
  if (!makeGridGeometry(points, resolution, g, error, box))
    return false;
  grid.feature = feature;
  grid.binning = binning;

  // Only the occupied cells are visited after the pass over the points, in the order of
  // their index (z, then y, then x), which is the order of grid.occupied.
  ZeroedArray<VoxelMoments> moments(g.cellCount());
  std::vector<std::uint32_t> occupied_cells;
  // The cells and quantised heights a block at a time, then the moments point by point.
  std::uint32_t cells[kCellBlock];
  int heights[kCellBlock];
  for (std::size_t begin = 0; begin < points.size(); begin += kCellBlock) {
    const std::size_t count = std::min(kCellBlock, points.size() - begin);
    cellsOfPoints(g, points.data() + begin, count, cells, heights);
    for (std::size_t k = 0; k < count; ++k) {
      VoxelMoments& m = moments[cells[k]];
      if (m.count == 0)
        occupied_cells.push_back(cells[k]);
      m.add(heights[k]);
    }
  }
  std::sort(occupied_cells.begin(), occupied_cells.end());
  if (binning.range_quantile > 0.0) {
    std::vector<double> values;
    values.reserve(occupied_cells.size());
    for (const std::uint32_t cell : occupied_cells)
      values.push_back(featureValue(feature, moments[cell]));
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
  grid.occupied.reserve(occupied_cells.size());
  const std::size_t row = static_cast<std::size_t>(g.dims.x());
  const std::size_t slice = row * static_cast<std::size_t>(g.dims.y());
  const std::size_t rows = g.cellCount() / row;
  grid.row_starts.assign(rows + 1, 0);
  for (const std::uint32_t cell : occupied_cells) {
    const auto bin = static_cast<std::uint8_t>(voxelBin(feature, grid.binning, moments[cell]));
    grid.bins[cell] = bin;
    grid.occupied.push_back({cell, static_cast<std::int32_t>(cell % row),
                             static_cast<std::int32_t>(cell / row % g.dims.y()),
                             static_cast<std::int32_t>(cell / slice), bin});
    ++grid.row_starts[cell / row + 1];
  }
  for (std::size_t r = 0; r < rows; ++r)
    grid.row_starts[r + 1] += grid.row_starts[r];
  // Cleared, the moments' memory can serve the next grid as it is.
  for (const std::uint32_t cell : occupied_cells)
    moments[cell] = VoxelMoments{};
  moments.returnsZeroed();
  return true;
}

} // namespace core
} // namespace pcl_mi
