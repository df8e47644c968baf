/*
 * pcl_mi: the confidence model: the probability that a result is right, from the evidence
 * at it, a logistic model fitted and calibrated on real scans.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_mi/types.h>

namespace pcl_mi {
namespace core {

/** \brief The confidence the evidence in \a v gives (normalised MI, contrasts, inliers and,
 * where set, the lead), through calibratedLogit(). */
double
confidenceOf(const Verification& v);

/** \brief The confidence model's logit \a z through the calibration's monotone map: the
 * identity outside the span from its first knot to logit(kReliableConfidence), so that a
 * confidence reaches kReliableConfidence exactly where the model's does. */
double
calibratedLogit(double z);

} // namespace core
} // namespace pcl_mi
