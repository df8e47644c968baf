/*
 * pcl_mi: the CPU backend's arithmetic pass: source samples moved into a target grid's
 * voxels, four at a time where SSE2 is there, with the OpenCL kernels' exact arithmetic.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "features/source_samples.h"
#include "features/voxel_grid.h"

#include <Eigen/Core>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace pcl_mi {
namespace backend {

/** \brief The samples of a source in columns (one array per coordinate and covariance
 * entry), so that four of them load as one vector. */
struct SampleColumns {
  std::vector<float> x, y, z;
  std::vector<float> covariance[6]; ///< xx, xy, xz, yy, yz, zz; empty without covariances

  explicit SampleColumns(const core::SourceSamples& source)
  {
    const std::size_t n = source.samples.size();
    x.resize(n);
    y.resize(n);
    z.resize(n);
    if (source.has_covariance)
      for (auto& c : covariance)
        c.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const core::SourceSample& s = source.samples[i];
      x[i] = s.position.x();
      y[i] = s.position.y();
      z[i] = s.position.z();
      if (source.has_covariance)
        for (int k = 0; k < 6; ++k)
          covariance[k][i] = s.covariance[k];
    }
  }
};

/** Samples per block: the block's voxel indices stay in L1 between the two passes. */
constexpr std::size_t kMovedBlock = 256;

/** \brief Where the samples of one block land: voxel indices clamped into the grid, whether
 * the sample lies inside it, its quantised height and its z variance in quantisation levels
 * squared (kernels/voxel_math.h). */
struct MovedBlock {
  alignas(16) std::int32_t ix[kMovedBlock];
  alignas(16) std::int32_t iy[kMovedBlock];
  alignas(16) std::int32_t iz[kMovedBlock];
  alignas(16) std::int32_t inside[kMovedBlock]; ///< all bits set where inside
  alignas(16) std::int32_t height[kMovedBlock];
  alignas(16) std::uint32_t variance[kMovedBlock];
};

/** \brief Moves samples [begin, end) of \a columns (at most kMovedBlock) by \a pose into the
 * grid of \a dims voxels, writing \a out from index 0 and widening the moved samples'
 * bounding box [\a min, \a max]. Every value is the one the scalar arithmetic of
 * kernels/voxel_math.h gives: the vector lanes round each operation alike, in the same
 * order, and no operation is fused. */
