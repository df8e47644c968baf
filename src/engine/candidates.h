/*
 * pcl_mi: an optimum made a candidate result (refined, then given the verdict) and weighed
 * against the result it might replace.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "engine/prepared_problem.h"
#include "engine/search_space.h"
#include "search/coarse_to_fine.h"

#include <pcl_mi/types.h>

#include <Eigen/Core>

#include <vector>

namespace pcl_mi {
namespace core {

/** \brief Refines \a pose and gives it the verdict, into \a result (whose search_converged
 * is set). Returns the normalised MI on the finest grid at the final pose, by which candidates
 * of different overlaps compare (takeIfAgreesBetter()). */
double
finishCandidate(PreparedProblem& problem,
                const SearchSpace& space,
                const Eigen::Matrix4d& pose,
                JointHistogram& scratch,
                AlignmentResult& result);

/** \brief Refines and verifies \a pose, whose search's convergence is \a search_converged,
 * and makes it the result where it agrees better with the target: it lies on surfaces the
 * clouds share where the result does not, or, alike in that, it has the higher normalised MI
 * on the finest grid than the result's own, \a finest_normalized_mi (then updated). With
 * \a needs_shared_surface, a candidate that shares too little surface is never taken.
 * Returns true where it was taken. */
bool
takeIfAgreesBetter(PreparedProblem& problem,
                   const SearchSpace& space,
                   const Eigen::Matrix4d& pose,
                   bool search_converged,
                   bool needs_shared_surface,
                   JointHistogram& scratch,
                   AlignmentResult& result,
                   double& finest_normalized_mi);

/** \brief Refines and verifies each of \a optima (search vectors with their searches'
 * convergence) and puts the one with the highest normalised MI on the finest grid into
 * \a result where that is higher than the result's own, \a finest_normalized_mi (updated);
 * counts them in result.runners_up_checked. Normalised MI, as on the coarsest level,
 * because the candidates' overlaps differ. A candidate where the clouds share surface beats
 * one where they share too little whatever their MI: the MI of a few voxels at the edge of
 * the overlap can be high by chance, and such a pose aligns nothing. */
const NelderMeadResult*
keepTheFinestGridsChoice(PreparedProblem& problem,
                         const SearchSpace& space,
                         const std::vector<NelderMeadResult>& optima,
                         JointHistogram& scratch,
                         AlignmentResult& result,
                         double& finest_normalized_mi);

/** \brief Finishes the search of the runner-up \a result holds, which stopped at \a from
 * (its search vector) at a candidate's share of the iteration cap, on what the cap
 * (\a max_iterations) leaves: from where it got, as the search finishes a capped candidate
 * that wins. Nothing is done where its search converged or the cap leaves nothing. The
 * finished optimum is refined and verified, and stands where it lies on surface the clouds
 * share and the finest grid's normalised MI prefers it at least as much, or where it passes
 * the verdict and is the same optimum: refined within half a finest voxel of the result
 * (root mean square shift of the source's samples). */
void
finishTheKeptRunnerUp(PreparedProblem& problem,
                      const SearchSpace& space,
                      LevelCosts& costs,
                      const CoarseToFineOptions& options,
                      const Eigen::VectorXd& from,
                      int max_iterations,
                      JointHistogram& scratch,
                      AlignmentResult& result,
                      double& finest_normalized_mi);

/** \brief True where \a pose puts the source's sensor (its input frame's origin) more than
 * a finest voxel from the target's (a translation that is not finite counts as apart). */
bool
sensorsApart(const PreparedProblem& problem, const Eigen::Matrix4d& pose);

/** \brief Judges \a result, refused only for free turns that the refinement holds, again with
 * those turns held (Verification::free_turns_held): where it then passes, it converges and
 * takes the second-optimum test if its search converged, and is a passed result whose search
 * was capped if not; otherwise it stays as it was. */
void
judgeWithTurnsHeld(PreparedProblem& problem, AlignmentResult& result);

/** \brief Judges \a result again with \a lead, its optimum's lead over the others nearby
 * (Verification::lead). A result whose evidence passed without it has had the
 * second-optimum test, whose outcome stands while the evidence still passes; one that
 * passes only now takes that test. */
void
judgeWithLead(PreparedProblem& problem, double lead, AlignmentResult& result);

} // namespace core
} // namespace pcl_mi
