/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/phase_spread.h"

#include "engine/refine_optimum.h"
#include "util/parallel.h"
#include "verify/plane_information.h"
#include "verify/pose_evidence.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace pcl_mi {
namespace core {

double
phaseSpreadScale(PreparedProblem& problem,
                 const Eigen::Matrix4d& pose,
                 const Eigen::Matrix<double, 6, 6>& covariance)
{
  const Parameters& p = problem.parameters();
  if (covariance.isZero() || !covariance.allFinite() ||
      p.refinement.method != Refinement::PointToDistribution)
    return 1.0;
  // The target's cubes (kept with the target) and the source's samples, side by side.
  const TargetDistributions* shifted_target = nullptr;
  SourceSamples source;
  parallelFor(2, p.num_threads, [&](int task) {
    if (task == 0)
      shifted_target = &problem.shiftedDistributions();
    else
      source = problem.shiftedRefinementSamples();
  });
  const TargetDistributions& target = *shifted_target;
  // From the result, as its own refinement ended: the finest stage, the same options.
  const LocalPose start = problem.toLocal(pose);
  const RefinementResult moved = refineToDistributions(
      target, source, start.rotation, start.translation, refinementOptions(p, p.search.searched()));
  const PoseEvidence at =
      gatherPoseEvidence(target, source, moved.rotation, moved.translation, 1, true);
  const Eigen::Matrix<double, 6, 6> moved_covariance =
      planeCovariance(at, source, problem.levelResolution(0), problem.target().centroid,
                      problem.targetAxes());
  // d: the left increment [t, rotation vector] that carries the result onto P1, in the
  // target's input frame, as the covariance is.
  const Eigen::Matrix4d increment =
      problem.fromLocal({moved.rotation, moved.translation}) * pose.inverse();
  const Eigen::AngleAxisd turn(Eigen::Matrix3d(increment.topLeftCorner<3, 3>()));
  Eigen::Matrix<double, 6, 1> d;
  d << increment.topRightCorner<3, 1>(), turn.angle() * turn.axis();
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> sum(covariance + moved_covariance);
  if (sum.info() != Eigen::Success || !sum.isPositive())
    return 1.0;
  const double form = d.dot(sum.solve(d));
  return std::isfinite(form) ? std::max(1.0, form / 6.0) : 1.0;
}

} // namespace core
} // namespace pcl_mi
