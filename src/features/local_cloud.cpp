/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "features/local_cloud.h"

#include "util/bounding_box.h"
#include "util/parallel.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace pcl_mi {
namespace core {

namespace {

/** Values of one axis sampled for its median: the median only anchors the cells in
 * bulkRanges(), and a strided sample finds it without a selection over every point. */
constexpr std::size_t kMedianSamples = 4096;

/** Cells of half a gap on either side of the median that bulkRanges() looks at: points
 * further out (2048 gaps: 131 km at 1 m voxels) are outliers whatever lies between. */
constexpr long kHalfGapCells = 4096;

/** The cell of a run before its first point: one no point lies in (cell -1, where a point
 * just below the median lies, would take the empty run's 0 as its minimum or maximum). */
constexpr long kNoCell = std::numeric_limits<long>::min();

/** Per axis, the count, least and greatest value of the points in a cell of bulkRanges(). */
struct RangeCell {
  std::size_t count = 0;
  float min = 0.0f, max = 0.0f;
};

/** Cells per axis in bulkRanges(). */
constexpr std::size_t kRangeCells = 2 * kHalfGapCells + 1;

/** Adds the \a count points from \a first to \a cells: kRangeCells per axis, where cell k
 * holds the values v with floor((v - median) * inv_width) = k - kHalfGapCells. */
void
fillRangeCells(const Eigen::Vector3f* first,
               std::size_t count,
               const double median[3],
               double inv_width,
               RangeCell* cells)
{
  // Scans list their points in sweep order, so one cell usually takes long runs of
  // consecutive points: each axis gathers its current run in registers and writes it to the
  // cell when the run ends, instead of every point reading back the store of the one before.
  struct Run {
    long cell = kNoCell;
    std::size_t count = 0;
    float min = 0.0f, max = 0.0f;
  };
  Run runs[3];
  const auto flush = [&](int axis) {
    const Run& r = runs[axis];
    if (r.count == 0)
      return;
    RangeCell& c = cells[axis * kRangeCells + static_cast<std::size_t>(r.cell + kHalfGapCells)];
    c.min = c.count ? std::min(c.min, r.min) : r.min;
    c.max = c.count ? std::max(c.max, r.max) : r.max;
    c.count += r.count;
  };
  const auto add = [&](const Eigen::Vector3f& p) {
    for (int axis = 0; axis < 3; ++axis) {
      // floor(d) within [-kHalfGapCells, kHalfGapCells] exactly when d lies in
      // [-kHalfGapCells, kHalfGapCells + 1); inside it, truncation corrected below zero is
      // floor() without the library call that generic x86-64 code makes for it.
      const float v = p[axis];
      const double d = (v - median[axis]) * inv_width;
      if (!(d >= -static_cast<double>(kHalfGapCells) && d < kHalfGapCells + 1.0))
        continue;
      long k = static_cast<long>(d);
      k -= static_cast<double>(k) > d;
      Run& r = runs[axis];
      if (k != r.cell) {
        flush(axis);
        r = {k, 0, v, v};
      }
      r.min = std::min(r.min, v);
      r.max = std::max(r.max, v);
      ++r.count;
    }
  };
  std::size_t i = 0;
#if defined(__SSE2__)
  // Most blocks of four consecutive points lie in their runs' cells on every axis. Such a
  // block joins the runs at once: d is computed two points at a time as add() computes it,
  // and lies in run cell k exactly when k <= d < k + 1 (no point is in kNoCell). Any other
  // block goes point by point. The runs' minima and maxima are the same values either way.
  const __m128d scale = _mm_set1_pd(inv_width);
  const auto inRun = [](__m128d d, __m128d cell, __m128d next) {
    return _mm_and_pd(_mm_cmple_pd(cell, d), _mm_cmplt_pd(d, next));
  };
  for (; i + 4 <= count; i += 4) {
    const Eigen::Vector3f* p = first + i;
    __m128 values[3];
    bool joined = true;
    for (int axis = 0; axis < 3 && joined; ++axis) {
      const __m128 v = _mm_setr_ps(p[0][axis], p[1][axis], p[2][axis], p[3][axis]);
      const __m128d centre = _mm_set1_pd(median[axis]);
      const double run = static_cast<double>(runs[axis].cell);
      const __m128d cell = _mm_set1_pd(run), next = _mm_set1_pd(run + 1.0);
      const __m128d d01 = _mm_mul_pd(_mm_sub_pd(_mm_cvtps_pd(v), centre), scale);
      const __m128d d23 = _mm_mul_pd(_mm_sub_pd(_mm_cvtps_pd(_mm_movehl_ps(v, v)), centre), scale);
      joined = _mm_movemask_pd(_mm_and_pd(inRun(d01, cell, next), inRun(d23, cell, next))) == 3;
      values[axis] = v;
    }
    if (!joined) {
      for (int k = 0; k < 4; ++k)
        add(p[k]);
      continue;
    }
    for (int axis = 0; axis < 3; ++axis) {
      const __m128 v = values[axis];
      const __m128 low = _mm_min_ps(v, _mm_movehl_ps(v, v));
      const __m128 high = _mm_max_ps(v, _mm_movehl_ps(v, v));
      Run& r = runs[axis];
      r.min = std::min(r.min, _mm_cvtss_f32(_mm_min_ss(low, _mm_shuffle_ps(low, low, 1))));
      r.max = std::max(r.max, _mm_cvtss_f32(_mm_max_ss(high, _mm_shuffle_ps(high, high, 1))));
      r.count += 4;
    }
  }
#endif
  for (; i < count; ++i)
    add(first[i]);
  for (int axis = 0; axis < 3; ++axis)
    flush(axis);
}

/** Per axis, [low, high]: the values of the largest group of \a points, where groups are
 * split wherever two consecutive values (in sorted order) are at least \a gap apart.
 * Exact without sorting: values are put in cells of half a gap, which keep their count,
 * minimum and maximum; values in the same or neighbouring cells are less than a gap apart,
 * and across empty cells the gap is the next cell's minimum minus the last one's maximum.
 * The three axes share one pass, so that their updates of the few cells most points fall
 * into do not wait on one another. */
void
bulkRanges(const PointList& points, double gap, Eigen::Vector3d& low, Eigen::Vector3d& high)
{
  const std::size_t stride = std::max<std::size_t>(1, points.size() / kMedianSamples);
  double median[3];
  std::vector<float> sample;
  sample.reserve(points.size() / stride + 1);
  for (int axis = 0; axis < 3; ++axis) {
    sample.clear();
    for (std::size_t i = 0; i < points.size(); i += stride)
      sample.push_back(points[i][axis]);
    auto mid = sample.begin() + sample.size() / 2;
    std::nth_element(sample.begin(), mid, sample.end());
    median[axis] = *mid;
  }
  std::vector<RangeCell> cells(3 * kRangeCells);
  fillRangeCells(points.data(), points.size(), median, 2.0 / gap, cells.data());
  for (int axis = 0; axis < 3; ++axis) {
    // The groups in order; the first of equally large ones wins.
    std::size_t best = 0, current = 0;
    double group_low = 0.0, last_max = 0.0;
    low[axis] = high[axis] = median[axis];
    for (std::size_t i = 0; i < kRangeCells; ++i) {
      const RangeCell& c = cells[axis * kRangeCells + i];
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
        low[axis] = group_low;
        high[axis] = last_max;
      }
    }
  }
}

/** Moves the points of \a points within [low, high] to its front, in order; returns how many
 * and, in \a sum, their sum in double. A function of its own so that the three sums stay
 * in registers: inlined into makeLocalCloud(), they lived in memory, and every point
 * waited on the store of the one before. */
__attribute__((noinline)) std::size_t
keepWithin(PointList& points,
           const Eigen::Vector3f& low,
           const Eigen::Vector3f& high,
           Eigen::Vector3d& sum)
{
  double x = 0.0, y = 0.0, z = 0.0;
  std::size_t count = 0;
  for (const auto& p : points) {
    if ((p.array() < low.array()).any() || (p.array() > high.array()).any())
      continue;
    points[count++] = p;
    x += p.x();
    y += p.y();
    z += p.z();
  }
  sum = Eigen::Vector3d(x, y, z);
  return count;
}

/** Moves the points of \a cloud to their centroid (cloud.centroid, input frame) and sets
 * their RMS radius, covariance and box, in one pass. Two points at a time in double lanes
 * where SSE2 is there: each point's local coordinates round as the scalar code's do, and
 * only the order of the sums differs (as scalars, every point waited on the sums of the one
 * before). The box is that of the stored float coordinates, as boundingBox() finds it. */
__attribute__((noinline)) void
centreAndScatter(LocalCloud& cloud)
{
  PointList& points = cloud.points;
  const std::size_t count = points.size();
  const Eigen::Vector3d& c = cloud.centroid;
  double squared = 0.0;
  double xx = 0.0, xy = 0.0, xz = 0.0, yy = 0.0, yz = 0.0, zz = 0.0;
  Eigen::Vector3d low = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d high = -low;
  std::size_t i = 0;
#if defined(__SSE2__)
  if (count >= 2) {
    const __m128d cx = _mm_set1_pd(c.x()), cy = _mm_set1_pd(c.y()), cz = _mm_set1_pd(c.z());
    __m128d sq = _mm_setzero_pd(), sxx = sq, sxy = sq, sxz = sq, syy = sq, syz = sq, szz = sq;
    __m128d lx = _mm_set1_pd(low.x()), ly = lx, lz = lx;
    __m128d hx = _mm_set1_pd(high.x()), hy = hx, hz = hx;
    float* xyz = points.front().data();
    for (; i + 2 <= count; i += 2) {
      float* a = xyz + 3 * i; // this point at a[0..2], the next at a[3..5]
      const __m128d dx = _mm_sub_pd(_mm_setr_pd(a[0], a[3]), cx);
      const __m128d dy = _mm_sub_pd(_mm_setr_pd(a[1], a[4]), cy);
      const __m128d dz = _mm_sub_pd(_mm_setr_pd(a[2], a[5]), cz);
      sq = _mm_add_pd(sq, _mm_add_pd(_mm_add_pd(_mm_mul_pd(dx, dx), _mm_mul_pd(dy, dy)),
                                     _mm_mul_pd(dz, dz)));
      const __m128 fx = _mm_cvtpd_ps(dx), fy = _mm_cvtpd_ps(dy), fz = _mm_cvtpd_ps(dz);
      a[0] = _mm_cvtss_f32(fx);
      a[1] = _mm_cvtss_f32(fy);
      a[2] = _mm_cvtss_f32(fz);
      a[3] = _mm_cvtss_f32(_mm_shuffle_ps(fx, fx, 1));
      a[4] = _mm_cvtss_f32(_mm_shuffle_ps(fy, fy, 1));
      a[5] = _mm_cvtss_f32(_mm_shuffle_ps(fz, fz, 1));
      const __m128d x = _mm_cvtps_pd(fx), y = _mm_cvtps_pd(fy), z = _mm_cvtps_pd(fz);
      sxx = _mm_add_pd(sxx, _mm_mul_pd(x, x));
      sxy = _mm_add_pd(sxy, _mm_mul_pd(x, y));
      sxz = _mm_add_pd(sxz, _mm_mul_pd(x, z));
      syy = _mm_add_pd(syy, _mm_mul_pd(y, y));
      syz = _mm_add_pd(syz, _mm_mul_pd(y, z));
      szz = _mm_add_pd(szz, _mm_mul_pd(z, z));
      lx = _mm_min_pd(lx, x);
      ly = _mm_min_pd(ly, y);
      lz = _mm_min_pd(lz, z);
      hx = _mm_max_pd(hx, x);
      hy = _mm_max_pd(hy, y);
      hz = _mm_max_pd(hz, z);
    }
    const auto sum = [](__m128d v) {
      return _mm_cvtsd_f64(_mm_add_sd(v, _mm_unpackhi_pd(v, v)));
    };
    const auto least = [](__m128d v) {
      return _mm_cvtsd_f64(_mm_min_sd(v, _mm_unpackhi_pd(v, v)));
    };
    const auto greatest = [](__m128d v) {
      return _mm_cvtsd_f64(_mm_max_sd(v, _mm_unpackhi_pd(v, v)));
    };
    squared = sum(sq);
    xx = sum(sxx), xy = sum(sxy), xz = sum(sxz), yy = sum(syy), yz = sum(syz), zz = sum(szz);
    low = Eigen::Vector3d(least(lx), least(ly), least(lz));
    high = Eigen::Vector3d(greatest(hx), greatest(hy), greatest(hz));
  }
#endif
  for (; i < count; ++i) {
    Eigen::Vector3f& p = points[i];
    const Eigen::Vector3d local = p.cast<double>() - c;
    squared += local.squaredNorm();
    p = local.cast<float>();
    const double x = p.x(), y = p.y(), z = p.z();
    xx += x * x;
    xy += x * y;
    xz += x * z;
    yy += y * y;
    yz += y * z;
    zz += z * z;
    low = low.cwiseMin(Eigen::Vector3d(x, y, z));
    high = high.cwiseMax(Eigen::Vector3d(x, y, z));
  }
  const double n = static_cast<double>(count);
  cloud.rms_radius = std::sqrt(squared / n);
  cloud.box.min = low.cast<float>();
  cloud.box.max = high.cast<float>();
  cloud.covariance << xx, xy, xz, xy, yy, yz, xz, yz, zz;
  cloud.covariance /= n;
}

/** Points below which makeLocalCloud() reads its input on one thread whatever it is given:
 * a split costs a few microseconds. */
constexpr std::size_t kTwoPartPoints = 16384;

/** A bound on atanUnit()'s error in radians, several times the largest one a dense sweep of
 * angles finds (docs/benchmarks.md, "Speed, tenth step"). */
constexpr double kAtanError = 1e-4;

/** atan(t) for t in [0, 1], within kAtanError: a fifth-order odd polynomial (Abramowitz and
 * Stegun 4.4.49), cheaper than std::atan2. */
double
atanUnit(double t)
{
  const double s = t * t;
  return t * (0.9998660 + s * (-0.3302995 + s * (0.1801410 + s * (-0.0851330 + s * 0.0208351))));
}

/** (atan2(y, x) + pi) in units of 2 pi / \a sectors: the polynomial where it lies clearly
 * inside a sector, std::atan2 within kAtanError of a sector's edge (and at the origin), so
 * that every point lands in the sector std::atan2 gives it. */
double
sectorOf(double x, double y, int sectors)
{
  const double per_radian = sectors / (2.0 * M_PI);
  const double ax = std::fabs(x), ay = std::fabs(y);
  const double longer = std::max(ax, ay);
  if (longer > 0.0) {
    double a = atanUnit(std::min(ax, ay) / longer);
    if (ay > ax)
      a = M_PI_2 - a;
    if (x < 0.0)
      a = M_PI - a;
    const double sector = ((y < 0.0 ? -a : a) + M_PI) * per_radian;
    if (std::fabs(sector - std::round(sector)) > kAtanError * per_radian)
      return sector;
  }
  return (std::atan2(y, x) + M_PI) * per_radian;
}

} // namespace

