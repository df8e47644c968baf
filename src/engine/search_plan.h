/*
 * pcl_mi: how an alignment searches from its guess: the search space and the first search's
 * options, and the wider second search of a 360-degree pair.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "engine/mutual_information_costs.h"
#include "engine/prepared_problem.h"
#include "engine/search_space.h"
#include "search/coarse_to_fine.h"

#include <pcl_mi/types.h>

#include <Eigen/Core>

namespace pcl_mi {
namespace core {

/** How an alignment searches from its guess: the space and the first search's options. */
struct SearchPlan {
  SearchSpace space;
  CoarseToFineOptions options;
  bool about_sensor; ///< rotations turn the source about its sensor
  bool leveled;      ///< the space runs along the target's up direction
};

/** \brief The search from \a guess, capped at \a max_iterations. Rotations turn the guessed
 * source about its centroid, or, for a narrow field of view with wider tilt steps, about its
 * sensor. A 360-degree pair whose up directions disagree is searched from the guess leveled,
 * along the target's up: a tilted sensor's roll and pitch are what the simplex finds least
 * well. A pair that agrees on an up far from z (a sensor mounted tilted) is searched along it
 * too. */
SearchPlan
planSearch(const PreparedProblem& problem, const Eigen::Matrix4d& guess, int max_iterations);

/** \brief A 360-degree pair's second search, wider than the first (\a options): more
 * headings, the tilt steps of a handheld sensor and starts along x, on what the cap
 * (\a max_iterations) leaves after \a result's iterations. Its optima are judged as
 * runners-up are (keepTheFinestGridsChoice()), into \a result and \a finest_normalized_mi. */
void
searchWider(PreparedProblem& problem,
            const SearchSpace& space,
            LevelCosts& costs,
            const CoarseToFineOptions& options,
            int max_iterations,
            JointHistogram& scratch,
            AlignmentResult& result,
            double& finest_normalized_mi);

} // namespace core
} // namespace pcl_mi
