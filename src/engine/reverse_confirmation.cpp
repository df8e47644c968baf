/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/reverse_confirmation.h"

#include "util/left_increment.h"
#include "verify/verification.h"

#include <Eigen/Geometry>

#include <cmath>
#include <iomanip>
#include <sstream>
#include <tuple>
#include <utility>

namespace pcl_mi {
namespace core {

namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

/** \a covariance of a left increment [delta, omega] of the pose \a pose's inverse, as one of
 * \a pose: T' = D T gives T'^-1 = T^-1 D^-1, whose increment is T^-1 D^-1 T. */
Matrix6d
invertedCovariance(const Eigen::Matrix4d& pose, const Matrix6d& covariance)
{
  const Eigen::Matrix4d inverse = pose.inverse();
  const Eigen::Matrix3d r = inverse.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = inverse.topRightCorner<3, 1>();
  Matrix6d a = Matrix6d::Zero();
  a.topLeftCorner<3, 3>() = -r;
  a.topRightCorner<3, 3>() = -crossMatrix(t) * r;
  a.bottomRightCorner<3, 3>() = -r;
  return a * covariance * a.transpose();
}

/** The shift of the target frame's origin, and the turn in degrees, of \a difference. */
std::pair<double, double>
shiftAndTurn(const Eigen::Matrix4d& difference)
{
  return {difference.topRightCorner<3, 1>().norm(),
          Eigen::AngleAxisd(Eigen::Matrix3d(difference.topLeftCorner<3, 3>())).angle() * 180.0 /
              M_PI};
}

} // namespace

bool
endsTogether(const Eigen::Matrix4d& pose, const Eigen::Matrix4d& other, double units_per_metre)
{
  const auto [shift, turn] = shiftAndTurn(other.inverse() * pose);
  return shift < kAgreementShiftMetres * units_per_metre && turn < kAgreementTurnDeg;
}

bool
mayBeConfirmed(const AlignmentResult& result)
{
  const Verification& v = result.verification;
  if (result.converged || !result.error.empty() || v.unsteady ||
      !(v.confidence >= kConfirmableConfidence))
    return false;
  switch (v.refusal) {
  case Refusal::Degenerate:
  case Refusal::WeakEvidence:
  case Refusal::SecondOptimum:
  case Refusal::LittleSharedSurface:
    return true;
  case Refusal::None: // passed, its search capped
    return !result.search_converged;
  }
  return false;
}

bool
holdsTheFreeTurn(const Verification& v, const Verification& w)
{
  return v.refusal == Refusal::Degenerate && onlyTurnsFree(v) && w.refusal == Refusal::None &&
         w.confidence >= kReliableConfidence;
}

bool
confirmWithTheReverse(const AlignmentResult& back, double units_per_metre, AlignmentResult& result)
{
  Verification& v = result.verification;
  if (!back.error.empty())
    return false;
  std::tie(v.reverse_shift, v.reverse_turn_deg) =
      shiftAndTurn(result.transformation * back.transformation);
  const Verification& w = back.verification;
  // A side that leaves a direction free says nothing along it, so it confirms only a result
  // that holds every direction itself, on enough surface, and names no second optimum.
  const bool result_holds_all =
      v.refusal == Refusal::None || v.refusal == Refusal::WeakEvidence;
  // Where the result leaves only a turn free, its own end along that turn is as good as
  // arbitrary; a swapped side that passes every test itself holds the turn, so the two need
  // only end within the success bound's turn of each other.
  const double turn_tolerance =
      holdsTheFreeTurn(v, w) ? kHeldFreeTurnAgreementDeg : kAgreementTurnDeg;
  std::ostringstream why;
  if (!(v.reverse_shift < kAgreementShiftMetres * units_per_metre) ||
      !(v.reverse_turn_deg < turn_tolerance))
    why << "it ends more than " << kAgreementShiftMetres << " m or " << turn_tolerance
        << " deg away";
  else if (w.refusal == Refusal::LittleSharedSurface)
    why << "it shares too little surface itself";
  else if (w.refusal == Refusal::Degenerate && !result_holds_all)
    why << "it leaves a direction free itself, and this result "
        << (v.refusal == Refusal::Degenerate      ? "leaves one free too"
            : v.refusal == Refusal::SecondOptimum ? "names a second optimum"
                                                  : "shares too little surface");
  else if (!(w.confidence >= kConfirmingConfidence))
    why << "its own confidence, " << std::fixed << std::setprecision(2) << w.confidence
        << ", is under " << kConfirmingConfidence;
  if (!why.str().empty()) {
    v.confidence = kReverseUnconfirmedConfidence;
    v.reverse_reason = why.str();
    return false;
  }
  v.reverse_confirmed = true;
  v.confidence = kReverseConfirmedConfidence;
  if (v.covariance.isZero())
    v.covariance = invertedCovariance(back.transformation, w.covariance);
  v.reason.clear();
  v.refusal = Refusal::None;
  result.converged = true;
  return true;
}

} // namespace core
} // namespace pcl_mi
