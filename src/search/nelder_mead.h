/*
 * pcl_mi: derivative-free Nelder-Mead minimisation of a function of a few parameters.
 * Knows nothing about clouds; tested on known functions.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>

#include <functional>

namespace pcl_mi {
namespace core {

/** \brief Stopping rules of one Nelder-Mead run. */
struct NelderMeadOptions {
  /** Iteration cap (one reflection/expansion/contraction/shrink step each). */
  int max_iterations = 500;
  /** Converged when every vertex is within tolerance[i] of the best vertex in every
   * coordinate i. */
  Eigen::VectorXd tolerance;
};

/** \brief Outcome of one Nelder-Mead run. */
struct NelderMeadResult {
  Eigen::VectorXd x;      ///< best vertex
  double value = 0.0;     ///< function value at x
  int iterations = 0;     ///< iterations performed
  int evaluations = 0;    ///< function evaluations performed
  bool converged = false; ///< simplex met the tolerance (false: iteration cap)
};

/** \brief Minimises \a f with the Nelder-Mead simplex method (standard coefficients:
 * reflection 1, expansion 2, contraction 1/2, shrink 1/2).
 *
 * The initial simplex is x0 and x0 + steps[i] * e_i for each i: the sign of a step chooses
 * the side of x0 on which that edge of the simplex lies.
 */
NelderMeadResult
minimizeNelderMead(const std::function<double(const Eigen::VectorXd&)>& f,
                   const Eigen::VectorXd& x0,
                   const Eigen::VectorXd& steps,
                   const NelderMeadOptions& options);

} // namespace core
} // namespace pcl_mi
