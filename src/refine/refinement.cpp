/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "refine/refinement.h"

#include "util/left_increment.h"
#include "util/parallel.h"
#include "util/prefetch.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>

namespace pcl_mi {
namespace core {

namespace {

/** 21 bits per axis: cubes further than 2^21 cells from the origin never match. */
constexpr int kKeyBits = 21;
constexpr std::int64_t kKeyLimit = std::int64_t{1} << kKeyBits;

/** Hash key of cell (x, y, z); each coordinate in [0, kKeyLimit). */
std::uint64_t
packCell(std::uint64_t x, std::uint64_t y, std::uint64_t z)
{
  return (z << (2 * kKeyBits)) | (y << kKeyBits) | x;
}

std::uint64_t
mix(std::uint64_t key)
{
  // A multiply by 2^64 / golden ratio, folded so the low bits see the high ones.
  key *= 0x9E3779B97F4A7C15ULL;
  return key ^ (key >> 32);
}

/** Cosine above which two successive steps count as the same direction. */
constexpr double kSameDirection = 0.9;
/** Largest extrapolation factor (a ratio of 0.75 between successive steps). */
constexpr double kMaxExtrapolation = 4.0;
/** Steps shrinking more slowly than this are not converging geometrically. */
constexpr double kMaxRatio = 0.95;

/** Factor for \a step given the previous one: 1 / (1 - ratio) when both point the same
 * way and shrink by that ratio, else 1; rotations count at \a lever_arm. */
double
extrapolation(const Eigen::Matrix<double, 6, 1>& step,
              const Eigen::Matrix<double, 6, 1>& previous,
              double lever_arm)
{
  Eigen::Matrix<double, 6, 1> a = step, b = previous;
  a.head<3>() *= lever_arm;
  b.head<3>() *= lever_arm;
  const double na = a.norm(), nb = b.norm();
  if (!(na > 0.0) || !(nb > 0.0) || a.dot(b) < kSameDirection * na * nb)
    return 1.0;
  const double ratio = na / nb;
  return ratio < kMaxRatio ? std::min(kMaxExtrapolation, 1.0 / (1.0 - ratio)) : 1.0;
}

/** A cube whose points spread across their main direction less than this fraction of the
 * spread along it (ratio of the two larger principal standard deviations) is a strip: one or
 * two scan lines of a sparse scanner, whose fitted plane follows the laser's cone and the
 * lines' calibration offsets rather than the surface, and pulls roll and pitch towards zero
 * relative motion. */
constexpr double kStripSpreadRatio = 0.5;

/** Principal variances (ascending) and axes of \a c, in double: closed form, cheap enough for
 * every cube and exact enough for the near-degenerate covariances of planes and lines. */
Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>
principalAxes(const Eigen::Matrix3d& c)
{
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(c);
  return solver;
}

/** The covariance with principal \a axes and \a variances (ascending), the two larger raised
 * to at least \a floor (the smallest, across the surface, is kept). */
Eigen::Matrix3d
flattenedCovariance(const Eigen::Matrix3d& axes, Eigen::Vector3d variances, double floor)
{
  variances[1] = std::max(variances[1], floor);
  variances[2] = std::max(variances[2], floor);
  return axes * variances.asDiagonal() * axes.transpose();
}

Eigen::Matrix3d
covarianceOf(const SourceSample& s)
{
  Eigen::Matrix3d c;
  c << s.covariance[0], s.covariance[1], s.covariance[2], //
      s.covariance[1], s.covariance[3], s.covariance[4],  //
      s.covariance[2], s.covariance[4], s.covariance[5];
  return c;
}

/** Open-addressing hash table of (key + 1, index); key + 1 == 0 marks an empty slot. */
using Slots = std::vector<std::pair<std::uint64_t, std::int32_t>>;

std::uint64_t
makeSlots(Slots& slots, std::size_t entries)
{
  std::size_t capacity = 16;
  while (capacity < 2 * entries)
    capacity *= 2;
  slots.assign(capacity, {0, -1});
  return capacity - 1;
}

/** The slot where the probes for \a key start. */
std::uint64_t
firstSlot(std::uint64_t mask, std::uint64_t key)
{
  return mix(key + 1) & mask;
}

void
insertSlot(Slots& slots, std::uint64_t mask, std::uint64_t key, std::int32_t index)
{
  for (std::uint64_t slot = firstSlot(mask, key);; slot = (slot + 1) & mask)
    if (slots[slot].first == 0) {
      slots[slot] = {key + 1, index};
      return;
    }
}

/** The index stored for \a key, probing from its first slot \a slot; -1 if none. */
int
findSlotFrom(const Slots& slots, std::uint64_t mask, std::uint64_t key, std::uint64_t slot)
{
  for (;; slot = (slot + 1) & mask) {
    if (slots[slot].first == key + 1)
      return slots[slot].second;
    if (slots[slot].first == 0)
      return -1;
  }
}

int
findSlot(const Slots& slots, std::uint64_t mask, std::uint64_t key)
{
  return findSlotFrom(slots, mask, key, firstSlot(mask, key));
}

/** Hash key of the cube of edge 1 / \a inv_cell from \a origin that holds \a p; 0 and
 * \a inside false where the cube lies beyond the keys' reach. */
std::uint64_t
cellKey(const Eigen::Vector3f& p, const Eigen::Vector3f& origin, float inv_cell, bool& inside)
{
  const Eigen::Vector3f c = cellCoordinates(p, origin, inv_cell);
  inside = (c.array() >= 0.0f).all() && (c.array() < static_cast<float>(kKeyLimit)).all();
  if (!inside)
    return 0;
  return packCell(static_cast<std::uint64_t>(c.x()), static_cast<std::uint64_t>(c.y()),
                  static_cast<std::uint64_t>(c.z()));
}

/** The 3x3x3 neighbourhoods of cells, found by the keys of their summaries' cells.
 * makeSourceSamples() lists the cells in the order of their keys (z, then y, then x), and a
 * summary's mean lies in its own cell. Then, for cells visited in that order, each row of
 * the neighbourhood is found by a cursor that only moves forward through the keys: nine
 * cursors read the keys once in sequence, where looking each neighbour up in a hash table
 * waits on a random read. Cells listed otherwise (keys that do not rise strictly) are looked
 * up in a hash table of every key; both find the same cells. */
class CellNeighbours {
public:
  CellNeighbours(const SourceSamples& cells, float inv_cell)
  : cells_(cells), inv_cell_(inv_cell)
  {
    keys_.reserve(cells.samples.size());
    bool rising = true;
    for (const SourceSample& s : cells.samples) {
      bool inside = false;
      const std::uint64_t key = cellKey(s.position, cells.grid_origin, inv_cell, inside);
      rising = rising && inside && (keys_.empty() || key > keys_.back());
      keys_.push_back(inside ? key : kOutside);
    }
    if (rising)
      return;
    mask_ = makeSlots(slots_, keys_.size());
    for (std::size_t i = 0; i < keys_.size(); ++i)
      if (keys_[i] != kOutside)
        insertSlot(slots_, mask_, keys_[i], static_cast<std::int32_t>(i));
  }

