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
  Eigen::Vector3f q[TargetDistributions::kFindBlock];
  std::int32_t found[TargetDistributions::kFindBlock];
  const std::size_t n_samples = source.samples.size();
  for (std::size_t begin = 0; begin < n_samples;) {
    std::size_t count = 0;
    for (; count < TargetDistributions::kFindBlock && begin < n_samples; ++count, begin += stride)
      q[count] = r * source.samples[begin].position + t;
    target.findBlock(q, count, found);
    evidence.samples += count;
    for (std::size_t k = 0; k < count; ++k) {
      if (found[k] < 0)
        continue;
      ++evidence.matched;
      const TargetDistributions::Distribution& dist = target[found[k]];
      const Eigen::Vector3f e = q[k] - dist.mean;
      const float m = e.dot(dist.information * e);
      if (!(m <= kInlierMahalanobis))
        continue;
      ++evidence.inliers;
      if (!with_information)
        continue;
      // n . (exp(omega) q + delta - mean): d/domega = (q x n)^T, d/ddelta = n^T.
      const Eigen::Vector3f n = dist.normal;
      Eigen::Matrix<double, 6, 1> a;
      a << q[k].cross(n).cast<double>(), n.cast<double>();
      information.noalias() += a * a.transpose();
      const double d = n.dot(e);
      evidence.plane_gradient += a * d;
      evidence.plane_residuals += d * d;
    }
  }
  evidence.plane_information = information;
  return evidence;
}

} // namespace core
} // namespace pcl_mi
