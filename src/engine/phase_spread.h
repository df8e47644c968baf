/*
 * pcl_mi: how far a result moves when the cells that summarise the clouds cut their surfaces
 * elsewhere, and what that says about the covariance.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "engine/prepared_problem.h"

#include <Eigen/Core>

namespace pcl_mi {
namespace core {

/** \brief The factor, 1 or more, by which \a covariance (the verification's, of the result
 * \a pose: source to target, input frames) is too small where the result depends on where
 * the cells cut the surfaces. The result is refined again with the source's samples and the
 * target's cubes moved half a cell along every axis, to the pose P1 with covariance C1; with
 * d the left increment from \a pose to P1, the factor is max(1, d^T (C0 + C1)^-1 d / 6),
 * C0 = \a covariance: two draws of that error differ by d, whose expected form is 6 when the
 * covariances hold it. 1 where \a covariance is zero (a degenerate result) or the refinement
 * is switched off. */
double
phaseSpreadScale(PreparedProblem& problem,
                 const Eigen::Matrix4d& pose,
                 const Eigen::Matrix<double, 6, 6>& covariance);

} // namespace core
} // namespace pcl_mi
