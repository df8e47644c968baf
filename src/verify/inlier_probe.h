/*
 * pcl_mi: the inliers of poses around a result, counted against the result's own: how much
 * of the evidence a move of the result loses, and how far a move carries the samples.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "features/source_samples.h"
#include "refine/refinement.h"
#include "util/left_increment.h"

#include <Eigen/Core>

#include <cstddef>

namespace pcl_mi {
namespace core {

/** \brief The mean of \a value_at(r, t) over the two poses that the left increments
 * +-[omega, delta] move \a rotation, \a translation to. */
template <typename ValueAt>
double
meanEitherWay(const Eigen::Matrix3d& rotation,
              const Eigen::Vector3d& translation,
              const Eigen::Vector3d& omega,
              const Eigen::Vector3d& delta,
              const ValueAt& value_at)
{
  double sum = 0.0;
  for (int sign = -1; sign <= 1; sign += 2) {
    Eigen::Matrix3d r = rotation;
    Eigen::Vector3d t = translation;
    applyLeftIncrement(sign * omega, sign * delta, r, t);
    sum += value_at(r, t);
  }
  return 0.5 * sum;
}

/** \brief Counts the inliers of poses near a result against the result's own, on every k-th
 * source sample (at most a few thousand), and measures how far moves of the result carry
 * those samples. */
class InlierProbe {
public:
  /** \brief The probe of the result \a rotation, \a translation (source local to target
   * local) of \a source against \a target. Both must outlive the probe. */
  InlierProbe(const TargetDistributions& target,
              const SourceSamples& source,
              const Eigen::Matrix3d& rotation,
              const Eigen::Vector3d& translation);

  /** \brief Mean share of the result's inliers lost by the left increments +-[omega,
   * delta] (rotations about the target local origin); 0 for a result without inliers. */
  double
  lostEitherWay(const Eigen::Vector3d& omega, const Eigen::Vector3d& delta) const;

  /** \brief lostEitherWay() counting only the inliers whose surface the move crosses (by a
   * good share of its length), at the result and at the moved poses alike: a sample moved
   * along its own surface (the ground under a move along the road) keeps or loses its
   * inlier by how the sensors sampled that surface, which says nothing of the pose where
   * their scan patterns fall on one another. */
  double
  lostAcrossEitherWay(const Eigen::Vector3d& omega, const Eigen::Vector3d& delta) const;

  /** \brief Mean over the probed samples q of the product of their moves, to first order,
   * by the left increments [omega_a, delta_a] and [omega_b, delta_b]:
   * (omega_a x q + delta_a) . (omega_b x q + delta_b); 0 without samples. */
  double
  meanMoveProduct(const Eigen::Vector3d& omega_a,
                  const Eigen::Vector3d& delta_a,
                  const Eigen::Vector3d& omega_b,
                  const Eigen::Vector3d& delta_b) const;

  /** \brief Root mean square distance by which the left increment [omega, delta] moves the
   * probed samples, to first order. */
  double
  rmsShift(const Eigen::Vector3d& omega, const Eigen::Vector3d& delta) const;

  /** \brief lostEitherWay() for turns by +-\a angle about the axis \a axis (0-2) through
   * the source's centroid, which sits at the translation in the target local frame. */
  double
  lostTurningEitherWay(int axis, double angle) const;

private:
  /** The mean of \a loss_at(r, t) over the poses the left increments +-[omega, delta] move
   * the result to; 0 for a result without inliers. */
  template <typename LossAt>
  double
  meanLoss(const Eigen::Vector3d& omega, const Eigen::Vector3d& delta, const LossAt& loss_at) const;

  /** The probed samples at \a rotation, \a translation that are inliers of a surface that
   * the left increment [omega, delta] crosses. */
  double
  inliersAcross(const Eigen::Matrix3d& rotation,
                const Eigen::Vector3d& translation,
                const Eigen::Vector3d& omega,
                const Eigen::Vector3d& delta) const;

  const TargetDistributions& target_;
  const SourceSamples& source_;
  const Eigen::Matrix3d rotation_;
  const Eigen::Vector3d translation_;
  const std::size_t stride_;
  const double base_;
  std::size_t probed_ = 0; // samples the moments below are over
  Eigen::Vector3d mean_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second_moment_ = Eigen::Matrix3d::Zero();
};

} // namespace core
} // namespace pcl_mi
