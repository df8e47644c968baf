/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/second_optimum.h"

#include <Eigen/Eigenvalues>

#include <array>

namespace pcl_mi {
namespace core {

namespace {

/** Distances of the probes, in voxels of the finest grid, each taken either way. */
constexpr std::array<double, kSecondOptimumProbes / 2> kProbeVoxels = {1.0, 2.0, 3.0};

} // namespace

std::optional<Eigen::Matrix4d>
higherAlongLeastConstrained(PreparedProblem& problem,
                            const Eigen::Matrix4d& pose,
                            double mutual_information,
                            const Eigen::Matrix<double, 6, 6>& covariance)
{
  const Eigen::Matrix3d translation = covariance.topLeftCorner<3, 3>();
  if (!(translation.trace() > 0.0))
    return std::nullopt;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(translation);
  const Eigen::Vector3d direction = solver.eigenvectors().col(2); // the largest variance
  const double voxel = problem.levelResolution(0);
  // All on the evaluator that scored the result: a second one would first have to touch
  // its own copy of the finest grid's moments, which on a fine grid costs more than the
  // probes themselves.
  JointHistogram histogram;
  std::optional<Eigen::Matrix4d> higher;
  double best = mutual_information;
  for (int i = 0; i < kSecondOptimumProbes; ++i) {
    Eigen::Matrix4d probe = pose;
    const double sign = i % 2 == 0 ? -1.0 : 1.0;
    probe.topRightCorner<3, 1>() += sign * kProbeVoxels[i / 2] * voxel * direction;
    const double value = problem.mutualInformation(probe, histogram, 0, 0);
    if (value > best) {
      best = value;
      higher = probe;
    }
  }
  return higher;
}

} // namespace core
} // namespace pcl_mi
