/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "verify/bound_chance.h"

#include "util/left_increment.h"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <iomanip>
#include <random>
#include <sstream>
#include <vector>

namespace pcl_mi {
namespace core {

namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

/** Draws the chance is counted over: its step, 1/4096, lies far below the margin between
 * kReliableConfidence and the confidences it multiplies. */
constexpr int kDraws = 4096;

/** Standard normal draws, the same in every run: std::mt19937's sequence is fixed by the
 * standard, std::normal_distribution's is not, so Box-Muller makes the normals here. */
const std::vector<Vector6d>&
standardNormalDraws()
{
  static const std::vector<Vector6d> draws = [] {
    std::mt19937 bits(20261207u);
    const auto uniform = [&bits] { // in (0, 1)
      return (static_cast<double>(bits()) + 0.5) / 4294967296.0;
    };
    std::vector<Vector6d> out(kDraws);
    for (Vector6d& z : out)
      for (int i = 0; i < 6; i += 2) {
        const double radius = std::sqrt(-2.0 * std::log(uniform()));
        const double angle = 2.0 * M_PI * uniform();
        z[i] = radius * std::cos(angle);
        z[i + 1] = radius * std::sin(angle);
      }
    return out;
  }();
  return draws;
}

} // namespace

double
chanceWithinBound(const Matrix6d& covariance,
                  const Eigen::Matrix4d& pose,
                  double shift,
                  double turn_deg)
{
  if (covariance.isZero() || !covariance.allFinite())
    return 1.0;
  // The error [e_t, omega]: a turn omega about the origin moves the pose's translation t by
  // omega x t.
  const Matrix6d j = incrementMovedBy(Eigen::Vector3d(pose.topRightCorner<3, 1>()));
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(j * covariance * j.transpose());
  if (eig.info() != Eigen::Success)
    return 1.0;
  const Matrix6d spread =
      eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  const double turn = turn_deg * M_PI / 180.0;
  int within = 0;
  for (const Vector6d& z : standardNormalDraws()) {
    const Vector6d e = spread * z;
    within += e.head<3>().norm() < shift && e.tail<3>().norm() < turn;
  }
  return static_cast<double>(within) / kDraws;
}

bool
spreadMatters(const AlignmentResult& result)
{
  const Verification& v = result.verification;
  // A result the clouds swapped confirmed has had its spread measured: another problem's
  // alignment ended within the agreement tolerance of it.
  return result.converged && !v.reverse_confirmed && v.inliers < kSparseInliers &&
         !v.covariance.isZero();
}

void
weighTheSpread(double covariance_scale, double units_per_metre, AlignmentResult& result)
{
  Verification& v = result.verification;
  const double chance =
      chanceWithinBound(covariance_scale * Matrix6d(v.covariance), result.transformation,
                        kSuccessShiftMetres * units_per_metre, kSuccessTurnDeg);
  v.confidence *= chance;
  if (v.confidence >= kReliableConfidence)
    return;
  std::ostringstream reason;
  reason << "the evidence is sparse (" << v.inliers
         << " source samples on a target surface), and its covariance leaves the pose within "
         << kSuccessShiftMetres << " m and " << kSuccessTurnDeg
         << " deg of the true one with a chance of " << std::fixed << std::setprecision(2)
         << chance << " (confidence " << v.confidence << ")";
  v.reason = reason.str();
  v.refusal = Refusal::WeakEvidence;
  result.converged = false;
}

} // namespace core
} // namespace pcl_mi
