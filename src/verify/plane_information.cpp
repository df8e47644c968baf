/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "verify/plane_information.h"

#include "util/left_increment.h"

#include <algorithm>
#include <cmath>

namespace pcl_mi {
namespace core {

namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

/** The samples' root mean square distance from the source's local origin. */
double
rmsRadius(const SourceSamples& source)
{
  double sum = 0.0;
  for (const SourceSample& s : source.samples)
    sum += s.position.squaredNorm();
  return source.samples.empty() ? 0.0 : std::sqrt(sum / source.samples.size());
}

/** [omega, delta] -> [delta, omega]: the evidence's order to the covariance's. */
Matrix6d
covarianceOrder()
{
  Matrix6d order = Matrix6d::Zero();
  order.block<3, 3>(0, 3).setIdentity();
  order.block<3, 3>(3, 0).setIdentity();
  return order;
}

/** Per parameter of [delta, omega], the scale that makes one unit of rotation move a point
 * at \a radius by one unit of length. */
Eigen::Matrix<double, 6, 1>
rotationScale(double radius)
{
  Eigen::Matrix<double, 6, 1> scale;
  scale << 1.0, 1.0, 1.0, 1.0 / radius, 1.0 / radius, 1.0 / radius;
  return scale;
}

/** The inliers' residual variance across the surfaces, six degrees of freedom taken by the
 * pose (more than 6 inliers). */
double
planeVariance(const PoseEvidence& at)
{
  return at.plane_residuals / static_cast<double>(at.inliers - 6);
}

/** The map that turns both halves of an increment [delta, omega] by \a axes. */
Matrix6d
turnedAlike(const Eigen::Matrix3d& axes)
{
  Matrix6d m = Matrix6d::Zero();
  m.block<3, 3>(0, 0) = axes;
  m.block<3, 3>(3, 3) = axes;
  return m;
}

} // namespace

double
rotationRadius(const SourceSamples& source, double resolution)
{
  return std::max(rmsRadius(source), resolution);
}

Eigen::SelfAdjointEigenSolver<Matrix6d>
scaledInformation(const PoseEvidence& at, double radius)
{
  const Matrix6d order = covarianceOrder();
  const Eigen::Matrix<double, 6, 1> scale = rotationScale(radius);
  const Matrix6d h = order * at.plane_information * order.transpose();
  return Eigen::SelfAdjointEigenSolver<Matrix6d>(scale.asDiagonal() * h * scale.asDiagonal());
}

Matrix6d
covarianceFrom(const PoseEvidence& at,
               const Eigen::SelfAdjointEigenSolver<Matrix6d>& solver,
               double radius,
               const Eigen::Vector3d& target_centroid,
               const Eigen::Matrix3d& target_axes)
{
  const double largest = solver.eigenvalues()[5];
  if (!(largest > 0.0) || at.inliers <= 6 || !(solver.eigenvalues()[0] / largest > 0.0))
    return Matrix6d::Zero();
  const Matrix6d order = covarianceOrder();
  const Eigen::Matrix<double, 6, 1> scale = rotationScale(radius);
  // Residual variance across the surfaces, then back from the scaled increments; the
  // increment about the target local origin becomes one about the input frame's origin:
  // delta_origin = delta + c x omega.
  const double variance = planeVariance(at);
  const Matrix6d scaled_inverse = solver.eigenvectors() *
                                  solver.eigenvalues().cwiseInverse().asDiagonal() *
                                  solver.eigenvectors().transpose();
  // The result is not exactly the point-to-plane optimum (the refinement weighs distributions,
  // not planes, and stops early): the Gauss-Newton step to it is an error of its own, which
  // the covariance takes in as its outer product.
  const Eigen::Matrix<double, 6, 1> step =
      scaled_inverse * (scale.asDiagonal() * (order * at.plane_gradient));
  const Matrix6d scaled_covariance = variance * scaled_inverse + step * step.transpose();
  const Matrix6d to_input = turnedAlike(target_axes);
  const Matrix6d local =
      to_input * scale.asDiagonal() * scaled_covariance * scale.asDiagonal() * to_input.transpose();
  const Matrix6d to_origin = incrementMovedBy(-target_centroid);
  return to_origin * local * to_origin.transpose();
}

Matrix6d
informationFrom(const PoseEvidence& at,
                const Eigen::Vector3d& target_centroid,
                const Eigen::Matrix3d& target_axes)
{
  if (at.inliers <= 6 || !(at.plane_residuals > 0.0))
    return Matrix6d::Zero();
  const double variance = planeVariance(at);
  const Matrix6d order = covarianceOrder();
  // An increment about the input frame's origin, as one about the target local origin.
  const Matrix6d from_origin =
      turnedAlike(target_axes.transpose()) * incrementMovedBy(target_centroid);
  return from_origin.transpose() * (order * at.plane_information * order.transpose()) *
         from_origin / variance;
}

Eigen::Matrix<double, 6, 6>
planeCovariance(const PoseEvidence& at,
                const SourceSamples& source,
                double resolution,
                const Eigen::Vector3d& target_centroid,
                const Eigen::Matrix3d& target_axes)
{
  const double radius = rotationRadius(source, resolution);
  return covarianceFrom(at, scaledInformation(at, radius), radius, target_centroid, target_axes);
}

} // namespace core
} // namespace pcl_mi