  /** Calls \a visit(sample) for each cell of the 3x3x3 cells around sample \a i's (its own
   * included), in the order z, then y, then x. Where the keys rise, \a i must not fall from
   * one call to the next. */
  template <typename Visit>
  void
  forEach(std::size_t i, const Visit& visit)
  {
    const Eigen::Vector3i cell =
        cellCoordinates(cells_.samples[i].position, cells_.grid_origin, inv_cell_).cast<int>();
    const auto valid = [](int v) { return v >= 0 && v < static_cast<int>(kKeyLimit); };
    const auto key = [](int x, int y, int z) {
      return packCell(static_cast<std::uint64_t>(x), static_cast<std::uint64_t>(y),
                      static_cast<std::uint64_t>(z));
    };
    std::size_t* cursor = cursors_;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy, ++cursor) {
        const int y = cell.y() + dy, z = cell.z() + dz;
        if (!valid(y) || !valid(z))
          continue;
        if (slots_.empty()) {
          // The row's cells from the first key at or after its first neighbour's.
          std::size_t& at = *cursor;
          const std::uint64_t first = key(std::max(cell.x() - 1, 0), y, z);
          while (at < keys_.size() && keys_[at] < first)
            ++at;
          const std::uint64_t last = key(std::min(cell.x() + 1, kLastKeyCell), y, z);
          for (std::size_t q = at; q < keys_.size() && keys_[q] <= last; ++q)
            visit(cells_.samples[q]);
          continue;
        }
        for (int dx = -1; dx <= 1; ++dx) {
          const int x = cell.x() + dx;
          const int index = valid(x) ? findSlot(slots_, mask_, key(x, y, z)) : -1;
          if (index >= 0)
            visit(cells_.samples[static_cast<std::size_t>(index)]);
        }
      }
  }

private:
  /** The key of a summary outside the keys' reach: never looked up, never found. */
  static constexpr std::uint64_t kOutside = ~std::uint64_t{0};
  /** The last cell of an axis that a key holds. */
  static constexpr int kLastKeyCell = static_cast<int>(kKeyLimit) - 1;

