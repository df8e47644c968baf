/*
 * pcl_mi: the chance that a result lies within the success bound, by its covariance, and the
 * verdict's use of it where the evidence is sparse.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "verify/verification.h"

#include <pcl_mi/types.h>

#include <Eigen/Core>

namespace pcl_mi {
namespace core {

/** Inliers under which a result's covariance is asked as well: twice the fewest that hold
 * six degrees of freedom (kMinimumInliers). */
constexpr std::size_t kSparseInliers = 2 * kMinimumInliers;

/** \brief The chance that the true pose lies within \a shift (the clouds' units) and
 * \a turn_deg of \a pose, where the left increment [t, rotation vector] that carries \a pose
 * onto the true pose (about the input frame's origin, as Verification::covariance) is drawn
 * from N(0, \a covariance): the true translation then differs by t + rotation vector x
 * translation. Counted over a fixed set of draws, so that equal inputs give equal chances;
 * 1 where \a covariance is zero or not finite. */
double
chanceWithinBound(const Eigen::Matrix<double, 6, 6>& covariance,
                  const Eigen::Matrix4d& pose,
                  double shift,
                  double turn_deg);

/** \brief True where \a result converged by its own tests on fewer than kSparseInliers
 * inliers and has a covariance: where the evidence is that sparse, the optimum may be the
 * right one and the pose still spread over more than the success bound. False where the
 * clouds swapped confirmed it (Verification::reverse_confirmed). */
bool
spreadMatters(const AlignmentResult& result);

/** \brief Multiplies the confidence of \a result by the chance that its pose lies within the
 * success bound (kSuccessShiftMetres times \a units_per_metre, kSuccessTurnDeg) by its
 * covariance times \a covariance_scale (RegistrationCore::covarianceScale(), as
 * getCovariance() reports it), and refuses it for weak evidence where that leaves the
 * confidence under kReliableConfidence. Call it where spreadMatters(). No pose changes. */
void
weighTheSpread(double covariance_scale, double units_per_metre, AlignmentResult& result);

} // namespace core
} // namespace pcl_mi
