/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "verify/inlier_probe.h"

#include "verify/pose_evidence.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace pcl_mi {
namespace core {

namespace {

/** Most samples each probe around the result looks at: the contrast is a ratio of counts,
 * which a few thousand samples fix well enough. */
constexpr std::size_t kProbeSamples = 4096;

/** Least share of a move that must cross a sample's surface for the sample to count in
 * lostAcrossEitherWay(): the sine of the angle between the move and the surface (about 17
 * deg). A road's slope and its noisy normals put a move along it a few degrees off the
 * ground, which must not count; steeper surfaces may (docs/benchmarks.md, "The verdict where
 * the sensors stand where they were"). */
constexpr float kAcrossSurface = 0.3f;

} // namespace

InlierProbe::InlierProbe(const TargetDistributions& target,
                         const SourceSamples& source,
                         const Eigen::Matrix3d& rotation,
                         const Eigen::Vector3d& translation)
: target_(target),
  source_(source),
  rotation_(rotation),
  translation_(translation),
  stride_(source.samples.size() / kProbeSamples + 1),
  base_(static_cast<double>(
      gatherPoseEvidence(target, source, rotation, translation, stride_).inliers))
{
  // The probed samples' first and second moments at the result: every motion measure
  // below is a quadratic form in them.
  for (std::size_t i = 0; i < source.samples.size(); i += stride_, ++probed_) {
    const Eigen::Vector3d q = rotation * source.samples[i].position.cast<double>() + translation;
    mean_ += q;
    second_moment_ += q * q.transpose();
  }
  if (probed_) {
    mean_ /= static_cast<double>(probed_);
    second_moment_ /= static_cast<double>(probed_);
  }
}

template <typename LossAt>
double
InlierProbe::meanLoss(const Eigen::Vector3d& omega,
                      const Eigen::Vector3d& delta,
                      const LossAt& loss_at) const
{
  return base_ > 0.0 ? meanEitherWay(rotation_, translation_, omega, delta, loss_at) : 0.0;
}

double
InlierProbe::lostEitherWay(const Eigen::Vector3d& omega, const Eigen::Vector3d& delta) const
{
  return meanLoss(omega, delta, [&](const Eigen::Matrix3d& r, const Eigen::Vector3d& t) {
    return 1.0 - gatherPoseEvidence(target_, source_, r, t, stride_).inliers / base_;
  });
}

double
InlierProbe::lostAcrossEitherWay(const Eigen::Vector3d& omega, const Eigen::Vector3d& delta) const
{
  if (!(base_ > 0.0))
    return 0.0;
  const double at = inliersAcross(rotation_, translation_, omega, delta);
  return meanLoss(omega, delta, [&](const Eigen::Matrix3d& r, const Eigen::Vector3d& t) {
    return (at - inliersAcross(r, t, omega, delta)) / base_;
  });
}

double
InlierProbe::meanMoveProduct(const Eigen::Vector3d& omega_a,
                             const Eigen::Vector3d& delta_a,
                             const Eigen::Vector3d& omega_b,
                             const Eigen::Vector3d& delta_b) const
{
  if (probed_ == 0)
    return 0.0;
  // (a x q) . (b x q) = (a . b)(q . q) - (a . q)(b . q)
  return delta_a.dot(delta_b) + delta_a.dot(omega_b.cross(mean_)) +
         delta_b.dot(omega_a.cross(mean_)) + omega_a.dot(omega_b) * second_moment_.trace() -
         omega_a.dot(second_moment_ * omega_b);
}

double
InlierProbe::rmsShift(const Eigen::Vector3d& omega, const Eigen::Vector3d& delta) const
{
  return std::sqrt(std::max(0.0, meanMoveProduct(omega, delta, omega, delta)));
}

double
InlierProbe::lostTurningEitherWay(int axis, double angle) const
{
  if (!(base_ > 0.0))
    return 0.0;
  double lost = 0.0;
  for (int sign = -1; sign <= 1; sign += 2) {
    const Eigen::Matrix3d r =
        Eigen::AngleAxisd(sign * angle, Eigen::Vector3d::Unit(axis)).toRotationMatrix() * rotation_;
    lost += 1.0 - gatherPoseEvidence(target_, source_, r, translation_, stride_).inliers / base_;
  }
  return 0.5 * lost;
}

double
InlierProbe::inliersAcross(const Eigen::Matrix3d& rotation,
                           const Eigen::Vector3d& translation,
                           const Eigen::Vector3d& omega,
                           const Eigen::Vector3d& delta) const
{
  const Eigen::Vector3f w = omega.cast<float>();
  const Eigen::Vector3f d = delta.cast<float>();
  std::size_t count = 0;
  visitInCubes(target_, source_, rotation.cast<float>(), translation.cast<float>(), 0,
               source_.samples.size(), stride_, [&](const Eigen::Vector3f& q, int k) {
                 if (k < 0 || !isInlier(target_[k], q))
                   return;
                 const Eigen::Vector3f m = w.cross(q) + d;
                 count += std::abs(target_[k].normal.dot(m)) >= kAcrossSurface * m.norm();
               });
  return static_cast<double>(count);
}

} // namespace core
} // namespace pcl_mi
