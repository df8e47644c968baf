/*
 * The alignment of the clouds swapped confirms a refused result only where it agrees, shares
 * surface with a confidence of its own, and holds every direction where the result leaves one
 * free (or, free itself, the directions the result leaves), names a second optimum or shares
 * too little surface; a confirmed result without a covariance of its own takes the swapped
 * one's, carried over to its pose, or the inverse of their mean information. Where the result
 * leaves only a turn free and the swapped side passes itself, the turn agrees within the bound.
 */
#include "engine/reverse_confirmation.h"
#include "verify/verification.h"

#include <Eigen/Geometry>

#include <gtest/gtest.h>

#include <cmath>

using pcl_mi::AlignmentResult;
using pcl_mi::Refusal;
using pcl_mi::Verification;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

namespace {

Eigen::Matrix4d
pose(double x, double y, double z, double roll, double pitch, double yaw)
{
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.topLeftCorner<3, 3>() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  t.topRightCorner<3, 1>() << x, y, z;
  return t;
}

/** A result held back for weak evidence at \a at, its search converged. */
AlignmentResult
heldBack(const Eigen::Matrix4d& at)
{
  AlignmentResult r;
  r.transformation = at;
  r.search_converged = true;
  r.verification.refusal = Refusal::WeakEvidence;
  r.verification.reason = "the evidence is weak";
  r.verification.confidence = 0.9;
  r.verification.covariance = Matrix6d::Identity() * 1e-4;
  return r;
}

/** The swapped alignment's result at \a at, passing. */
AlignmentResult
swapped(const Eigen::Matrix4d& at)
{
  AlignmentResult b;
  b.transformation = at;
  b.search_converged = true;
  b.converged = true;
  b.verification.confidence = 0.99;
  b.verification.covariance = Matrix6d::Identity() * 1e-4;
  return b;
}

/** The left increment [delta, omega] that takes \a from to \a to (to = D from), to first order. */
Eigen::Matrix<double, 6, 1>
increment(const Eigen::Matrix4d& from, const Eigen::Matrix4d& to)
{
  const Eigen::Matrix4d d = to * from.inverse();
  Eigen::Matrix<double, 6, 1> x;
  x.head<3>() = d.topRightCorner<3, 1>();
  const Eigen::Matrix3d w = d.topLeftCorner<3, 3>() - Eigen::Matrix3d::Identity();
  x.tail<3>() << w(2, 1), w(0, 2), w(1, 0);
  return x;
}

/** The small move by \a e along parameter \a k of [x, y, z, roll, pitch, yaw]: a shift, or a
 * turn about the origin's axis. */
Eigen::Matrix4d
smallMove(int k, double e)
{
  Eigen::Matrix4d d = Eigen::Matrix4d::Identity();
  if (k < 3)
    d(k, 3) = e;
  else
    d.topLeftCorner<3, 3>() = Eigen::AngleAxisd(e, Eigen::Vector3d::Unit(k - 3)).toRotationMatrix();
  return d;
}

} // namespace