LocalCloud
makeLocalCloud(const PointView& points, double outlier_gap, int threads)
{
  LocalCloud cloud;
  makeLocalCloud(points, outlier_gap, threads, cloud);
  return cloud;
}

void
makeLocalCloud(const PointView& points, double outlier_gap, int threads, LocalCloud& cloud)
{
  // Built in place in the output, without an intermediate copy: clouds of tens of millions
  // of points are worth 12 bytes a point.
  PointList storage = std::move(cloud.points);
  if (storage.capacity() > 2 * points.size())
    PointList().swap(storage);
  cloud = LocalCloud();
  cloud.points = std::move(storage);
  PointList& kept = cloud.points;
  // Many drivers write a beam without a return as (0, 0, 0) rather than NaN. Piled into the
  // voxel at the sensor, they make a feature that agrees wherever the two sensors' piles
  // meet, which outscores the true alignment (docs/method.md).
  const auto usable = [](const Eigen::Vector3f& p) {
    return p.allFinite() && !(p.x() == 0.0f && p.y() == 0.0f && p.z() == 0.0f);
  };
  // The usable points in order: on two threads, each half of the input is read into the
  // front of its own half of the output, and the second half's points then move down
  // behind the first's.
  const int parts = threads > 1 && points.size() >= kTwoPartPoints ? 2 : 1;
  const std::size_t half = parts == 2 ? points.size() / 2 : points.size();
  kept.resize(points.size());
  std::size_t finite_in[2] = {0, 0}, usable_in[2] = {0, 0};
  parallelFor(parts, parts, [&](int part) {
    const std::size_t begin = part == 0 ? 0 : half;
    const std::size_t end = part == 0 ? half : points.size();
    Eigen::Vector3f* out = kept.data() + begin;
    std::size_t finite = 0, count = 0;
    for (std::size_t i = begin; i < end; ++i) {
      const Eigen::Vector3f p = points[i];
      finite += p.allFinite();
      if (usable(p))
        out[count++] = p;
    }
    finite_in[part] = finite;
    usable_in[part] = count;
  });
  std::copy(kept.begin() + static_cast<std::ptrdiff_t>(half),
            kept.begin() + static_cast<std::ptrdiff_t>(half + usable_in[1]),
            kept.begin() + static_cast<std::ptrdiff_t>(usable_in[0]));
  const std::size_t finite = finite_in[0] + finite_in[1];
  const std::size_t kept_count = usable_in[0] + usable_in[1];
  kept.resize(kept_count);
  cloud.non_finite = points.size() - finite;
  cloud.no_return = finite - kept_count;
  if (kept_count == 0)
    return;

  Eigen::Vector3d low, high;
  bulkRanges(kept, outlier_gap, low, high);

  // The ranges' ends are point coordinates, so comparing in float is exact.
  Eigen::Vector3d sum;
  const std::size_t count = keepWithin(kept, low.cast<float>(), high.cast<float>(), sum);
  cloud.outliers = kept_count - count;
  kept.resize(count);
  // Measured in the input frame, before re-centring, since the sensor sits at its origin.
  cloud.azimuth_coverage_deg = azimuthCoverageDegrees(kept);
  cloud.centroid = sum / static_cast<double>(count);
  centreAndScatter(cloud);
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
    const double sector = sectorOf(p.x(), p.y(), kSectors);
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

} // namespace core
} // namespace pcl_mi
