/*
 * pcl_mi: what the target's surfaces say about one pose of the source samples: how many
 * samples land on them, and how firmly they hold the pose in each direction.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "features/source_samples.h"
#include "refine/refinement.h"

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>

namespace pcl_mi {
namespace core {

/** \brief Counts and point-to-plane information of the source samples at one pose. */
struct PoseEvidence {
  std::size_t samples = 0; ///< source samples looked at
  std::size_t matched = 0; ///< samples inside a target cube of kEvidenceMinimumPoints or more
  std::size_t inliers = 0; ///< matched samples within kInlierMahalanobis of the distribution
  /** Sum over the inliers of a^T a, a = d(n . e) / d[omega, delta]: how the distance of a
   * sample from its cube's surface (normal n) changes under a left increment of the pose
   * (rotation first, about the target local origin). Unweighted, so its null space is
   * exactly what the surfaces leave free: a floor's x, y and yaw, a corridor's length. */
  Eigen::Matrix<double, 6, 6> plane_information = Eigen::Matrix<double, 6, 6>::Zero();
  /** Sum over the inliers of a (n . e): with plane_information, the Gauss-Newton step to the
   * point-to-plane optimum. */
  Eigen::Matrix<double, 6, 1> plane_gradient = Eigen::Matrix<double, 6, 1>::Zero();
  double plane_residuals = 0.0; ///< sum of the inliers' squared distances (n . e)^2
};

/** Squared Mahalanobis distance below which a sample lies on its cube's surface: three
 * standard deviations across it. */
constexpr double kInlierMahalanobis = 9.0;

/** Fewest points a target cube needs to count as evidence. The refinement also pulls
 * samples into sparser cubes, whose surface may come from their neighbours; a cube of its
 * own four or more points is firmer evidence that a sample found the surface, and the
 * confidence model was fitted on such cubes. */
constexpr std::uint32_t kEvidenceMinimumPoints = 4;

/** \brief True where the sample \a q lies on the surface of the target cube \a dist: the cube
 * holds kEvidenceMinimumPoints or more, and q lies within kInlierMahalanobis of its
 * distribution. */
inline bool
isInlier(const TargetDistributions::Distribution& dist, const Eigen::Vector3f& q)
{
  const Eigen::Vector3f e = q - dist.mean;
  return dist.points >= kEvidenceMinimumPoints && e.dot(dist.information * e) <= kInlierMahalanobis;
}

/** \brief The evidence of every \a stride-th sample of \a source moved by \a rotation,
 * \a translation (source local to target local) against \a target; the point-to-plane
 * terms only when \a with_information. */
PoseEvidence
gatherPoseEvidence(const TargetDistributions& target,
                   const SourceSamples& source,
                   const Eigen::Matrix3d& rotation,
                   const Eigen::Vector3d& translation,
                   std::size_t stride = 1,
                   bool with_information = false);

} // namespace core
} // namespace pcl_mi
