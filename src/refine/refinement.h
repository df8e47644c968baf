/*
 * pcl_mi: local refinement of an MI alignment against the target's voxel distributions.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "features/source_samples.h"
#include "util/left_increment.h"

#include <pcl_mi/types.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace Eigen {
template <typename MatrixType>
class SelfAdjointEigenSolver; // <Eigen/Eigenvalues>, where the axes are read
}

namespace pcl_mi {
namespace core {

/** \brief The target summarised per cube of edge cell_size: the mean of its points and the
 * inverse of their (regularised) covariance, found by hashing a point's cell. */
class TargetDistributions {
public:
  /** \brief Summarises \a points (target local frame) per cube of edge \a cell_size.
   * Cubes with fewer than \a min_points points are left out. The two larger principal
   * variances of each cube are raised to at least (cell_size / 2)^2: where inside a cube
   * the target's scan lines crossed a surface says little about the surface, so samples
   * may slide along it and are held mainly across it (GICP's plane regularisation in
   * spirit).
   * A cube whose points form a strip (one or two scan lines of a sparse scanner: spread
   * across less than half the spread along) takes its across-surface direction from the
   * points of its 3x3x3 cubes instead, when those are less strip-like: a plane through one
   * scan line is the laser's cone, which moves with the sensor and pulls roll and pitch
   * towards zero relative motion.
   * \a noise_sigma (m) is then added to the diagonal as squared noise, which keeps the
   * distributions invertible and bounds how sharply a single cube can pull. */
  TargetDistributions(const PointList& points,
                      double cell_size,
                      int min_points,
                      double noise_sigma);

  /** \brief Principal axes of a cube's own points: cell index and eigen solver (ascending). */
  using AxesVisitor =
      std::function<void(std::size_t cell, const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>&)>;

  /** \brief The same from the cubes' summaries, \a cells = makeSourceSamples(points,
   * cell_size), for a caller that reads them too: \a on_axes, where given, is handed the
   * principal axes of every cube of \a min_points or more, in the cells' order. */
  TargetDistributions(const SourceSamples& cells,
                      int min_points,
                      double noise_sigma,
                      const AxesVisitor& on_axes = {});

  /** \brief Index of the distribution whose cube holds \a p, or -1. */
  int
  find(const Eigen::Vector3f& p) const;

  /** \brief find() for each of \a count points, into \a indices. The same answers, with the
   * lookups' memory reads started for the whole block before any is used: one at a time,
   * each sample waits on two reads of a table larger than the caches. kFindBlock or fewer
   * points; the distributions found are being read when it returns. */
  void
  findBlock(const Eigen::Vector3f* points, std::size_t count, std::int32_t* indices) const;

  /** Most points findBlock() takes at once. */
  static constexpr std::size_t kFindBlock = 64;

  /** \brief Mean and inverse covariance of one cube's points, side by side so a lookup
   * touches one cache line, the surface normal the covariance is flattened across, and
   * how many points the cube holds. */
  struct Distribution {
    Eigen::Vector3f mean;
    Eigen::Matrix3f information;
    Eigen::Vector3f normal;
    std::uint32_t points;
  };

  std::size_t
  size() const
  {
    return distributions_.size();
  }
  const Distribution&
  operator[](int i) const
  {
    return distributions_[static_cast<std::size_t>(i)];
  }
  double
  cellSize() const
  {
    return cell_size_;
  }

private:
  std::uint64_t
  keyOf(const Eigen::Vector3f& p, bool& inside) const;

  double cell_size_;
  float inv_cell_;
  Eigen::Vector3f origin_;
  std::vector<Distribution> distributions_;
  /** Open-addressing table of (key + 1, index); key 0 marks an empty slot. */
  std::vector<std::pair<std::uint64_t, std::int32_t>> table_;
  std::uint64_t mask_ = 0;
};

/** \brief Calls \a visit(q, k) for samples begin, begin + stride, ... (before \a end) of
 * \a source moved by \a rotation, \a translation: q the moved position, k the index of the
 * distribution of \a target whose cube holds it, or -1. The samples are looked up
 * TargetDistributions::kFindBlock at a time (findBlock()) and visited in order. */
