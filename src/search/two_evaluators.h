/*
 * pcl_mi: independent Nelder-Mead runs on two evaluators, one thread each, where an
 * evaluator with no run left helps the other's.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "search/nelder_mead.h"

#include <Eigen/Core>

#include <functional>
#include <vector>

namespace pcl_mi {
namespace core {

/** \brief The value of \a x by evaluator \a slot (0 or 1). The two slots are called
 * concurrently; one slot never is. */
using SlotCost = std::function<double(int slot, const Eigen::VectorXd& x)>;

/** \brief Drives every run of \a runs to its end on two evaluators, one thread each. Each
 * takes the next run not yet started as soon as it is done with one, so that a short run
 * does not leave its evaluator waiting for a long one. Once no run is left to start, an
 * evaluator helps the other's run instead of waiting: it evaluates the second half of a
 * request of several points (a first simplex, a shrink), or the run's spare point beside a
 * reflection asked alone. Every run is told the values it would be told alone, so its
 * result is the same. With \a threads below 2, evaluator 0 runs them one after another.
 * Returns the requests answered, summed over the runs. */
int
runOnTwoEvaluators(std::vector<NelderMeadRun>& runs, const SlotCost& cost, int threads = 2);

} // namespace core
} // namespace pcl_mi