inline void
moveSamples(const core::GridPose& pose,
            const Eigen::Vector3i& dims,
            const SampleColumns& columns,
            std::size_t begin,
            std::size_t end,
            MovedBlock& out,
            Eigen::Vector3f& min,
            Eigen::Vector3f& max)
{
  const Eigen::Matrix3f& r = pose.rotation;
  const Eigen::Vector3f& t = pose.translation;
  const Eigen::Vector3f grid_end = dims.cast<float>();
  // The largest floats below the grid's end: inside samples clamp to themselves.
  const Eigen::Vector3f grid_last(std::nextafter(grid_end.x(), 0.0f),
                                  std::nextafter(grid_end.y(), 0.0f),
                                  std::nextafter(grid_end.z(), 0.0f));
  const bool has_covariance = !columns.covariance[0].empty();
  const float rx = pose.rotation_z.x(), ry = pose.rotation_z.y(), rz = pose.rotation_z.z();
  const float two_rz = 2.0f * rz, rz_rz = rz * rz;
  std::size_t i = begin;
#if defined(__SSE2__)
  const auto all = [](float v) { return _mm_set1_ps(v); };
  const __m128 r00 = all(r(0, 0)), r01 = all(r(0, 1)), r02 = all(r(0, 2)), t0 = all(t.x());
  const __m128 r10 = all(r(1, 0)), r11 = all(r(1, 1)), r12 = all(r(1, 2)), t1 = all(t.y());
  const __m128 r20 = all(r(2, 0)), r21 = all(r(2, 1)), r22 = all(r(2, 2)), t2 = all(t.z());
  const __m128 zero = _mm_setzero_ps();
  const __m128 end_x = all(grid_end.x()), end_y = all(grid_end.y()), end_z = all(grid_end.z());
  const __m128 last_x = all(grid_last.x()), last_y = all(grid_last.y()),
               last_z = all(grid_last.z());
  const __m128 levels = all(static_cast<float>(PCL_MI_HEIGHT_LEVELS));
  const __m128i top_level = _mm_set1_epi32(PCL_MI_HEIGHT_LEVELS - 1);
  const __m128 vrx = all(rx), vry = all(ry), vrz = all(rz), two = all(2.0f),
               vtwo_rz = all(two_rz), vrz_rz = all(rz_rz), scale = all(pose.variance_scale),
               half = all(0.5f);
  __m128 min_x = all(min.x()), min_y = all(min.y()), min_z = all(min.z());
  __m128 max_x = all(max.x()), max_y = all(max.y()), max_z = all(max.z());
  for (; i + 4 <= end; i += 4) {
    const std::size_t k = i - begin;
    const __m128 x = _mm_loadu_ps(&columns.x[i]);
    const __m128 y = _mm_loadu_ps(&columns.y[i]);
    const __m128 z = _mm_loadu_ps(&columns.z[i]);
    // ((r0 x + r1 y) + r2 z) + t, as pcl_mi_moved.
    const auto moved = [&](__m128 a, __m128 b, __m128 c, __m128 d) {
      return _mm_add_ps(
          _mm_add_ps(_mm_add_ps(_mm_mul_ps(a, x), _mm_mul_ps(b, y)), _mm_mul_ps(c, z)), d);
    };
    const __m128 fx = moved(r00, r01, r02, t0);
    const __m128 fy = moved(r10, r11, r12, t1);
    const __m128 fz = moved(r20, r21, r22, t2);
    min_x = _mm_min_ps(min_x, fx);
    min_y = _mm_min_ps(min_y, fy);
    min_z = _mm_min_ps(min_z, fz);
    max_x = _mm_max_ps(max_x, fx);
    max_y = _mm_max_ps(max_y, fy);
    max_z = _mm_max_ps(max_z, fz);
    const __m128 inside = _mm_and_ps(
        _mm_and_ps(_mm_and_ps(_mm_cmpge_ps(fx, zero), _mm_cmplt_ps(fx, end_x)),
                   _mm_and_ps(_mm_cmpge_ps(fy, zero), _mm_cmplt_ps(fy, end_y))),
        _mm_and_ps(_mm_cmpge_ps(fz, zero), _mm_cmplt_ps(fz, end_z)));
    const __m128 cz = _mm_min_ps(_mm_max_ps(fz, zero), last_z);
    const __m128i iz = _mm_cvttps_epi32(cz);
    _mm_store_si128(reinterpret_cast<__m128i*>(&out.ix[k]),
                    _mm_cvttps_epi32(_mm_min_ps(_mm_max_ps(fx, zero), last_x)));
    _mm_store_si128(reinterpret_cast<__m128i*>(&out.iy[k]),
                    _mm_cvttps_epi32(_mm_min_ps(_mm_max_ps(fy, zero), last_y)));
    _mm_store_si128(reinterpret_cast<__m128i*>(&out.iz[k]), iz);
    _mm_store_si128(reinterpret_cast<__m128i*>(&out.inside[k]), _mm_castps_si128(inside));
    // pcl_mi_quantise_height: (int)((z - iz) * levels), clamped to [0, levels - 1].
    __m128i q = _mm_cvttps_epi32(_mm_mul_ps(_mm_sub_ps(cz, _mm_cvtepi32_ps(iz)), levels));
    q = _mm_andnot_si128(_mm_cmplt_epi32(q, _mm_setzero_si128()), q);
    const __m128i over = _mm_cmpgt_epi32(q, top_level);
    q = _mm_or_si128(_mm_and_si128(over, top_level), _mm_andnot_si128(over, q));
    _mm_store_si128(reinterpret_cast<__m128i*>(&out.height[k]), q);
    if (!has_covariance)
      continue;
    // pcl_mi_variance_levels, term by term. Its values stay far below 2^31 (a sample's
    // cube is half a voxel), where the signed conversion equals the unsigned one.
    const auto c = [&](int j) { return _mm_loadu_ps(&columns.covariance[j][i]); };
    const __m128 variance = _mm_add_ps(
        _mm_add_ps(
            _mm_mul_ps(vrx, _mm_add_ps(_mm_mul_ps(vrx, c(0)),
                                       _mm_mul_ps(two, _mm_add_ps(_mm_mul_ps(vry, c(1)),
                                                                  _mm_mul_ps(vrz, c(2)))))),
            _mm_mul_ps(vry, _mm_add_ps(_mm_mul_ps(vry, c(3)), _mm_mul_ps(vtwo_rz, c(4))))),
        _mm_mul_ps(vrz_rz, c(5)));
    _mm_store_si128(
        reinterpret_cast<__m128i*>(&out.variance[k]),
        _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(_mm_max_ps(variance, zero), scale), half)));
  }
  alignas(16) float lanes[4];
  const auto lowest = [&](__m128 v) {
    _mm_store_ps(lanes, v);
    return std::min(std::min(lanes[0], lanes[1]), std::min(lanes[2], lanes[3]));
  };
  const auto highest = [&](__m128 v) {
    _mm_store_ps(lanes, v);
    return std::max(std::max(lanes[0], lanes[1]), std::max(lanes[2], lanes[3]));
  };
  min = Eigen::Vector3f(lowest(min_x), lowest(min_y), lowest(min_z));
  max = Eigen::Vector3f(highest(max_x), highest(max_y), highest(max_z));
#endif
  // The rest (and every sample without SSE2), one at a time.
  for (; i < end; ++i) {
    const std::size_t k = i - begin;
    const float px = columns.x[i], py = columns.y[i], pz = columns.z[i];
    const Eigen::Vector3f f(voxel::pcl_mi_moved(r(0, 0), r(0, 1), r(0, 2), t.x(), px, py, pz),
                            voxel::pcl_mi_moved(r(1, 0), r(1, 1), r(1, 2), t.y(), px, py, pz),
                            voxel::pcl_mi_moved(r(2, 0), r(2, 1), r(2, 2), t.z(), px, py, pz));
    min = min.cwiseMin(f);
    max = max.cwiseMax(f);
    const bool inside = (f.array() >= 0.0f).all() && (f.array() < grid_end.array()).all();
    const Eigen::Vector3f clamped = f.cwiseMax(0.0f).cwiseMin(grid_last);
    out.ix[k] = static_cast<int>(clamped.x());
    out.iy[k] = static_cast<int>(clamped.y());
    out.iz[k] = static_cast<int>(clamped.z());
    out.inside[k] = inside ? -1 : 0;
    out.height[k] = core::quantiseHeight(clamped.z(), out.iz[k]);
    if (has_covariance) {
      const float c[6] = {columns.covariance[0][i], columns.covariance[1][i],
                          columns.covariance[2][i], columns.covariance[3][i],
                          columns.covariance[4][i], columns.covariance[5][i]};
      out.variance[k] = voxel::pcl_mi_variance_levels(rx, ry, rz, c, pose.variance_scale);
    }
  }
}

} // namespace backend
} // namespace pcl_mi
