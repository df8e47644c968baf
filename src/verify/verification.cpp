/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "verify/verification.h"

#include "features/mutual_information.h"
#include "util/left_increment.h"
#include "util/parallel.h"
#include "verify/pose_evidence.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iterator>
#include <limits>
#include <sstream>

namespace pcl_mi {
namespace core {

namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

/** Most samples each probe around the result looks at: the contrast is a ratio of counts,
 * which a few thousand samples fix well enough. */
constexpr std::size_t kProbeSamples = 4096;

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

/** Least share of a move that must cross a sample's surface for the sample to count in the
 * free-direction probe where the sensors stand at one place: the sine of the angle between
 * the move and the surface (about 17 deg). A road's slope and its noisy normals put a move along it
 * a few degrees off the ground, which must not count; steeper surfaces may
 * (docs/benchmarks.md, "The verdict where the sensors stand where they were"). */
constexpr float kAcrossSurface = 0.3f;

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

double
rmsRadius(const SourceSamples& source)
{
  double sum = 0.0;
  for (const SourceSample& s : source.samples)
    sum += s.position.squaredNorm();
  return source.samples.empty() ? 0.0 : std::sqrt(sum / source.samples.size());
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

/** The mean of \a value_at(r, t) over the two poses that the left increments +-[omega,
 * delta] move \a rotation, \a translation to. */
template <typename ValueAt>
double
meanEitherWay(const Eigen::Matrix3d& rotation,
              const Eigen::Vector3d& translation,
              const Eigen::Vector3d& omega,
              const Eigen::Vector3d& delta,
              const ValueAt& value_at)
{
  double sum = 0.0;
  for (int sign = -1; sign <= 1; sign += 2) {
    Eigen::Matrix3d r = rotation;
    Eigen::Vector3d t = translation;
    applyLeftIncrement(sign * omega, sign * delta, r, t);
    sum += value_at(r, t);
  }
  return 0.5 * sum;
}

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

/** Counts the inliers of poses near the result against the result's own, on every k-th
 * sample (at most kProbeSamples). */
class InlierProbe {
public:
  InlierProbe(const TargetDistributions& target,
              const SourceSamples& source,
              const Eigen::Matrix3d& rotation,
              const Eigen::Vector3d& translation)
  : target_(target),
    source_(source),
    rotation_(rotation),
    translation_(translation),
    stride_(source.samples.size() / kProbeSamples + 1),
    base_(static_cast<double>(
        gatherPoseEvidence(target, source, rotation, translation, stride_).inliers))
  {
    // The probed samples' first and second moments at the result: every motion measure
    // below is a quadratic form in them.
    for (std::size_t i = 0; i < source.samples.size(); i += stride_, ++probed_) {
      const Eigen::Vector3d q = rotation * source.samples[i].position.cast<double>() + translation;
      mean_ += q;
      second_moment_ += q * q.transpose();
    }
    if (probed_) {
      mean_ /= static_cast<double>(probed_);
      second_moment_ /= static_cast<double>(probed_);
    }
  }

  /** \brief Mean share of the result's inliers lost by the left increments +-[omega,
   * delta] (rotations about the target local origin); 0 for a result without inliers. */
  double
  lostEitherWay(const Eigen::Vector3d& omega, const Eigen::Vector3d& delta) const
  {
    return meanLoss(omega, delta, [&](const Eigen::Matrix3d& r, const Eigen::Vector3d& t) {
      return 1.0 - gatherPoseEvidence(target_, source_, r, t, stride_).inliers / base_;
    });
  }

  /** \brief lostEitherWay() counting only the inliers whose surface the move crosses (by at
   * least kAcrossSurface of its length), at the result and at the moved poses alike: a
   * sample moved along its own surface (the ground under a move along the road) keeps or
   * loses its inlier by how the sensors sampled that surface, which says nothing of the
   * pose where their scan patterns fall on one another. */
  double
  lostAcrossEitherWay(const Eigen::Vector3d& omega, const Eigen::Vector3d& delta) const
  {
    if (!(base_ > 0.0))
      return 0.0;
    const double at = inliersAcross(rotation_, translation_, omega, delta);
    return meanLoss(omega, delta, [&](const Eigen::Matrix3d& r, const Eigen::Vector3d& t) {
      return (at - inliersAcross(r, t, omega, delta)) / base_;
    });
  }

  /** \brief Mean over the probed samples q of the product of their moves, to first order,
   * by the left increments [omega_a, delta_a] and [omega_b, delta_b]:
   * (omega_a x q + delta_a) . (omega_b x q + delta_b); 0 without samples. */
  double
  meanMoveProduct(const Eigen::Vector3d& omega_a,
                  const Eigen::Vector3d& delta_a,
                  const Eigen::Vector3d& omega_b,
                  const Eigen::Vector3d& delta_b) const
  {
    if (probed_ == 0)
      return 0.0;
    // (a x q) . (b x q) = (a . b)(q . q) - (a . q)(b . q)
    return delta_a.dot(delta_b) + delta_a.dot(omega_b.cross(mean_)) +
           delta_b.dot(omega_a.cross(mean_)) + omega_a.dot(omega_b) * second_moment_.trace() -
           omega_a.dot(second_moment_ * omega_b);
  }

  /** \brief Root mean square distance by which the left increment [omega, delta] moves the
   * probed samples, to first order. */
  double
  rmsShift(const Eigen::Vector3d& omega, const Eigen::Vector3d& delta) const
  {
    return std::sqrt(std::max(0.0, meanMoveProduct(omega, delta, omega, delta)));
  }

  /** \brief The same for turns by +-\a angle about the axis \a axis through the source's
   * centroid, which sits at the translation in the target local frame. */
  double
  lostTurningEitherWay(int axis, double angle) const
  {
    if (!(base_ > 0.0))
      return 0.0;
    double lost = 0.0;
    for (int sign = -1; sign <= 1; sign += 2) {
      const Eigen::Matrix3d r =
          Eigen::AngleAxisd(sign * angle, Eigen::Vector3d::Unit(axis)).toRotationMatrix() *
          rotation_;
      lost += 1.0 - gatherPoseEvidence(target_, source_, r, translation_, stride_).inliers / base_;
    }
    return 0.5 * lost;
  }

private:
  /** The mean of \a loss_at(r, t) over the poses the left increments +-[omega, delta] move
   * the result to; 0 for a result without inliers. */
  template <typename LossAt>
  double
  meanLoss(const Eigen::Vector3d& omega, const Eigen::Vector3d& delta, const LossAt& loss_at) const
  {
    return base_ > 0.0 ? meanEitherWay(rotation_, translation_, omega, delta, loss_at) : 0.0;
  }

  /** The probed samples at \a rotation, \a translation that are inliers of a surface that
   * the left increment [omega, delta] crosses. */
  double
  inliersAcross(const Eigen::Matrix3d& rotation,
                const Eigen::Vector3d& translation,
                const Eigen::Vector3d& omega,
                const Eigen::Vector3d& delta) const
  {
    const Eigen::Vector3f w = omega.cast<float>();
    const Eigen::Vector3f d = delta.cast<float>();
    std::size_t count = 0;
    visitInCubes(target_, source_, rotation.cast<float>(), translation.cast<float>(), 0,
                 source_.samples.size(), stride_, [&](const Eigen::Vector3f& q, int k) {
                   if (k < 0 || !isInlier(target_[k], q))
                     return;
                   const Eigen::Vector3f m = w.cross(q) + d;
                   count += std::abs(target_[k].normal.dot(m)) >= kAcrossSurface * m.norm();
                 });
    return static_cast<double>(count);
  }

  const TargetDistributions& target_;
  const SourceSamples& source_;
  const Eigen::Matrix3d rotation_;
  const Eigen::Vector3d translation_;
  const std::size_t stride_;
  const double base_;
  std::size_t probed_ = 0; // samples the moments below are over
  Eigen::Vector3d mean_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second_moment_ = Eigen::Matrix3d::Zero();
};

/** The share of the inliers lost one voxel (\a step) along \a axis (0-2), or turned by
 * \a turn about it (3-5), either way: over the six, their mean is the peak contrast, their
 * least the weakest. */
double
probeAxis(const InlierProbe& probe, int axis, double step, double turn)
{
  return axis < 3 ? probe.lostEitherWay(Eigen::Vector3d::Zero(), step * Eigen::Vector3d::Unit(axis))
                  : probe.lostTurningEitherWay(axis - 3, turn);
}

/** [omega, delta] -> [delta, omega]: the evidence's order to the covariance's. */
Matrix6d
covarianceOrder()
{
  Matrix6d order = Matrix6d::Zero();
  order.block<3, 3>(0, 3).setIdentity();
  order.block<3, 3>(3, 0).setIdentity();
  return order;
}

/** Per parameter of [delta, omega], the scale that makes one unit of rotation move a point
 * at \a radius by one unit of length. */
Eigen::Matrix<double, 6, 1>
rotationScale(double radius)
{
  Eigen::Matrix<double, 6, 1> scale;
  scale << 1.0, 1.0, 1.0, 1.0 / radius, 1.0 / radius, 1.0 / radius;
  return scale;
}

/** The point-to-plane information of \a at in [delta, omega], rotations scaled by
 * \a radius, decomposed. */
Eigen::SelfAdjointEigenSolver<Matrix6d>
scaledInformation(const PoseEvidence& at, double radius)
{
  const Matrix6d order = covarianceOrder();
  const Eigen::Matrix<double, 6, 1> scale = rotationScale(radius);
  const Matrix6d h = order * at.plane_information * order.transpose();
  return Eigen::SelfAdjointEigenSolver<Matrix6d>(scale.asDiagonal() * h * scale.asDiagonal());
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

/** The radius at which verifyPose() scales rotations for \a source. */
double
rotationRadius(const SourceSamples& source, double resolution)
{
  return std::max(rmsRadius(source), resolution);
}

/** The inliers' residual variance across the surfaces, six degrees of freedom taken by the
 * pose (more than 6 inliers). */
double
planeVariance(const PoseEvidence& at)
{
  return at.plane_residuals / static_cast<double>(at.inliers - 6);
}

/** The map that turns both halves of an increment [delta, omega] by \a axes. */
Matrix6d
turnedAlike(const Eigen::Matrix3d& axes)
{
  Matrix6d m = Matrix6d::Zero();
  m.block<3, 3>(0, 0) = axes;
  m.block<3, 3>(3, 3) = axes;
  return m;
}

/** planeCovariance() of \a at from \a solver, scaledInformation(at, radius)'s
 * decomposition. */
Matrix6d
covarianceFrom(const PoseEvidence& at,
               const Eigen::SelfAdjointEigenSolver<Matrix6d>& solver,
               double radius,
               const Eigen::Vector3d& target_centroid,
               const Eigen::Matrix3d& target_axes)
{
  const double largest = solver.eigenvalues()[5];
  if (!(largest > 0.0) || at.inliers <= 6 || !(solver.eigenvalues()[0] / largest > 0.0))
    return Matrix6d::Zero();
  const Matrix6d order = covarianceOrder();
  const Eigen::Matrix<double, 6, 1> scale = rotationScale(radius);
  // Residual variance across the surfaces, then back from the scaled increments; the
  // increment about the target local origin becomes one about the input frame's origin:
  // delta_origin = delta + c x omega.
  const double variance = planeVariance(at);
  const Matrix6d scaled_inverse = solver.eigenvectors() *
                                  solver.eigenvalues().cwiseInverse().asDiagonal() *
                                  solver.eigenvectors().transpose();
  // The result is not exactly the point-to-plane optimum (the refinement weighs distributions,
  // not planes, and stops early): the Gauss-Newton step to it is an error of its own, which
  // the covariance takes in as its outer product.
  const Eigen::Matrix<double, 6, 1> step =
      scaled_inverse * (scale.asDiagonal() * (order * at.plane_gradient));
  const Matrix6d scaled_covariance = variance * scaled_inverse + step * step.transpose();
  const Matrix6d to_input = turnedAlike(target_axes);
  const Matrix6d local =
      to_input * scale.asDiagonal() * scaled_covariance * scale.asDiagonal() * to_input.transpose();
  const Matrix6d to_origin = incrementMovedBy(-target_centroid);
  return to_origin * local * to_origin.transpose();
}

/** The point-to-plane information of \a at over its residuals' variance, as covarianceFrom()
 * gives the covariance: a left increment [delta, omega] about the input frame's origin.
 * Zero with 6 inliers or fewer. */
Matrix6d
informationFrom(const PoseEvidence& at,
                const Eigen::Vector3d& target_centroid,
                const Eigen::Matrix3d& target_axes)
{
  if (at.inliers <= 6 || !(at.plane_residuals > 0.0))
    return Matrix6d::Zero();
  const double variance = planeVariance(at);
  const Matrix6d order = covarianceOrder();
  // An increment about the input frame's origin, as one about the target local origin.
  const Matrix6d from_origin =
      turnedAlike(target_axes.transpose()) * incrementMovedBy(target_centroid);
  return from_origin.transpose() * (order * at.plane_information * order.transpose()) *
         from_origin / variance;
}

/** The confidence the evidence in \a v gives. */
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

} // namespace

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

Eigen::Matrix<double, 6, 6>
planeCovariance(const PoseEvidence& at,
                const SourceSamples& source,
                double resolution,
                const Eigen::Vector3d& target_centroid,
                const Eigen::Matrix3d& target_axes)
{
  const double radius = rotationRadius(source, resolution);
  return covarianceFrom(at, scaledInformation(at, radius), radius, target_centroid, target_axes);
}

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
