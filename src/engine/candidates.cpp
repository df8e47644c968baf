/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/candidates.h"

#include "engine/refine_optimum.h"
#include "engine/second_optimum.h"
#include "features/mutual_information.h"
#include "util/stage_clock.h"
#include "verify/verification.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <optional>
#include <sstream>
#include <string>
#include <utility>

namespace pcl_mi {
namespace core {

namespace {

/** Root mean square shift, in finest voxels, below which two refined poses are one optimum:
 * the finest grid's MI cannot tell them apart. */
constexpr double kSameOptimumVoxels = 0.5;

/** Samples of the source at most that rmsShift() moves. */
constexpr std::size_t kShiftSamples = 4096;

/** Root mean square distance between the source's samples moved by \a a and by \a b (input
 * frames). */
double
rmsShift(const PreparedProblem& problem, const Eigen::Matrix4d& a, const Eigen::Matrix4d& b)
{
  const std::vector<SourceSample>& samples = problem.refinementSamples().samples;
  const Eigen::Matrix4d d = b - a;
  const Eigen::Vector3d& centroid = problem.source().centroid;
  const std::size_t stride = samples.size() / kShiftSamples + 1;
  double sum = 0.0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < samples.size(); i += stride, ++count) {
    const Eigen::Vector3d x = samples[i].position.cast<double>() + centroid;
    sum += (d.topLeftCorner<3, 3>() * x + d.topRightCorner<3, 1>()).squaredNorm();
  }
  return count ? std::sqrt(sum / static_cast<double>(count)) : 0.0;
}

/** Takes the trust from \a result, which passed the reliability test, where a pose a few
 * voxels along its least constrained direction scores a higher MI on the finest grid
 * (higherAlongLeastConstrained()). */
void
refuseASecondOptimum(PreparedProblem& problem, AlignmentResult& result)
{
  StageClock clock;
  const std::optional<Eigen::Matrix4d> higher = higherAlongLeastConstrained(
      problem, result.transformation, result.mutual_information, result.verification.covariance);
  clock.end(result.stages, "second optimum", kSecondOptimumProbes);
  if (!higher)
    return;
  const Eigen::Vector3d shift =
      higher->topRightCorner<3, 1>() - result.transformation.topRightCorner<3, 1>();
  std::ostringstream reason;
  reason << std::fixed << std::setprecision(2) << "a second optimum: the pose moved by ("
         << shift.x() << ", " << shift.y() << ", " << shift.z()
         << "), along the direction the surfaces constrain least, scores a higher MI";
  result.verification.reason = reason.str();
  result.verification.refusal = Refusal::SecondOptimum;
  result.converged = false;
}

/** Makes the refined and verified candidate \a other, whose normalised MI on the finest grid
 * is \a other_normalized_mi, the result: its pose, verdict and refinement, not the counts and
 * stages of the whole alignment. */
void
takeCandidate(AlignmentResult&& other,
              double other_normalized_mi,
              AlignmentResult& result,
              double& finest_normalized_mi)
{
  finest_normalized_mi = other_normalized_mi;
  result.transformation = other.transformation;
  result.converged = other.converged;
  result.search_converged = other.search_converged;
  result.refinement_iterations = other.refinement_iterations;
  result.refinement_stages = other.refinement_stages;
  result.mutual_information = other.mutual_information;
  result.verification = std::move(other.verification);
}

/** Where \a pose puts the source's sensor against the target's: within a voxel or apart, and
 * whether it tilts its vertical axis by less than the verdict's probes turn it (a voxel at
 * the source's RMS radius), whatever its heading. A spinning LiDAR's rings are cones about
 * that axis, which fall on themselves turned about it by any angle. A narrow view tilted at
 * one place counts as apart: a handheld solid-state sensor turned on the spot tilts too, and
 * the surfaces crossed alone refused such right results (docs/benchmarks.md, "A ring scan
 * tilted on a featureless road"). */
SensorPlacement
sensorPlacement(const PreparedProblem& problem, const Eigen::Matrix4d& pose)
{
  if (sensorsApart(problem, pose))
    return SensorPlacement::kApart;
  const double resolution = problem.levelResolution(0);
  const double tilt = std::acos(std::clamp(pose(2, 2), -1.0, 1.0)); // z onto z
  if (tilt * std::max(problem.source().rms_radius, resolution) < resolution)
    return SensorPlacement::kSamePlaceAndAxis;
  return problem.narrowView() ? SensorPlacement::kApart : SensorPlacement::kSamePlace;
}

/** The verdict on \a pose, whose joint histogram on the finest grid \a histogram holds;
 * with \a free_turns_held, free turns do not count as free (verifyPose()). */
Verification
verifyAt(PreparedProblem& problem,
         const Eigen::Matrix4d& pose,
         const JointHistogram& histogram,
         bool free_turns_held)
{
  const LocalPose at = problem.toLocal(pose);
  JointHistogram probed;
  const FinestMutualInformation finest_mi = [&](const Eigen::Matrix3d& rotation,
                                                const Eigen::Vector3d& translation) {
    return problem.mutualInformation(problem.fromLocal({rotation, translation}), probed);
  };
  return verifyPose(problem.distributions(), problem.refinementSamples(), at.rotation,
                    at.translation, problem.levelResolution(0), histogram,
                    problem.target().centroid, problem.targetAxes(),
                    sensorPlacement(problem, pose), problem.parameters().num_threads, finest_mi,
                    free_turns_held);
}

} // namespace

bool
sensorsApart(const PreparedProblem& problem, const Eigen::Matrix4d& pose)
{
  return !(pose.topRightCorner<3, 1>().norm() < problem.levelResolution(0));
}

double
finishCandidate(PreparedProblem& problem,
                const SearchSpace& space,
                const Eigen::Matrix4d& pose,
                JointHistogram& scratch,
                AlignmentResult& result)
{
  const Parameters& p = problem.parameters();
  result.transformation = pose;
  result.refinement_iterations = 0;
  result.refinement_stages = 0;
  if (p.refinement.method == Refinement::PointToDistribution) {
    StageClock refinement_clock;
    const int coarser_stages = coarserRefinementStages(problem);
    const RefinedOptimum refined =
        refineOptimum(problem, space, result.transformation, coarser_stages);
    refinement_clock.end(result.stages, "refinement", refined.iterations);
    if (refined.accepted) {
      result.refinement_iterations = refined.iterations;
      result.refinement_stages = 1 + coarser_stages;
      result.transformation = refined.transformation;
    }
  }

  // The verdict: the search's convergence says nothing about whether the optimum is the
  // true pose; the target's surfaces do.
  StageClock verification_clock;
  result.mutual_information = problem.mutualInformation(result.transformation, scratch);
  const double finest_normalized_mi =
      scratch.overlap_voxels == 0 ? 0.0 : normalizedMutualInformation(scratch);
  result.verification = verifyAt(problem, result.transformation, scratch, false);
  result.converged = result.search_converged && result.verification.reason.empty();
  verification_clock.end(result.stages, "verification", 1);
  if (result.converged)
    refuseASecondOptimum(problem, result);
  return finest_normalized_mi;
}

bool
takeIfAgreesBetter(PreparedProblem& problem,
                   const SearchSpace& space,
                   const Eigen::Matrix4d& pose,
                   bool search_converged,
                   bool needs_shared_surface,
                   JointHistogram& scratch,
                   AlignmentResult& result,
                   double& finest_normalized_mi)
{
  AlignmentResult other; // its stages are the caller's stage's
  other.search_converged = search_converged;
  const double other_normalized_mi = finishCandidate(problem, space, pose, scratch, other);
  const bool supported = sharesSurface(other.verification);
  if (needs_shared_surface && !supported)
    return false;
  const bool better = supported != sharesSurface(result.verification)
                          ? supported
                          : other_normalized_mi > finest_normalized_mi;
  if (!better)
    return false;
  takeCandidate(std::move(other), other_normalized_mi, result, finest_normalized_mi);
  return true;
}

const NelderMeadResult*
keepTheFinestGridsChoice(PreparedProblem& problem,
                         const SearchSpace& space,
                         const std::vector<NelderMeadResult>& optima,
                         JointHistogram& scratch,
                         AlignmentResult& result,
                         double& finest_normalized_mi)
{
  const NelderMeadResult* kept = nullptr;
  for (const NelderMeadResult& optimum : optima) {
    ++result.runners_up_checked;
    if (takeIfAgreesBetter(problem, space, space.pose(optimum.x), optimum.converged, false,
                           scratch, result, finest_normalized_mi)) {
      result.runner_up_kept = true;
      kept = &optimum;
    }
  }
  return kept;
}

void
finishTheKeptRunnerUp(PreparedProblem& problem,
                      const SearchSpace& space,
                      LevelCosts& costs,
                      const CoarseToFineOptions& options,
                      const Eigen::VectorXd& from,
                      int max_iterations,
                      JointHistogram& scratch,
                      AlignmentResult& result,
                      double& finest_normalized_mi)
{
  const int left = max_iterations - result.iterations;
  if (result.search_converged || left <= 0)
    return;
  StageClock clock;
  const NelderMeadResult finished = finishOnFirstLevel(costs, options, from, left);
  result.iterations += finished.iterations;
  result.evaluations += finished.evaluations;
  AlignmentResult other; // its stages are this stage's
  other.search_converged = finished.converged;
  const double other_normalized_mi =
      finishCandidate(problem, space, space.pose(finished.x), scratch, other);
  // Finished, the same optimum (refined within half a finest voxel of the result) is taken
  // where it passes the verdict, whatever the finest grid's noise in its normalised MI.
  const bool same_trusted_optimum =
      other.converged && rmsShift(problem, result.transformation, other.transformation) <
                             kSameOptimumVoxels * problem.levelResolution(0);
  if (sharesSurface(other.verification) &&
      (other_normalized_mi >= finest_normalized_mi || same_trusted_optimum))
    takeCandidate(std::move(other), other_normalized_mi, result, finest_normalized_mi);
  clock.end(result.stages, "runner-up finished", finished.evaluations);
}

void
judgeWithLead(PreparedProblem& problem, double lead, AlignmentResult& result)
{
  Verification& v = result.verification;
  Verification without = v;
  judge(without);
  const std::string previous = v.reason;
  const Refusal previous_refusal = v.refusal;
  v.lead = lead;
  judge(v);
  if (!v.reason.empty()) {
    result.converged = false;
    return;
  }
  if (without.reason.empty()) {
    v.reason = previous;
    v.refusal = previous_refusal;
    result.converged = result.search_converged && previous.empty();
    return;
  }
  result.converged = result.search_converged;
  if (result.converged)
    refuseASecondOptimum(problem, result);
}

void
judgeWithTurnsHeld(PreparedProblem& problem, AlignmentResult& result)
{
  JointHistogram histogram;
  problem.mutualInformation(result.transformation, histogram);
  Verification held = verifyAt(problem, result.transformation, histogram, true);
  held.lead = result.verification.lead;
  held.restart_turn_deg = result.verification.restart_turn_deg;
  held.restart_shift = result.verification.restart_shift;
  judge(held);
  // Refused again, the first refusal stays: it names the free turns.
  if (!held.reason.empty())
    return;
  result.verification = std::move(held);
  result.converged = result.search_converged;
  if (result.converged)
    refuseASecondOptimum(problem, result);
}

} // namespace core
} // namespace pcl_mi
