/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/reverse_confirmation.h"

#include "util/left_increment.h"
#include "verify/verification.h"

#include <Eigen/Eigenvalues>
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

/** The map from a left increment D of \a pose's inverse to the left increment of \a pose it
 * makes: (D pose^-1)^-1 = pose D^-1 = (pose D^-1 pose^-1) pose, minus D carried by \a pose's
 * adjoint. */
Matrix6d
inverseIncrementMap(const Eigen::Matrix4d& pose)
{
  const Eigen::Matrix3d r = pose.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = pose.topRightCorner<3, 1>();
  Matrix6d a = Matrix6d::Zero();
  a.topLeftCorner<3, 3>() = -r;
  a.topRightCorner<3, 3>() = -crossMatrix(t) * r;
  a.bottomRightCorner<3, 3>() = -r;
  return a;
}

/** \a covariance of a left increment [delta, omega] of the pose \a pose's inverse, as one of
 * \a pose. */
Matrix6d
invertedCovariance(const Eigen::Matrix4d& pose, const Matrix6d& covariance)
{
  const Matrix6d a = inverseIncrementMap(pose);
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

using Vector6d = Eigen::Matrix<double, 6, 1>;

/** The inverse of the mean of \a v's information and \a w's, carried over from the swapped
 * pose \a back: about either side's covariance where both hold a direction, twice the holding
 * side's where the other leaves it free. Zero where the two leave a direction without
 * information. */
Matrix6d
meanInformationCovariance(const Verification& v, const Verification& w, const Eigen::Matrix4d& back)
{
  const Matrix6d a = inverseIncrementMap(back); // the result's increments to back's
  const Matrix6d mean = 0.5 * (Matrix6d(v.information) + a.transpose() * w.information * a);
  const Eigen::SelfAdjointEigenSolver<Matrix6d> solver(mean);
  if (!(solver.eigenvalues()[0] > 0.0))
    return Matrix6d::Zero();
  return solver.eigenvectors() * solver.eigenvalues().cwiseInverse().asDiagonal() *
         solver.eigenvectors().transpose();
}

/** The left increment [delta, omega] about the input frame's origin that the \a k-th
 * observability direction of \a v ([t, omega * radius] about its centre) stands for. */
Vector6d
incrementAboutOrigin(const Verification& v, int k)
{
  Vector6d about_centre = v.observability_directions.col(k);
  about_centre.tail<3>() /= v.observability_radius;
  return incrementMovedBy(-Eigen::Vector3d(v.observability_centre)) * about_centre;
}

/** \a increment (about the input frame's origin) in \a v's observability units: about its
 * centre, turns scaled at its radius, unit length. */
Vector6d
inObservabilityUnits(const Verification& v, const Vector6d& increment)
{
  Vector6d u = incrementMovedBy(Eigen::Vector3d(v.observability_centre)) * increment;
  u.tail<3>() *= v.observability_radius;
  return u.normalized();
}

} // namespace

bool
holdsTheFreeDirections(const Verification& v, const Verification& w, const Eigen::Matrix4d& back)
{
  const bool w_free[2] = {isFree(w, 0), isFree(w, 1)};
  const int w_free_count = int(w_free[0]) + int(w_free[1]);
  Eigen::Matrix<double, 6, Eigen::Dynamic> free(6, w_free_count);
  for (int k = 0, column = 0; k < 2; ++k)
    if (w_free[k])
      free.col(column++) = w.observability_directions.col(k);
  const Matrix6d to_back = inverseIncrementMap(back); // the result's increments to back's
  bool any = false;
  for (int k = 0; k < 2; ++k) {
    if (!isFree(v, k))
      continue;
    any = true;
    const Vector6d u = inObservabilityUnits(w, to_back * incrementAboutOrigin(v, k));
    const Vector6d across =
        w_free_count == 0 ? u : Vector6d(u - free * free.colPivHouseholderQr().solve(u));
    if (!(across.squaredNorm() >= kHeldAcrossShare))
      return false;
  }
  return any;
}

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
  // that holds every direction itself, on enough surface, and names no second optimum, or
  // one that leaves free only directions that the side holds: each side then holds what the
  // other leaves free.
  const bool result_holds_all =
      v.refusal == Refusal::None || v.refusal == Refusal::WeakEvidence;
  const bool free_directions_held = v.refusal == Refusal::Degenerate &&
                                    w.refusal == Refusal::Degenerate &&
                                    holdsTheFreeDirections(v, w, back.transformation);
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
  else if (w.refusal == Refusal::Degenerate && !result_holds_all && !free_directions_held)
    why << "it leaves a direction free itself, and this result "
        << (v.refusal == Refusal::Degenerate      ? "leaves one free within 45 deg of it"
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
    v.covariance = w.covariance.isZero()
                       ? meanInformationCovariance(v, w, back.transformation)
                       : invertedCovariance(back.transformation.inverse(), w.covariance);
  v.reason.clear();
  v.refusal = Refusal::None;
  result.converged = true;
  return true;
}

} // namespace core
} // namespace pcl_mi
