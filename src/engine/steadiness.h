/*
 * pcl_mi: restarts of the refinement around a refused result, which tell whether the
 * refinement holds it where it is.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "engine/prepared_problem.h"
#include "engine/search_space.h"

#include <pcl_mi/types.h>

namespace pcl_mi {
namespace core {

/** \brief For a result the reliability test refused, restarts the refinement from the result
 * turned kRestartTurnDeg either way about each axis of the target's local frame (about the
 * moved source's centroid) and sets Verification::restart_turn_deg and restart_shift to the
 * farthest any restart ends from it; a restart the refinement discards counts as infinitely
 * far, and ends the restarts. Where that reaches half the success bound, the result is
 * unsteady (Verification::unsteady) and its confidence becomes kUnsteadyConfidence. A steady
 * result refused only for free turns which puts the sensors (the input frames' origins) more
 * than a voxel apart is judged again with those turns held (judgeWithTurnsHeld()): the
 * refinement's hold does not depend on whether the search met its tolerance. No pose
 * changes. Converged results, and alignments
 * without the refinement, are left as they are: their restarts would cost six refinements for
 * nothing the verdict uses. */
void
judgeSteadiness(PreparedProblem& problem, const SearchSpace& space, AlignmentResult& result);

/** \brief Turn (degrees) of each restart. */
constexpr double kRestartTurnDeg = 2.0;

} // namespace core
} // namespace pcl_mi