template <typename Visit>
void
visitInCubes(const TargetDistributions& target,
             const SourceSamples& source,
             const Eigen::Matrix3f& rotation,
             const Eigen::Vector3f& translation,
             std::size_t begin,
             std::size_t end,
             std::size_t stride,
             const Visit& visit)
{
  Eigen::Vector3f q[TargetDistributions::kFindBlock];
  std::int32_t found[TargetDistributions::kFindBlock];
  for (std::size_t i = begin; i < end;) {
    std::size_t count = 0;
    for (; count < TargetDistributions::kFindBlock && i < end; ++count, i += stride)
      q[count] = rotation * source.samples[i].position + translation;
    target.findBlock(q, count, found);
    for (std::size_t k = 0; k < count; ++k)
      visit(q[k], found[k]);
  }
}

/** \brief Options of the refinement. */
struct RefinementOptions {
  int max_iterations = 20;
  /** Stop once a Gauss-Newton step (before extrapolation) rotates less than this (rad)
   * and translates less than translation_epsilon (in the clouds' units; 0.5 mm). */
  double rotation_epsilon = 5e-5;
  double translation_epsilon = 5e-4;
  /** Lever arm (in the clouds' units; 10 m) that makes a rotation step comparable with a
   * translation step when successive steps are compared for extrapolation. */
  double lever_arm = 10.0;
  /** Which of [tx, ty, tz, roll, pitch, yaw] may change (rotations about the target's
   * axes); the others keep the starting pose's value, as in a search with zero steps. */
  Eigen::Matrix<bool, 6, 1> active = Eigen::Matrix<bool, 6, 1>::Constant(true);
  /** Threads; the result does not depend on it. */
  int num_threads = 1;
  /** Extrapolate the series of Gauss-Newton steps when successive steps agree in direction
   * (see refineToDistributions()). */
  bool extrapolate = true;
  /** Scale of the Cauchy kernel on the squared Mahalanobis distance. */
  double kernel_scale = 3.0;
};

/** \brief Outcome of a refinement, in the local frames. */
struct RefinementResult {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  int iterations = 0;
  std::size_t correspondences = 0; ///< samples matched in the last iteration
  bool converged = false;
};

/** \brief Adds one sample's share, weighted by \a w, to the Gauss-Newton normal equations
 * \a h (J^T A J) and \a g (J^T A e) of the residual e = exp(xi) q - mean, with the left
 * increment xi = [omega, delta], its Jacobian J = [-[q]x, I] and A = \a information. Only
 * the upper right of the two off-diagonal blocks is written: the caller mirrors it. Inline:
 * the refinement calls it for every sample. */
inline void
addToNormalEquations(const Eigen::Vector3f& q,
                     const Eigen::Vector3f& e,
                     const Eigen::Matrix3f& information,
                     float w,
                     Eigen::Matrix<float, 6, 6>& h,
                     Eigen::Matrix<float, 6, 1>& g)
{
  // By blocks, [q]x A (-[q]x), [q]x A and A, and q x (A e) and A e: a third of the
  // multiplies of the dense 3x6 products.
  const Eigen::Vector3f v = information * e;
  const Eigen::Matrix3f skew = crossMatrix(q);
  const Eigen::Matrix3f b = skew * information;
  h.topLeftCorner<3, 3>().noalias() -= w * (b * skew);
  h.topRightCorner<3, 3>().noalias() += w * b;
  h.bottomRightCorner<3, 3>().noalias() += w * information;
  g.head<3>().noalias() += w * q.cross(v);
  g.tail<3>().noalias() += w * v;
}

/** \brief Gauss-Newton minimisation of the robust point-to-distribution distance of the
 * source samples (moved by rotation, translation from the source's into the target's local
 * frame) to the target distribution of the cube each one falls into. Every sample weighs
 * the same, whatever its point count: weighting by count lets the dense ground near the
 * sensor outvote the structure that fixes the horizontal position. The steps tend to land
 * short (moving the samples moves them into other cubes) and shrink geometrically in one
 * direction; when two successive steps agree, the series' remainder is taken at once. */
RefinementResult
refineToDistributions(const TargetDistributions& target,
                      const SourceSamples& source,
                      const Eigen::Matrix3d& rotation,
                      const Eigen::Vector3d& translation,
                      const RefinementOptions& options);

} // namespace core
} // namespace pcl_mi
