/*
 * pcl_mi: the reliability test of an alignment result: the evidence gathered at the result
 * and at poses around it, the directions it leaves free, the confidence and the covariance
 * (their models: confidence_model.h, plane_information.h), and the verdict.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "features/source_samples.h"
#include "refine/refinement.h"

#include <pcl_mi/types.h>

#include <Eigen/Core>

#include <functional>

namespace pcl_mi {
namespace core {

/** Confidence at or above which a result passes the reliability test: a result passes
 * when it is right with a probability of at least 95 %. */
constexpr double kReliableConfidence = 0.95;
/** The success bound the confidence is fitted to: a result within this shift (metres,
 * Parameters::units_per_metre) and turn of the true pose is right. The tests of a held-back
 * result derive their bounds from it. */
constexpr double kSuccessShiftMetres = 0.5;
constexpr double kSuccessTurnDeg = 2.0;

/** Confidence of a refused result that restarts of the refinement find unsteady
 * (judgeSteadiness()): the share of such results that were right over the shared sets'
 * results (docs/benchmarks.md, "The confidence of unsteady results"). */
constexpr double kUnsteadyConfidence = 0.06;

/** Confidence of a result refused as degenerate that leaves the sensors where they were
 * (Verification::sensors_in_place): the share of such results that were right
 * (docs/benchmarks.md, "Degenerate where the sensors stand where they were"). */
constexpr double kInPlaceDegenerateConfidence = 0.04;

/** Confidence of a result that the alignment of the clouds swapped confirmed
 * (Verification::reverse_confirmed): the share of such results that were right
 * (docs/benchmarks.md, "Confirmed by the clouds swapped"). */
constexpr double kReverseConfirmedConfidence = 0.99;

/** Confidence of a result that the alignment of the clouds swapped was asked to confirm and
 * did not: the share of such results that were right (docs/benchmarks.md, "Confirmed by the
 * clouds swapped"; measured again and kept in "A free side confirms a result that holds every
 * direction"). */
constexpr double kReverseUnconfirmedConfidence = 0.77;

/** Fewest inliers (source samples on a target surface) that can hold six degrees of
 * freedom with room to spare; a result with fewer does not pass. */
constexpr std::size_t kMinimumInliers = 30;

/** \brief True where the clouds share enough surface at the verified pose to hold a pose
 * (at least kMinimumInliers inliers). */
inline bool
sharesSurface(const Verification& verification)
{
  return verification.inliers >= kMinimumInliers;
}

/** \brief True where the \a k-th (0 or 1) least observable direction of \a v is free: its
 * contrast is low and the MI does not hold it (false for a NaN loss), nor, for a turn, the
 * refinement (Verification::free_turns_held). */
bool
isFree(const Verification& v, int k);

/** \brief True where \a v leaves a direction free and every free direction is mostly a turn
 * (a unit move [t, omega * radius] at least 0.7 a turn). */
bool
onlyTurnsFree(const Verification& v);

/** \brief Sets the confidence of \a v from its evidence (kInPlaceDegenerateConfidence for a
 * degenerate result that leaves the sensors in place), and the reason it fails the
 * reliability test (empty where it passes). verifyPose() calls it; call it again after
 * setting Verification::lead. */
void
judge(Verification& v);

/** \brief The MI on the finest grid at a source-to-target pose between the local frames
 * (target_local = rotation * source_local + translation). */
using FinestMutualInformation =
    std::function<double(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation)>;

/** \brief Where a result puts the source's sensor against the target's: the input frames'
 * origins and vertical axes stand for the sensors, as for the azimuth coverage. */
enum class SensorPlacement {
  kApart,            ///< more than a voxel apart
  kSamePlace,        ///< within a voxel, their vertical axes tilted apart
  kSamePlaceAndAxis, ///< within a voxel, tilted apart less than the probes' tilt; any heading
};

/** \brief The verification of the pose \a rotation, \a translation (source local to target
 * local) against \a target, on a grid of voxel size \a resolution. \a histogram is the joint
 * histogram at the pose; \a target_centroid and \a target_axes place the target local frame
 * in the target's input frame (input = centroid + axes * local), in which the covariance
 * (about the input frame's origin) and the observability directions are given.
 * \a placement says where the pose leaves the sensors (the caller decides): standing at one
 * place, their scan patterns are centred on one point, and a shift moves one off the other
 * whatever the surfaces, so only surfaces that a move crosses count as holding a free
 * direction that is mostly a shift; with their vertical axes also within the probes' tilt,
 * the patterns may fall on one another under any move, and that holds for every free
 * direction. Elsewhere a free direction that is mostly a turn tilting the source is asked of
 * \a finest_mi, where given, which may hold it (Verification::free_turn_mi_loss). It runs on
 * up to \a num_threads threads, with the same result on any number. With
 * \a free_turns_held, a free direction that is mostly a turn does not count as free
 * (Verification::free_turns_held): the caller has found that the refinement holds it. */
Verification
verifyPose(const TargetDistributions& target,
           const SourceSamples& source,
           const Eigen::Matrix3d& rotation,
           const Eigen::Vector3d& translation,
           double resolution,
           const JointHistogram& histogram,
           const Eigen::Vector3d& target_centroid,
           const Eigen::Matrix3d& target_axes,
           SensorPlacement placement,
           int num_threads = 1,
           const FinestMutualInformation& finest_mi = {},
           bool free_turns_held = false);

} // namespace core
} // namespace pcl_mi
