/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/steadiness.h"

#include "engine/candidates.h"
#include "engine/refine_optimum.h"
#include "util/stage_clock.h"
#include "verify/verification.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pcl_mi {
namespace core {

namespace {

/** Half the success bound of the confidence: a restart that ends this far from the result or
 * farther makes it unsteady. */
constexpr double kSteadyTurnDeg = kSuccessTurnDeg / 2.0;
constexpr double kSteadyShiftMetres = kSuccessShiftMetres / 2.0;

} // namespace

void
judgeSteadiness(PreparedProblem& problem, const SearchSpace& space, AlignmentResult& result)
{
  if (result.converged ||
      problem.parameters().refinement.method != Refinement::PointToDistribution)
    return;
  StageClock clock;
  // The result's own refinement, so that a restart can end where the result did.
  const int coarser_stages = coarserRefinementStages(problem);
  const LocalPose at = problem.toLocal(result.transformation);
  double turn_deg = 0.0, shift = 0.0;
  int restarts = 0;
  // Six restarts, or fewer where one leaves the basin: nothing is farther.
  for (; restarts < 6 && std::isfinite(turn_deg); ++restarts) {
    const double sign = restarts % 2 == 0 ? -1.0 : 1.0;
    const Eigen::Matrix3d turned = Eigen::AngleAxisd(sign * kRestartTurnDeg * M_PI / 180.0,
                                                     Eigen::Vector3d::Unit(restarts / 2))
                                       .toRotationMatrix() *
                                   at.rotation;
    const RefinedOptimum restart = refineOptimum(
        problem, space, problem.fromLocal({turned, at.translation}), coarser_stages);
    if (!restart.accepted) {
      turn_deg = shift = std::numeric_limits<double>::infinity();
      continue;
    }
    const LocalPose end = problem.toLocal(restart.transformation);
    const Eigen::AngleAxisd turn(end.rotation * at.rotation.transpose());
    turn_deg = std::max(turn_deg, turn.angle() * 180.0 / M_PI);
    shift = std::max(shift, (end.translation - at.translation).norm());
  }
  Verification& v = result.verification;
  v.restart_turn_deg = turn_deg;
  v.restart_shift = shift;
  const double steady_shift = kSteadyShiftMetres * problem.parameters().units_per_metre;
  v.unsteady = !(turn_deg < kSteadyTurnDeg && shift < steady_shift);
  if (v.unsteady)
    v.confidence = kUnsteadyConfidence;
  // Within a voxel of each other, the scans' patterns share a centre and may hold a turn
  // about it by themselves (a spinning sensor's rings on a road, a narrow view turned on the
  // spot): a steady result there says nothing of its turns (docs/benchmarks.md, "Free turns
  // the refinement holds").
  else if (v.refusal == Refusal::Degenerate && onlyTurnsFree(v) &&
           sensorsApart(problem, result.transformation))
    judgeWithTurnsHeld(problem, result);
  clock.end(result.stages, "steadiness", restarts);
}

} // namespace core
} // namespace pcl_mi
