/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/second_optimum.h"

#include "util/parallel.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
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
  std::array<Eigen::Matrix4d, kSecondOptimumProbes> probes;
  for (int i = 0; i < kSecondOptimumProbes; ++i) {
    const double sign = i % 2 == 0 ? -1.0 : 1.0;
    probes[i] = pose;
    probes[i].topRightCorner<3, 1>() += sign * kProbeVoxels[i / 2] * voxel * direction;
  }
  // Both evaluators, each on every other probe; the best is then taken in the probes' order,
  // so the answer does not depend on the threads.
  std::array<double, kSecondOptimumProbes> values;
  const int threads = std::min(2, problem.parameters().num_threads);
  parallelFor(threads, threads, [&](int slot) {
    JointHistogram histogram;
    for (int i = slot; i < kSecondOptimumProbes; i += threads)
      values[i] = problem.mutualInformation(probes[i], histogram, 0, slot);
  });
  std::optional<Eigen::Matrix4d> higher;
  double best = mutual_information;
  for (int i = 0; i < kSecondOptimumProbes; ++i)
    if (values[i] > best) {
      best = values[i];
      higher = probes[i];
    }
  return higher;
}

} // namespace core
} // namespace pcl_mi