TEST(ReverseConfirmation, OnlyAgreementWithASteadyHoldingOtherSideConfirms)
{
  const Eigen::Matrix4d at = pose(3.0, -1.0, 0.2, 0.05, -0.02, 0.6);
  const AlignmentResult refused = heldBack(at);
  ASSERT_TRUE(pcl_mi::core::mayBeConfirmed(refused));

  AlignmentResult r = refused;
  // 0.1 m and 0.3 deg apart: confirmed, with the share of such results.
  EXPECT_TRUE(pcl_mi::core::confirmWithTheReverse(
      swapped((pose(0.1, 0.0, 0.0, 0.0, 0.0, 0.3 * M_PI / 180.0) * at).inverse()), 1.0, r));
  EXPECT_TRUE(r.converged);
  EXPECT_TRUE(r.verification.reverse_confirmed);
  EXPECT_TRUE(r.verification.reason.empty());
  EXPECT_EQ(r.verification.refusal, Refusal::None);
  EXPECT_DOUBLE_EQ(r.verification.confidence, pcl_mi::core::kReverseConfirmedConfidence);
  EXPECT_NEAR(r.verification.reverse_turn_deg, 0.3, 1e-9);
  EXPECT_TRUE(r.verification.reverse_reason.empty());

  // Too far apart in shift or in turn.
  r = refused;
  EXPECT_FALSE(pcl_mi::core::confirmWithTheReverse(
      swapped((pose(0.3, 0.0, 0.0, 0.0, 0.0, 0.0) * at).inverse()), 1.0, r));
  EXPECT_FALSE(r.converged);
  EXPECT_NEAR(r.verification.reverse_shift, 0.3, 1e-9);
  EXPECT_DOUBLE_EQ(r.verification.confidence, pcl_mi::core::kReverseUnconfirmedConfidence);
  EXPECT_EQ(r.verification.reverse_reason, "it ends more than 0.25 m or 0.5 deg away");
  r = refused;
  EXPECT_FALSE(pcl_mi::core::confirmWithTheReverse(
      swapped((pose(0.0, 0.0, 0.0, 0.6 * M_PI / 180.0, 0.0, 0.0) * at).inverse()), 1.0, r));
  // The shift is in metres: in millimetres, 0.3 units is close and 300 are not.
  r = refused;
  EXPECT_TRUE(pcl_mi::core::confirmWithTheReverse(
      swapped((pose(0.3, 0.0, 0.0, 0.0, 0.0, 0.0) * at).inverse()), 1000.0, r));
  r = refused;
  EXPECT_FALSE(pcl_mi::core::confirmWithTheReverse(
      swapped((pose(300.0, 0.0, 0.0, 0.0, 0.0, 0.0) * at).inverse()), 1000.0, r));

  // The other side shares too little surface, or is weak.
  AlignmentResult little = swapped(at.inverse());
  little.verification.refusal = Refusal::LittleSharedSurface;
  r = refused;
  EXPECT_FALSE(pcl_mi::core::confirmWithTheReverse(little, 1.0, r));
  EXPECT_EQ(r.verification.reverse_reason, "it shares too little surface itself");
  // The other side leaves a direction free: it says nothing along it, so it confirms a result
  // that holds every direction itself (weak evidence, or passed with its search capped), which
  // keeps its own covariance, and not one that leaves a direction free, names a second optimum
  // or shares too little surface.
  AlignmentResult free_side = swapped(at.inverse());
  free_side.converged = false;
  free_side.verification.refusal = Refusal::Degenerate;
  free_side.verification.covariance.setZero();
  r = refused;
  EXPECT_TRUE(pcl_mi::core::confirmWithTheReverse(free_side, 1.0, r));
  EXPECT_TRUE(r.verification.covariance.isApprox(refused.verification.covariance));
  r = refused;
  r.verification.refusal = Refusal::None; // passed, its search capped
  r.search_converged = false;
  EXPECT_TRUE(pcl_mi::core::confirmWithTheReverse(free_side, 1.0, r));
  for (const Refusal own :
       {Refusal::Degenerate, Refusal::SecondOptimum, Refusal::LittleSharedSurface}) {
    r = refused;
    r.verification.refusal = own;
    EXPECT_FALSE(pcl_mi::core::confirmWithTheReverse(free_side, 1.0, r));
    EXPECT_FALSE(r.converged);
    EXPECT_EQ(r.verification.reverse_reason.rfind("it leaves a direction free itself", 0), 0u)
        << r.verification.reverse_reason;
  }
  AlignmentResult weak = swapped(at.inverse());
  weak.verification.confidence = 0.4;
  r = refused;
  EXPECT_FALSE(pcl_mi::core::confirmWithTheReverse(weak, 1.0, r));
  EXPECT_EQ(r.verification.reverse_reason, "its own confidence, 0.40, is under 0.50");

  // A failed alignment of the clouds swapped changes nothing.
  AlignmentResult failed = swapped(at.inverse());
  failed.error = "no overlap";
  r = refused;
  EXPECT_FALSE(pcl_mi::core::confirmWithTheReverse(failed, 1.0, r));
  EXPECT_DOUBLE_EQ(r.verification.confidence, refused.verification.confidence);
  EXPECT_TRUE(std::isnan(r.verification.reverse_shift));
  EXPECT_TRUE(r.verification.reverse_reason.empty());

  // Neither search met its tolerance: agreement from opposite sides is enough.
  AlignmentResult capped = swapped(at.inverse());
  capped.search_converged = false;
  r = refused;
  r.search_converged = false;
  EXPECT_TRUE(pcl_mi::core::confirmWithTheReverse(capped, 1.0, r));

  // Not worth asking: unsteady, in place (its fixed confidence), under 0.8.
  r = refused;
  r.verification.unsteady = true;
  EXPECT_FALSE(pcl_mi::core::mayBeConfirmed(r));
  r = refused;
  r.verification.confidence = pcl_mi::core::kInPlaceDegenerateConfidence;
  r.verification.refusal = Refusal::Degenerate;
  EXPECT_FALSE(pcl_mi::core::mayBeConfirmed(r));
  r = refused;
  r.verification.confidence = 0.79;
  EXPECT_FALSE(pcl_mi::core::mayBeConfirmed(r));
  // Too little shared surface on this side: the other side, sampling the other cloud, may
  // find enough; one that holds every direction confirms it, with its covariance.
  r = refused;
  r.verification.refusal = Refusal::LittleSharedSurface;
  r.verification.covariance.setZero();
  EXPECT_TRUE(pcl_mi::core::mayBeConfirmed(r));
  EXPECT_TRUE(pcl_mi::core::confirmWithTheReverse(swapped(at.inverse()), 1.0, r));
  EXPECT_FALSE(r.verification.covariance.isZero());
  r = refused;
  r.verification.refusal = Refusal::None; // passed, its search capped
  r.search_converged = false;
  EXPECT_TRUE(pcl_mi::core::mayBeConfirmed(r));
}

