/*
 * pcl_mi: the axis-aligned bounding box of a list of points.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cstddef>
#include <vector>

#if defined(__SSE2__)
#include <xmmintrin.h>
#endif

namespace pcl_mi {
namespace core {

/** \brief Bounding box of the non-empty \a points: four lanes a point where SSE2 is there,
 * with two running bounds so that no point waits on the one before, else six scalars (with
 * Eigen vectors the compiler spilled one bound to the stack and every point waited on the
 * store). Minima and maxima are exact, so both paths give the same box (up to the sign of
 * a zero bound, which no cell index sees). */
inline void
boundingBox(const std::vector<Eigen::Vector3f>& points, Eigen::Vector3f& min, Eigen::Vector3f& max)
{
  static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "points are packed x, y, z");
  const float* xyz = points.front().data();
  const std::size_t count = points.size();
  std::size_t i = 0;
  float x0 = xyz[0], y0 = xyz[1], z0 = xyz[2];
  float x1 = x0, y1 = y0, z1 = z0;
#if defined(__SSE2__)
  if (count >= 3) {
    // Each load takes a point and the next one's x (lane 3, ignored); the loop stops while a
    // point remains after the pair, so no load reads past the last point.
    __m128 lo_even = _mm_loadu_ps(xyz), hi_even = lo_even, lo_odd = lo_even, hi_odd = lo_even;
    for (; i + 2 < count; i += 2) {
      const __m128 even = _mm_loadu_ps(xyz + 3 * i);
      const __m128 odd = _mm_loadu_ps(xyz + 3 * i + 3);
      lo_even = _mm_min_ps(even, lo_even);
      hi_even = _mm_max_ps(even, hi_even);
      lo_odd = _mm_min_ps(odd, lo_odd);
      hi_odd = _mm_max_ps(odd, hi_odd);
    }
    float lo[4], hi[4];
    _mm_storeu_ps(lo, _mm_min_ps(lo_odd, lo_even));
    _mm_storeu_ps(hi, _mm_max_ps(hi_odd, hi_even));
    x0 = lo[0], y0 = lo[1], z0 = lo[2];
    x1 = hi[0], y1 = hi[1], z1 = hi[2];
  }
#endif
  for (; i < count; ++i) {
    const float* p = xyz + 3 * i;
    x0 = std::min(x0, p[0]);
    y0 = std::min(y0, p[1]);
    z0 = std::min(z0, p[2]);
    x1 = std::max(x1, p[0]);
    y1 = std::max(y1, p[1]);
    z1 = std::max(z1, p[2]);
  }
  min = Eigen::Vector3f(x0, y0, z0);
  max = Eigen::Vector3f(x1, y1, z1);
}

/** \brief An axis-aligned box: its least and its greatest corner. */
struct Box {
  Eigen::Vector3f min = Eigen::Vector3f::Zero();
  Eigen::Vector3f max = Eigen::Vector3f::Zero();
};

/** \brief boundingBox() of the non-empty \a points as a Box. */
inline Box
boundingBox(const std::vector<Eigen::Vector3f>& points)
{
  Box box;
  boundingBox(points, box.min, box.max);
  return box;
}

} // namespace core
} // namespace pcl_mi
