/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "verify/pose_evidence.h"

#include <Eigen/Geometry>

#include <algorithm>

namespace pcl_mi {
namespace core {

PoseEvidence
gatherPoseEvidence(const TargetDistributions& target,
                   const SourceSamples& source,
                   const Eigen::Matrix3d& rotation,
                   const Eigen::Vector3d& translation,
                   std::size_t stride,
                   bool with_information)
{
  PoseEvidence evidence;
  const Eigen::Matrix3f r = rotation.cast<float>();
  const Eigen::Vector3f t = translation.cast<float>();
  stride = std::max<std::size_t>(stride, 1);
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  visitInCubes(target, source, r, t, 0, source.samples.size(), stride,
               [&](const Eigen::Vector3f& q, int k) {
                 ++evidence.samples;
                 if (k < 0 || target[k].points < kEvidenceMinimumPoints)
                   return;
                 ++evidence.matched;
                 const TargetDistributions::Distribution& dist = target[k];
                 if (!isInlier(dist, q))
                   return;
                 ++evidence.inliers;
                 if (!with_information)
                   return;
                 // n . (exp(omega) q + delta - mean): d/domega = (q x n)^T, d/ddelta = n^T.
                 const Eigen::Vector3f n = dist.normal;
                 const Eigen::Vector3f e = q - dist.mean;
                 Eigen::Matrix<double, 6, 1> a;
                 a << q.cross(n).cast<double>(), n.cast<double>();
                 information.noalias() += a * a.transpose();
                 const double d = n.dot(e);
                 evidence.plane_gradient += a * d;
                 evidence.plane_residuals += d * d;
               });
  evidence.plane_information = information;
  return evidence;
}

} // namespace core
} // namespace pcl_mi
