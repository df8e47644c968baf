/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "verify/confidence_model.h"

#include "verify/verification.h"

#include <algorithm>
#include <cmath>
#include <iterator>

namespace pcl_mi {
namespace core {

namespace {

/** The logistic model: confidence = 1 / (1 + exp(-(intercept + sum of weight * term))),
 * fitted by scripts/fit_confidence.py on the evidence of every result of the real sets in
 * docs/benchmarks.md ("The verdict"), each set weighing the same; the intercept was refitted
 * alone (-weights) after the narrow-view refinement stages and scanned turns made more Livox
 * results right. */
constexpr double kIntercept = -9.66;
constexpr double kWeightNormalizedMi = 19.70;
constexpr double kWeightWeakestContrast = 7.40;
constexpr double kWeightInlierLogit = 0.46;
constexpr double kWeightLogInliers = 0.65;
constexpr double kWeightPeakContrast = 1.42;
/** Inlier fractions are clamped to [kFractionClamp, 1 - kFractionClamp] for the logit. */
constexpr double kFractionClamp = 1e-3;

/** A narrow view's lead (Verification::lead), clamped to [kLeadLow, kLeadHigh], and the
 * offset that comes with it, fitted by scripts/fit_confidence.py -lead on the narrow views'
 * results with the terms above kept: a result no other optimum nearby comes close to is the
 * one place where the clouds agree, and a slide along a facade is not. */
constexpr double kWeightLead = 19.72;
constexpr double kLeadOffset = -1.63;
constexpr double kLeadLow = -0.3;
constexpr double kLeadHigh = 0.5;

/** The calibration of the model's logit (the lead term included) below the verdict's
 * threshold: a monotone piecewise-linear map through these knots' values, fitted by
 * scripts/fit_confidence.py -calibration on every result of the real sets and of scans of
 * unrelated places but those that take kUnsteadyConfidence (docs/benchmarks.md, "A
 * calibrated confidence", "The confidence of unsteady results"): a logistic line in the
 * logit does not follow how the success of the uncertain results rises. The map runs from
 * the first knot to the threshold's logit, which it keeps, and leaves the logit outside that
 * span as it is: it changes no verdict. */
constexpr double kCalibrationKnots[] = {-5.0, -3.0, -2.0, -1.0, 0.0, 1.0, 2.0};
constexpr double kCalibratedLogits[] = {-5.0, -1.43, -0.65, -0.24, 1.43, 1.58, 2.39};

} // namespace

double
confidenceOf(const Verification& v)
{
  const double f = std::clamp(v.inlier_fraction, kFractionClamp, 1.0 - kFractionClamp);
  const double z = kIntercept + kWeightNormalizedMi * v.normalized_mi +
                   kWeightWeakestContrast * v.weakest_contrast +
                   kWeightInlierLogit * std::log(f / (1.0 - f)) +
                   kWeightLogInliers * std::log1p(static_cast<double>(v.inliers)) +
                   kWeightPeakContrast * v.peak_contrast +
                   (std::isnan(v.lead) ? 0.0
                                       : kWeightLead * std::clamp(v.lead, kLeadLow, kLeadHigh) +
                                             kLeadOffset);
  return 1.0 / (1.0 + std::exp(-calibratedLogit(z)));
}

double
calibratedLogit(double z)
{
  const double threshold = std::log(kReliableConfidence / (1.0 - kReliableConfidence));
  if (!(z > kCalibrationKnots[0] && z < threshold))
    return z;
  constexpr int n = static_cast<int>(std::size(kCalibrationKnots));
  int i = 0;
  while (i + 1 < n && z >= kCalibrationKnots[i + 1])
    ++i;
  const double upper = i + 1 < n ? kCalibrationKnots[i + 1] : threshold;
  const double upper_value = i + 1 < n ? kCalibratedLogits[i + 1] : threshold;
  const double t = (z - kCalibrationKnots[i]) / (upper - kCalibrationKnots[i]);
  return kCalibratedLogits[i] + t * (upper_value - kCalibratedLogits[i]);
}

} // namespace core
} // namespace pcl_mi
