/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/second_optimum.h"

#include "util/parallel.h"

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
                            const Eigen::Matrix<double, 6, 6>& covariance,
                            int num_threads)
{
  const Eigen::Matrix3d translation = covariance.topLeftCorner<3, 3>();
  if (!(translation.trace() > 0.0))
    return std::nullopt;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(translation);
  const Eigen::Vector3d direction = solver.eigenvectors().col(2); // the largest variance
  const double voxel = problem.levelResolution(0);
  std::array<Eigen::Matrix4d, kSecondOptimumProbes> probes;
  for (std::size_t i = 0; i < probes.size(); ++i) {
    const double sign = i % 2 == 0 ? -1.0 : 1.0;
    probes[i] = pose;
    probes[i].topRightCorner<3, 1>() += sign * kProbeVoxels[i / 2] * voxel * direction;
  }
  // Half the probes on each evaluator; every value is its own task's.
  std::array<double, kSecondOptimumProbes> values{};
  JointHistogram histograms[2];
  parallelFor(2, num_threads, [&](int slot) {
    for (std::size_t i = static_cast<std::size_t>(slot); i < probes.size(); i += 2)
      values[i] = problem.mutualInformation(probes[i], histograms[slot], 0, slot);
  });
  std::optional<Eigen::Matrix4d> higher;
  double best = mutual_information;
  for (std::size_t i = 0; i < probes.size(); ++i)
    if (values[i] > best) {
      best = values[i];
      higher = probes[i];
    }
  return higher;
}

} // namespace core
} // namespace pcl_mi
