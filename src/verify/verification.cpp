/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "verify/verification.h"

#include "features/mutual_information.h"
#include "util/parallel.h"
#include "verify/confidence_model.h"
#include "verify/inlier_probe.h"
#include "verify/plane_information.h"
#include "verify/pose_evidence.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iterator>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

namespace pcl_mi {
namespace core {

namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

/** Share of the inliers that a move of one voxel along one of the two least observable
 * directions must lose at least: a floor or a corridor loses only its edges along its free
 * directions, whereas their noisy normals leave those directions some small information. */
constexpr double kFreeDirectionContrast = 0.05;
/** Eigenvalues of the scaled information within this factor of each other leave their
 * eigenvectors ill-determined: the normals' noise turns them within their span. Applied to
 * every pair, the information per motion of the samples also turned well-separated
 * eigenvectors, and the axis shifts' probes held back right results where only two
 * directions were weak; both cost right Livox results (docs/benchmarks.md, "A free direction
 * mixed with a turn", "A free shift among three weak directions"). */
constexpr double kMixedEigenvalues = 2.0;
/** A component of a free direction at least this large names its axis in the reason. */
constexpr double kNamedComponent = 0.4;

/** A free direction whose unit move ([t, omega * radius]) is at least this much a turn is
 * asked of the MI on the finest grid, where the sensors do not stand where they were: the
 * surfaces may hold a narrow view's turn about its axis of view only weakly while the MI holds
 * it. A shift along a floor or a corridor changes the MI only where the scans end, which the
 * sensor's range sets, not the scene (docs/benchmarks.md, "Free turns the MI holds"). Where
 * the sensors stand at one place with their vertical axes tilted apart, a free direction less
 * of a turn than this is a shift, which only the surfaces it crosses may hold. */
constexpr double kTurnShare = 0.7;
/** Largest share of that turn's axis along the input frame's z: a turn about the vertical
 * swings a narrow view's samples sideways, as the slides along facades that the MI can prefer
 * do; a tilt, about the axis of view or across it, does not. */
constexpr double kSwingShare = 0.5;
/** Least share of the MI that the free turn's moves must lose, either way on average, for the
 * MI to hold the turn. */
constexpr double kHeldTurnMiLoss = 0.1;

const char* const kAxisNames[6] = {"x", "y", "z", "roll", "pitch", "yaw"};

/** True where the unit move \a direction ([t, omega * radius]) is mostly a turn
 * (kTurnShare). */
bool
mostlyATurn(const Eigen::Matrix<double, 6, 1>& direction)
{
  return direction.tail<3>().norm() >= kTurnShare;
}

} // namespace

bool
isFree(const Verification& v, int k)
{
  if (v.free_turns_held && mostlyATurn(v.observability_directions.col(k)))
    return false;
  return v.free_direction_contrast[k] < kFreeDirectionContrast &&
         !(v.free_turn_mi_loss[k] >= kHeldTurnMiLoss);
}

namespace {

/** "x, y and yaw": the axes that the free directions of \a v move. */
std::string
freeAxes(const Verification& v, const bool free[2])
{
  bool named[6] = {false, false, false, false, false, false};
  for (int k = 0; k < 2; ++k)
    if (free[k])
      for (int i = 0; i < 6; ++i)
        named[i] = named[i] || std::abs(v.observability_directions(i, k)) >= kNamedComponent;
  std::vector<std::string> names;
  for (int i = 0; i < 6; ++i)
    if (named[i])
      names.push_back(kAxisNames[i]);
  std::string text;
  for (std::size_t i = 0; i < names.size(); ++i)
    text += (i == 0 ? "" : i + 1 == names.size() ? " and " : ", ") + names[i];
  return text;
}

/** The share of the inliers lost one voxel (\a step) along \a axis (0-2), or turned by
 * \a turn about it (3-5), either way: over the six, their mean is the peak contrast, their
 * least the weakest. */
double
probeAxis(const InlierProbe& probe, int axis, double step, double turn)
{
  return axis < 3 ? probe.lostEitherWay(Eigen::Vector3d::Zero(), step * Eigen::Vector3d::Unit(axis))
                  : probe.lostTurningEitherWay(axis - 3, turn);
}

/** The observability from \a solver, scaledInformation()'s decomposition; directions in the
 * local frame. */
void
observabilityOf(const Eigen::SelfAdjointEigenSolver<Matrix6d>& solver, Verification& v)
{
  const double largest = solver.eigenvalues()[5];
  if (!(largest > 0.0))
    return;
  v.observability = (solver.eigenvalues() / largest).cwiseMax(0.0);
  v.observability_directions = solver.eigenvectors();
}

/** Where the two least observable directions of \a v (local frame, [t, omega * \a radius])
 * have eigenvalues within kMixedEigenvalues of each other, turns them within their plane so
 * that the first is the one of least information per motion of the probed samples and the
 * second the one of most (a generalised eigenproblem in the plane). Scaled at the RMS radius,
 * a turn that moves the samples less than that radius (a roll about a long corridor's axis)
 * can look as weak as a shift the surfaces leave free, and the eigenvectors of two such
 * eigenvalues are any mix of the two: each then turns the samples off the surfaces, and
 * neither probe finds the free shift (docs/benchmarks.md, "A free direction mixed with a
 * turn"). Unit length each; they need not be orthogonal. */
void
separateLeastObservable(const InlierProbe& probe, double radius, Verification& v)
{
  using Vector6d = Eigen::Matrix<double, 6, 1>;
  if (!(v.observability[1] < kMixedEigenvalues * v.observability[0]))
    return;
  const Vector6d d0 = v.observability_directions.col(0);
  const Vector6d d1 = v.observability_directions.col(1);
  const auto motion = [&](const Vector6d& a, const Vector6d& b) {
    return probe.meanMoveProduct(a.tail<3>() / radius, a.head<3>(), b.tail<3>() / radius,
                                 b.head<3>());
  };
  Eigen::Matrix2d m;
  m(0, 0) = motion(d0, d0);
  m(1, 1) = motion(d1, d1);
  m(0, 1) = m(1, 0) = motion(d0, d1);
  if (!(m.determinant() > 1e-12 * m(0, 0) * m(1, 1)))
    return; // a direction that moves no sample
  const Eigen::Matrix2d information = v.observability.head<2>().asDiagonal();
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::Matrix2d> plane(information, m);
  if (plane.info() != Eigen::Success)
    return;
  for (int k = 0; k < 2; ++k) {
    const Vector6d u = plane.eigenvectors()(0, k) * d0 + plane.eigenvectors()(1, k) * d1;
    v.observability_directions.col(k) = u.normalized();
  }
}

} // namespace

Verification
verifyPose(const TargetDistributions& target,
           const SourceSamples& source,
           const Eigen::Matrix3d& rotation,
           const Eigen::Vector3d& translation,
           double resolution,
           const JointHistogram& histogram,
           const Eigen::Vector3d& target_centroid,
           const Eigen::Matrix3d& target_axes,
           SensorPlacement placement,
           int num_threads,
           const FinestMutualInformation& finest_mi,
           bool free_turns_held)
{
  Verification v;
  v.free_turns_held = free_turns_held;
  v.observability_centre = target_centroid;
  v.sensors_in_place = placement == SensorPlacement::kSamePlaceAndAxis;
  // The evidence at the result and the contrast probes are independent tasks. Every count
  // and sum is its own task's, so the figures do not depend on the threads.
  PoseEvidence at;
  const double radius = rotationRadius(source, resolution);
  v.observability_radius = radius;
  const InlierProbe probe(target, source, rotation, translation);
  double contrast[6] = {0, 0, 0, 0, 0, 0};
  // The full gather is the longest task: it goes first, and the six axes' probes fill the
  // other thread and then whichever is free.
  parallelFor(7, num_threads, [&](int task) {
    if (task == 0)
      at = gatherPoseEvidence(target, source, rotation, translation, 1, true);
    else
      contrast[task - 1] = probeAxis(probe, task - 1, resolution, resolution / radius);
  });
  v.peak_contrast = (contrast[0] + contrast[1] + contrast[2] + contrast[3] + contrast[4] +
                     contrast[5]) /
                    6.0;
  v.weakest_contrast = *std::min_element(std::begin(contrast), std::end(contrast));
  if (at.samples > 0) {
    v.inliers = at.inliers;
    v.overlap = static_cast<double>(at.matched) / at.samples;
    v.inlier_fraction = at.matched ? static_cast<double>(at.inliers) / at.matched : 0.0;
  }
  const Entropies h = entropies(histogram);
  const double floor_entropy = std::min(h.source, h.target);
  v.normalized_mi = floor_entropy > 0.0 ? h.mutualInformation() / floor_entropy : 0.0;

  const Eigen::SelfAdjointEigenSolver<Matrix6d> information = scaledInformation(at, radius);
  observabilityOf(information, v);
  v.covariance = covarianceFrom(at, information, radius, target_centroid, target_axes);
  v.information = informationFrom(at, target_centroid, target_axes);
  separateLeastObservable(probe, radius, v);
  // The two least observable directions ([t, omega * radius]), moved either way so far that
  // the samples move one voxel (root mean square). A turn scaled at the RMS radius moves a
  // narrow view's samples much less than that about its axis of view, which left such turns
  // looking free where the surfaces hold them (docs/benchmarks.md, "Free directions moved a
  // voxel"); a turn about a tunnel's axis moves its samples along its surface, any distance.
  Eigen::Vector3d omega[2], delta[2]; // the moves probed
  parallelFor(2, num_threads, [&](int k) {
    const Eigen::Matrix<double, 6, 1> direction = v.observability_directions.col(k);
    const Eigen::Vector3d unit_omega = direction.tail<3>() / radius;
    const Eigen::Vector3d unit_delta = direction.head<3>();
    const double shift = probe.rmsShift(unit_omega, unit_delta);
    const double step = shift > 0.0 ? resolution / shift : resolution;
    omega[k] = step * unit_omega;
    delta[k] = step * unit_delta;
    const bool only_crossed = placement == SensorPlacement::kSamePlaceAndAxis ||
                              (placement == SensorPlacement::kSamePlace && !mostlyATurn(direction));
    v.free_direction_contrast[k] = only_crossed ? probe.lostAcrossEitherWay(omega[k], delta[k])
                                                : probe.lostEitherWay(omega[k], delta[k]);
  });
  const double mi = h.mutualInformation();
  if (finest_mi && placement != SensorPlacement::kSamePlaceAndAxis &&
      histogram.overlap_voxels > 0 && mi > 0.0) {
    const Eigen::Vector3d up = target_axes.row(2).transpose(); // the input z, local
    for (int k = 0; k < 2; ++k) {
      const Eigen::Vector3d turn = v.observability_directions.col(k).tail<3>();
      if (isFree(v, k) && mostlyATurn(v.observability_directions.col(k)) &&
          std::abs(turn.dot(up)) <= kSwingShare * turn.norm())
        v.free_turn_mi_loss[k] =
            1.0 - meanEitherWay(rotation, translation, omega[k], delta[k], finest_mi) / mi;
    }
  }
  // Where the three least eigenvalues lie within kMixedEigenvalues of one another and
  // neither direction probed counts free, a shift along an axis of the target's frame that
  // its contrast probe found free: two walls without a floor leave the shift along them, the
  // shift up and the pitch nearly without information, the last two held only where the
  // walls end; the eigenvectors mix all three, and each probe meets an edge
  // (docs/benchmarks.md, "A free shift among three weak directions"). That probe moves the
  // samples a voxel, as these do; where the sensors stand at one place it counts every
  // inlier, which the probes above do not.
  if (placement == SensorPlacement::kApart && !isFree(v, 0) && !isFree(v, 1) &&
      v.observability[2] < kMixedEigenvalues * v.observability[0]) {
    const int axis = static_cast<int>(std::min_element(contrast, contrast + 3) - contrast);
    if (contrast[axis] < kFreeDirectionContrast) {
      v.observability_directions.col(1).setZero();
      v.observability_directions(axis, 1) = 1.0;
      v.free_direction_contrast[1] = contrast[axis];
      v.free_turn_mi_loss[1] = std::numeric_limits<double>::quiet_NaN();
    }
  }
  // Reported in the input frame: [delta, omega * radius] turn alike.
  v.observability_directions.topRows<3>() = target_axes * v.observability_directions.topRows<3>();
  v.observability_directions.bottomRows<3>() =
      target_axes * v.observability_directions.bottomRows<3>();
  const bool free[2] = {isFree(v, 0), isFree(v, 1)};
  if (free[0] || free[1] || !sharesSurface(v))
    v.covariance.setZero();
  judge(v);
  return v;
}

bool
onlyTurnsFree(const Verification& v)
{
  bool any = false;
  for (int k = 0; k < 2; ++k) {
    if (!isFree(v, k))
      continue;
    if (!mostlyATurn(v.observability_directions.col(k)))
      return false;
    any = true;
  }
  return any;
}

void
judge(Verification& v)
{
  v.confidence = confidenceOf(v);
  const bool free[2] = {isFree(v, 0), isFree(v, 1)};
  std::ostringstream reason;
  v.refusal = Refusal::None;
  if (!sharesSurface(v)) {
    v.refusal = Refusal::LittleSharedSurface;
    reason << "the clouds share too little surface at this resolution (" << v.inliers
           << " source samples on a target surface)";
  }
  else if (free[0] || free[1]) {
    v.refusal = Refusal::Degenerate;
    reason << "degenerate along " << freeAxes(v, free) << ": the surfaces leave the pose free there";
    // The scans' own patterns raise every term of the confidence where they fall on one
    // another; its logistic model then says nothing of the free direction.
    if (v.sensors_in_place) {
      v.confidence = kInPlaceDegenerateConfidence;
      reason << ", and the result leaves the sensors where they were, where their own scan "
                "patterns fall on one another";
    }
  }
  else if (v.lead < 0.0) { // false for NaN
    v.refusal = Refusal::SecondOptimum;
    reason << "a second optimum: one a few voxels across scores a higher MI on the finest "
              "grid (the result's lead is "
           << std::fixed << std::setprecision(0) << 100.0 * v.lead << " %)";
  }
  else if (v.confidence < kReliableConfidence) {
    v.refusal = Refusal::WeakEvidence;
    reason << "the evidence is weak (confidence " << std::fixed << std::setprecision(2)
           << v.confidence << ")";
  }
  v.reason = reason.str();
}

} // namespace core
} // namespace pcl_mi