// A degenerate result has no covariance; the swapped one's, a left increment of the inverse
// pose, becomes one of the result's pose: each unit variance of the swapped pose moves the
// result as the increment it induces, to first order.
TEST(ReverseConfirmation, ADegenerateResultTakesTheSwappedCovarianceCarriedOver)
{
  const Eigen::Matrix4d at = pose(4.0, 2.0, -0.5, 0.1, 0.05, -0.7);
  const Eigen::Matrix4d back = at.inverse();
  for (int k = 0; k < 6; ++k) {
    SCOPED_TRACE(k);
    AlignmentResult r = heldBack(at);
    r.verification.refusal = Refusal::Degenerate;
    r.verification.covariance.setZero();
    AlignmentResult b = swapped(back);
    b.verification.covariance = Matrix6d::Zero();
    b.verification.covariance(k, k) = 1.0;
    ASSERT_TRUE(pcl_mi::core::confirmWithTheReverse(b, 1.0, r));
    // Move the swapped pose by a small unit increment k and see where its inverse goes.
    const double e = 1e-6;
    const Eigen::Matrix<double, 6, 1> moved = increment(at, (smallMove(k, e) * back).inverse()) / e;
    const Matrix6d expected = moved * moved.transpose();
    EXPECT_TRUE(r.verification.covariance.isApprox(expected, 1e-4))
        << r.verification.covariance << "\n\n"
        << expected;
  }
}