  const SourceSamples& cells_;
  float inv_cell_;
  std::vector<std::uint64_t> keys_;
  Slots slots_; // empty where the keys rise
  std::uint64_t mask_ = 0;
  std::size_t cursors_[9] = {};
};

/** Covariance of the points of the 3x3x3 cells around sample \a i's (cell moments pooled). */
Eigen::Matrix3d
neighbourhoodCovariance(const SourceSamples& cells, CellNeighbours& neighbours, std::size_t i)
{
  // Moments about the centre cube's mean, which keeps the sums well conditioned.
  const SourceSample& centre = cells.samples[i];
  double count = 0.0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  neighbours.forEach(i, [&](const SourceSample& o) {
    const double w = o.count;
    const Eigen::Vector3d d = (o.position - centre.position).cast<double>();
    count += w;
    sum += w * d;
    second += w * (covarianceOf(o) + d * d.transpose());
  });
  const Eigen::Vector3d mean = sum / count;
  return second / count - mean * mean.transpose();
}

} // namespace

std::uint64_t
TargetDistributions::keyOf(const Eigen::Vector3f& p, bool& inside) const
{
  return cellKey(p, origin_, inv_cell_, inside);
}

TargetDistributions::TargetDistributions(const PointList& points,
                                         double cell_size,
                                         int min_points,
                                         double noise_sigma)
: TargetDistributions(makeSourceSamples(points, cell_size), min_points, noise_sigma)
{}

TargetDistributions::TargetDistributions(const SourceSamples& cells,
                                         int min_points,
                                         double noise_sigma,
                                         const AxesVisitor& on_axes)
: cell_size_(cells.cell_size),
  inv_cell_(static_cast<float>(1.0 / cells.cell_size)),
  origin_(cells.grid_origin)
{
  if (cells.samples.empty())
    return;
  // The cubes are makeSourceSamples' cells: its per-cell centroid and covariance are exactly
  // the statistics needed here, and its grid origin is where keyOf() must start.
  const double cell_size = cell_size_;

  // Every cell, sparse ones included: the neighbourhood of a strip pools them all.
  CellNeighbours neighbours(cells, inv_cell_);

  const float noise = static_cast<float>(noise_sigma * noise_sigma);
  const double in_surface_floor = 0.25 * cell_size * cell_size;
  const double strip_variance_ratio = kStripSpreadRatio * kStripSpreadRatio;
  for (std::size_t i = 0; i < cells.samples.size(); ++i) {
    const SourceSample& s = cells.samples[i];
    if (s.count < static_cast<std::uint32_t>(std::max(min_points, 1)))
      continue;
    const Eigen::Matrix3d c = covarianceOf(s);
    const auto own = principalAxes(c);
    if (on_axes)
      on_axes(i, own);
    const Eigen::Vector3d& spread = own.eigenvalues();
    Eigen::Matrix3d flattened;
    Eigen::Vector3d normal = own.eigenvectors().col(0);
    bool pooled_normal = false;
    if (spread[1] < strip_variance_ratio * spread[2]) {
      // A strip fixes no plane. Take the orientation of the points of its 3x3x3 cubes,
      // which span more scan lines, when those are less strip-like than the cube itself,
      // and keep the cube's own spread along the pooled normal.
      const auto pooled = principalAxes(neighbourhoodCovariance(cells, neighbours, i));
      const Eigen::Vector3d& pooled_spread = pooled.eigenvalues();
      if (pooled_spread[1] * spread[2] > spread[1] * pooled_spread[2]) {
        normal = pooled.eigenvectors().col(0);
        const Eigen::Matrix3d across = normal * normal.transpose();
        flattened = across * normal.dot(c * normal) +
                    (Eigen::Matrix3d::Identity() - across) * std::max(spread[2], in_surface_floor);
        pooled_normal = true;
      }
    }
    if (!pooled_normal)
      flattened = flattenedCovariance(own.eigenvectors(), spread, in_surface_floor);
    Eigen::Matrix3f covariance = flattened.cast<float>();
    covariance.diagonal().array() += noise;
    distributions_.push_back({s.position, covariance.inverse(), normal.cast<float>(), s.count});
  }
  mask_ = makeSlots(table_, distributions_.size());
  for (std::size_t i = 0; i < distributions_.size(); ++i) {
    bool inside = false;
    insertSlot(table_, mask_, keyOf(distributions_[i].mean, inside),
               static_cast<std::int32_t>(i));
  }
}

int
TargetDistributions::find(const Eigen::Vector3f& p) const
{
  if (distributions_.empty())
    return -1;
  bool inside = false;
  const std::uint64_t key = keyOf(p, inside);
  return inside ? findSlot(table_, mask_, key) : -1;
}

void
TargetDistributions::findBlock(const Eigen::Vector3f* points,
                               std::size_t count,
                               std::int32_t* indices) const
{
  constexpr std::uint64_t kOutside = ~std::uint64_t{0};
  std::uint64_t keys[kFindBlock];
  std::uint64_t slots[kFindBlock];
  count = std::min(count, kFindBlock);
  if (distributions_.empty()) {
    std::fill(indices, indices + count, -1);
    return;
  }
  // First every key and its first slot, asking for the slot's line; then the probes, which
  // find those lines arrived, asking for the distributions' lines in turn.
  for (std::size_t k = 0; k < count; ++k) {
    bool inside = false;
    keys[k] = keyOf(points[k], inside);
    slots[k] = inside ? firstSlot(mask_, keys[k]) : kOutside;
    if (inside)
      prefetch(&table_[slots[k]]);
  }
  for (std::size_t k = 0; k < count; ++k) {
    indices[k] = slots[k] == kOutside ? -1 : findSlotFrom(table_, mask_, keys[k], slots[k]);
    if (indices[k] < 0)
      continue;
    // A distribution may straddle two lines.
    const char* first = reinterpret_cast<const char*>(&distributions_[indices[k]]);
    prefetch(first);
    prefetch(first + sizeof(Distribution) - 1);
  }
}

RefinementResult
refineToDistributions(const TargetDistributions& target,
                      const SourceSamples& source,
                      const Eigen::Matrix3d& rotation,
                      const Eigen::Vector3d& translation,
                      const RefinementOptions& options)
{
  RefinementResult result;
  result.rotation = rotation;
  result.translation = translation;
  using Matrix6d = Eigen::Matrix<double, 6, 6>;
  using Vector6d = Eigen::Matrix<double, 6, 1>;
  const float c2 = static_cast<float>(options.kernel_scale * options.kernel_scale);
  // A fixed number of chunks, summed in order, whatever the thread count.
  constexpr int kChunks = 8;
  struct Partial {
    // Float within a chunk of a few thousand samples is ample for Gauss-Newton steps.
    Eigen::Matrix<float, 6, 6> h;
    Eigen::Matrix<float, 6, 1> g;
    std::size_t matched;
  };
  std::vector<Partial> partials(kChunks);
  const std::size_t n = source.samples.size();
  Vector6d previous_step = Vector6d::Zero();
  for (int it = 0; it < options.max_iterations; ++it) {
    const Eigen::Matrix3f r = result.rotation.cast<float>();
    const Eigen::Vector3f t = result.translation.cast<float>();
    parallelFor(kChunks, options.num_threads, [&](int chunk) {
      // The sums in locals, not in the shared partials: the compiler may then keep them in
      // registers instead of storing and reloading them for every sample.
      Eigen::Matrix<float, 6, 6> h = Eigen::Matrix<float, 6, 6>::Zero();
      Eigen::Matrix<float, 6, 1> g = Eigen::Matrix<float, 6, 1>::Zero();
      std::size_t matched = 0;
      visitInCubes(target, source, r, t, n * chunk / kChunks, n * (chunk + 1) / kChunks, 1,
                   [&](const Eigen::Vector3f& q, int k) {
                     if (k < 0)
                       return;
                     const TargetDistributions::Distribution& dist = target[k];
                     const Eigen::Vector3f e = q - dist.mean;
                     const Eigen::Matrix3f& info = dist.information;
                     const float m = e.dot(info * e);
                     // Cauchy weight: residuals far beyond the kernel scale barely pull.
                     const float w = 1.0f / (1.0f + m / c2);
                     addToNormalEquations(q, e, info, w, h, g);
                     ++matched;
                   });
      // addToNormalEquations() leaves the lower left block to the caller.
      h.bottomLeftCorner<3, 3>() = h.topRightCorner<3, 3>().transpose();
      Partial& p = partials[static_cast<std::size_t>(chunk)];
      p.h = h;
      p.g = g;
      p.matched = matched;
    });
    Matrix6d h = Matrix6d::Zero();
    Vector6d g = Vector6d::Zero();
    std::size_t matched = 0;
    for (const Partial& p : partials) {
      h += p.h.cast<double>();
      g += p.g.cast<double>();
      matched += p.matched;
    }
    // Pinned parameters: xi = [omega, delta] holds rotations first.
    for (int i = 0; i < 6; ++i) {
      if (options.active[i < 3 ? i + 3 : i - 3])
        continue;
      h.row(i).setZero();
      h.col(i).setZero();
      h(i, i) = 1.0;
      g[i] = 0.0;
    }
    result.correspondences = matched;
    if (matched < 6)
      break;
    const Vector6d step = h.ldlt().solve(-g);
    if (!step.allFinite())
      break;
    // The steps shrink geometrically and keep their direction (each one lands short:
    // moving the samples changes which cubes they fall into), so when two successive
    // steps agree the rest of the series is taken at once, as Aitken's extrapolation
    // does: step / (1 - ratio), at most kMaxExtrapolation times the step.
    Vector6d xi = step;
    if (it > 0 && options.extrapolate)
      xi *= extrapolation(step, previous_step, options.lever_arm);
    previous_step = step;
    applyLeftIncrement(xi.head<3>(), xi.tail<3>(), result.rotation, result.translation);
    result.iterations = it + 1;
    if (step.head<3>().norm() < options.rotation_epsilon &&
        step.tail<3>().norm() < options.translation_epsilon) {
      result.converged = true;
      break;
    }
  }
  // Keep the rotation orthonormal after many small updates.
  const Eigen::Quaterniond q(result.rotation);
  result.rotation = q.normalized().toRotationMatrix();
  return result;
}

} // namespace core
} // namespace pcl_mi
