/*
 * pcl_mi: the look for a second optimum along the direction the surfaces constrain least.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "engine/prepared_problem.h"

#include <Eigen/Core>

#include <optional>

namespace pcl_mi {
namespace core {

/** \brief Probes the MI on the finest grid at \a pose moved 1, 2 and 3 voxels either way
 * along the translation that \a covariance (6x6, [t, rotation], input frame)
 * leaves least certain. Returns the best probe where it scores a higher MI than
 * \a mutual_information, the pose's own; none otherwise, or for a zero covariance. A scene
 * that repeats along a corridor or a row of facades has a second optimum a few metres
 * along it, which the verdict's evidence, all gathered at the pose, does not see. */
std::optional<Eigen::Matrix4d>
higherAlongLeastConstrained(PreparedProblem& problem,
                            const Eigen::Matrix4d& pose,
                            double mutual_information,
                            const Eigen::Matrix<double, 6, 6>& covariance);

/** \brief Number of poses higherAlongLeastConstrained() evaluates. */
constexpr int kSecondOptimumProbes = 6;

} // namespace core
} // namespace pcl_mi