// A degenerate result and a swapped side that leave different directions free each hold what
// the other leaves: where they agree, every direction is held, and the result converges with
// the inverse of the two sides' mean information. A side free within 45 deg of the result's
// free direction does not hold it. Directions are [t, omega * radius] about each side's centre.
TEST(ReverseConfirmation, ASideFreeAlongAnotherDirectionConfirmsADegenerateResult)
{
  using Vector6d = Eigen::Matrix<double, 6, 1>;
  const Eigen::Matrix4d at = pose(3.0, -1.0, 0.2, 0.05, -0.02, 0.6);
  const Eigen::Matrix4d back = at.inverse();
  AlignmentResult refused = heldBack(at);
  Verification& v = refused.verification;
  v.refusal = Refusal::Degenerate;
  v.covariance.setZero();
  v.observability_centre << 40.0, -25.0, 3.0; // far from the origin, as a local frame is
  v.observability_radius = 8.0;
  v.observability_directions.col(0) << 0.0, 0.0, 0.0, 1.0, 0.0, 0.0; // a roll about the centre
  v.free_direction_contrast[0] = 0.01;
  v.free_direction_contrast[1] = 0.3;
  v.information = Vector6d(400.0, 300.0, 200.0, 1e-3, 500.0, 600.0).asDiagonal();
  ASSERT_TRUE(pcl_mi::core::isFree(v, 0));
  ASSERT_FALSE(pcl_mi::core::isFree(v, 1));

  // Where that roll moves the swapped pose, found by moving the result a little.
  const double e = 1e-6;
  Eigen::Matrix4d d = Eigen::Matrix4d::Identity();
  d.topLeftCorner<3, 3>() = Eigen::AngleAxisd(e, Eigen::Vector3d::UnitX()).toRotationMatrix();
  d.topRightCorner<3, 1>() = Eigen::Vector3d(v.observability_centre) -
                             d.topLeftCorner<3, 3>() * Eigen::Vector3d(v.observability_centre);
  const Vector6d moved = increment(back, (d * at).inverse()) / e; // about back's origin
  AlignmentResult side = swapped(back);
  side.converged = false;
  Verification& w = side.verification;
  w.refusal = Refusal::Degenerate;
  w.covariance.setZero();
  w.observability_centre << -30.0, 35.0, 2.0;
  w.observability_radius = 6.0;
  w.free_direction_contrast[0] = 0.02;
  w.free_direction_contrast[1] = 0.4;
  w.information = Vector6d(300.0, 1e-3, 250.0, 350.0, 450.0, 550.0).asDiagonal();
  Vector6d same;
  same << moved.head<3>() + moved.tail<3>().cross(Eigen::Vector3d(w.observability_centre)),
      moved.tail<3>() * w.observability_radius;
  same.normalize();
  Vector6d across = Vector6d::Unit(1) - same * same(1); // a shift, made orthogonal to it
  across.normalize();

  for (const double degrees : {0.0, 30.0, 40.0, 50.0, 60.0, 90.0}) {
    SCOPED_TRACE(degrees);
    const double angle = degrees * M_PI / 180.0;
    w.observability_directions.col(0) = std::cos(angle) * same + std::sin(angle) * across;
    const bool held = degrees > 45.0;
    EXPECT_EQ(pcl_mi::core::holdsTheFreeDirections(v, w, back), held);
    AlignmentResult r = refused;
    EXPECT_EQ(pcl_mi::core::confirmWithTheReverse(side, 1.0, r), held);
    EXPECT_EQ(r.converged, held);
    if (!held) {
      EXPECT_EQ(r.verification.reverse_reason,
                "it leaves a direction free itself, and this result leaves one free within 45 "
                "deg of it");
      continue;
    }
    // The covariance: the inverse of the mean information, the swapped side's carried over
    // by the map that small moves of the result give.
    Matrix6d map;
    for (int k = 0; k < 6; ++k)
      map.col(k) = increment(back, (smallMove(k, e) * at).inverse()) / e;
    const Matrix6d expected =
        (0.5 * (Matrix6d(v.information) + map.transpose() * w.information * map)).inverse();
    EXPECT_TRUE(r.verification.covariance.isApprox(expected, 1e-4))
        << r.verification.covariance << "\n\n"
        << expected;
  }
  // The result's free direction must be free: one without any is not held by this test.
  AlignmentResult r = refused;
  r.verification.free_direction_contrast[0] = 0.3;
  EXPECT_FALSE(pcl_mi::core::holdsTheFreeDirections(r.verification, w, back));
}

// A result that leaves only a turn free ends anywhere along it; a swapped side that passes
// every test itself holds that turn, so agreement within the success bound's turn confirms
// it. A side that is weaker, or a result free along a shift, keeps the quarter-bound.
TEST(ReverseConfirmation, ASwappedSideThatPassesHoldsAFreeTurnWithinTheBound)
{
  const Eigen::Matrix4d at = pose(2.0, 1.0, 0.1, 0.02, 0.01, 0.4);
  AlignmentResult turn_free = heldBack(at);
  turn_free.verification.refusal = Refusal::Degenerate;
  turn_free.verification.reason = "degenerate along a turn";
  turn_free.verification.covariance.setZero();
  Eigen::Matrix<double, 6, 1> roll = Eigen::Matrix<double, 6, 1>::Zero();
  roll[3] = 1.0;
  turn_free.verification.observability_directions.col(0) = roll;
  turn_free.verification.free_direction_contrast[0] = 0.0;
  turn_free.verification.free_direction_contrast[1] = 1.0;
  ASSERT_TRUE(pcl_mi::core::onlyTurnsFree(turn_free.verification));
  ASSERT_TRUE(pcl_mi::core::mayBeConfirmed(turn_free));
  const auto turned = [&](double roll_deg, double shift) {
    return swapped((pose(shift, 0.0, 0.0, roll_deg * M_PI / 180.0, 0.0, 0.0) * at).inverse());
  };

  AlignmentResult r = turn_free;
  EXPECT_TRUE(pcl_mi::core::confirmWithTheReverse(turned(1.5, 0.0), 1.0, r));
  EXPECT_TRUE(r.converged);
  EXPECT_NEAR(r.verification.reverse_turn_deg, 1.5, 1e-9);
  EXPECT_FALSE(r.verification.covariance.isZero()); // the swapped side's, carried over

  r = turn_free;
  EXPECT_FALSE(pcl_mi::core::confirmWithTheReverse(turned(2.5, 0.0), 1.0, r));
  EXPECT_EQ(r.verification.reverse_reason, "it ends more than 0.25 m or 2 deg away");
  r = turn_free;
  EXPECT_FALSE(pcl_mi::core::confirmWithTheReverse(turned(1.0, 0.3), 1.0, r));

  // A swapped side under kReliableConfidence, or one held back itself, holds nothing.
  AlignmentResult unsure = turned(1.5, 0.0);
  unsure.verification.confidence = 0.9;
  r = turn_free;
  EXPECT_FALSE(pcl_mi::core::confirmWithTheReverse(unsure, 1.0, r));
  EXPECT_EQ(r.verification.reverse_reason, "it ends more than 0.25 m or 0.5 deg away");
  AlignmentResult weak = turned(1.5, 0.0);
  weak.verification.refusal = Refusal::WeakEvidence;
  r = turn_free;
  EXPECT_FALSE(pcl_mi::core::confirmWithTheReverse(weak, 1.0, r));

  // A result free along a shift: its turn is its own evidence, as before.
  AlignmentResult shift_free = turn_free;
  shift_free.verification.observability_directions.col(0) << 1.0, 0.0, 0.0, 0.0, 0.0, 0.0;
  ASSERT_FALSE(pcl_mi::core::onlyTurnsFree(shift_free.verification));
  r = shift_free;
  EXPECT_FALSE(pcl_mi::core::confirmWithTheReverse(turned(1.5, 0.0), 1.0, r));
  r = shift_free;
  EXPECT_TRUE(pcl_mi::core::confirmWithTheReverse(turned(0.3, 0.0), 1.0, r));
}

// Two poses of one problem end together within the agreement tolerance that confirms a
// result, measured as confirmWithTheReverse() measures a result against the swapped side.
TEST(ReverseConfirmation, PosesEndTogetherWithinTheAgreementTolerance)
{
  const Eigen::Matrix4d at = pose(12.0, -3.0, 0.5, 0.02, -0.01, 0.7);
  const auto moved = [&](double shift, double yaw_deg, double units) -> Eigen::Matrix4d {
    return pose(shift * units, 0.0, 0.0, 0.0, 0.0, yaw_deg * M_PI / 180.0) * at;
  };
  EXPECT_TRUE(pcl_mi::core::endsTogether(at, at, 1.0));
  EXPECT_TRUE(pcl_mi::core::endsTogether(moved(0.2, 0.4, 1.0), at, 1.0));
  EXPECT_TRUE(pcl_mi::core::endsTogether(at, moved(0.2, 0.4, 1.0), 1.0));
  EXPECT_FALSE(pcl_mi::core::endsTogether(moved(0.3, 0.0, 1.0), at, 1.0));
  EXPECT_FALSE(pcl_mi::core::endsTogether(moved(0.0, 0.6, 1.0), at, 1.0));
  // In millimetres the shift's tolerance is a thousand times the number.
  EXPECT_TRUE(pcl_mi::core::endsTogether(moved(0.2, 0.0, 1000.0), at, 1000.0));
  EXPECT_FALSE(pcl_mi::core::endsTogether(moved(0.3, 0.0, 1000.0), at, 1000.0));

  // The measure is confirmWithTheReverse()'s: a swapped side at the other pose, inverted,
  // confirms the result exactly where the two end together.
  for (const Eigen::Matrix4d& other : {moved(0.2, 0.4, 1.0), moved(0.3, 0.0, 1.0)}) {
    AlignmentResult r = heldBack(at);
    EXPECT_EQ(pcl_mi::core::confirmWithTheReverse(swapped(other.inverse()), 1.0, r),
              pcl_mi::core::endsTogether(other, at, 1.0));
  }
}
