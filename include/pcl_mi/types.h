/*
 * pcl_mi: 3D scan alignment by maximising the mutual information of voxel features.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

// The bottom floor: the value types every layer shares (engine, search, features,
// backends, adapter). It includes nothing of pcl_mi.

#include <Eigen/Core>

#include <cstddef>

#include <cstdint>
#include <limits>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

namespace pcl_mi {

/** \brief Point coordinates as the core consumes them: plain xyz, no point type. */
using PointList = std::vector<Eigen::Vector3f>;

/** \brief Read-only view of points kept elsewhere: point i's x, y and z are three
 * consecutive floats at \a stride bytes per point from the first point's x, as in a PCL cloud
 * of any point type with x, y and z. The core reads the points through it instead of
 * copying them first; the memory must stay valid and unchanged while the view is in use,
 * which owner(), when set, ensures for as long as the view (or a copy of it) lives. */
class PointView {
public:
  PointView() = default;

  /** \brief Views \a points, which must outlive the view unless \a owner keeps them. */
  PointView(const PointList& points, // NOLINT: a list is a view's most common source
            std::shared_ptr<const void> owner = nullptr)
  : first_(points.empty() ? nullptr : reinterpret_cast<const unsigned char*>(points.data()->data()))
  , stride_(sizeof(Eigen::Vector3f))
  , size_(points.size())
  , owner_(std::move(owner))
  {}

  /** \brief Views \a size points whose first x is at \a first_x, \a stride bytes apart;
   * \a owner (optional) keeps their memory alive. */
  PointView(const float* first_x,
            std::size_t stride,
            std::size_t size,
            std::shared_ptr<const void> owner = nullptr)
  : first_(reinterpret_cast<const unsigned char*>(first_x))
  , stride_(stride)
  , size_(first_x ? size : 0)
  , owner_(std::move(owner))
  {}

  std::size_t
  size() const
  {
    return size_;
  }
  bool
  empty() const
  {
    return size_ == 0;
  }
  Eigen::Vector3f
  operator[](std::size_t i) const
  {
    const float* p = reinterpret_cast<const float*>(first_ + i * stride_);
    return {p[0], p[1], p[2]};
  }
  /** \brief What keeps the points alive (null for a view that does not own them). */
  const std::shared_ptr<const void>&
  owner() const
  {
    return owner_;
  }

private:
  const unsigned char* first_ = nullptr;
  std::size_t stride_ = sizeof(Eigen::Vector3f);
  std::size_t size_ = 0;
  std::shared_ptr<const void> owner_;
};

/** \brief A view that owns \a points. */
inline PointView
ownedView(PointList points)
{
  auto owned = std::make_shared<const PointList>(std::move(points));
  const PointList& list = *owned; // bound before the owner moves into the view
  return PointView(list, std::move(owned));
}

/** \brief Joint histogram of target (X) and source (Y) voxel feature bins over the overlap.
 *
 * Row-major: count(x, y) = counts[x * num_bins + y]; bin 0 is "unoccupied". */
struct JointHistogram {
  int num_bins = 0;                   ///< bins per axis (occupied bins + 1)
  std::vector<std::uint32_t> counts;  ///< num_bins * num_bins integer counts
  std::uint64_t overlap_voxels = 0;   ///< voxels in the overlap region (sum of counts)

  std::uint32_t
  at(int x, int y) const
  {
    return counts[static_cast<std::size_t>(x) * num_bins + y];
  }
};

/** \brief Per-voxel feature whose distribution the mutual information is computed over. */
enum class Feature {
  VarianceZ,  ///< variance of the points' z in the voxel (the paper's MI-VARZ)
  PointCount  ///< number of points in the voxel (the paper's MI-N)
};

/** \brief Human-readable name of a feature ("VarianceZ", "PointCount"). */
const char*
featureName(Feature feature);

/** \brief Prints the feature's name (for logs and test output). */
inline std::ostream&
operator<<(std::ostream& os, Feature feature)
{
  return os << featureName(feature);
}

/** \brief How the value of an occupied voxel maps to a histogram bin.
 *
 * Bin 0 is reserved for unoccupied voxels (the paper's "no feature" value). An occupied
 * voxel with feature value v falls into
 *
 *     bin = 1 + min(num_bins - 1, floor(num_bins * v / max_value))
 *
 * so bins 1..num_bins split [0, max_value) into equal intervals and values >= max_value
 * land in the last bin. The histograms therefore have num_bins + 1 bins.
 *
 * Feature values: VarianceZ uses var(z) / resolution^2 (dimensionless, in [0, 0.25];
 * a voxel filled uniformly top to bottom, such as a wall, gives 1/12), so the binning
 * does not have to change with the resolution. PointCount uses the plain point count.
 */
struct FeatureBinning {
  int num_bins = 0;       ///< number of bins for occupied voxels (>= 1)
  double max_value = 0.0; ///< upper end of the binned range (> 0)
  /** When > 0, each target grid takes max_value from its own occupied voxels instead: the
   * range_quantile quantile of their feature values (max_value stays the fallback when
   * that quantile is 0). Source voxels are binned with the same range, so X and Y stay
   * comparable. 0 = the fixed max_value. In [0, 1]. */
  double range_quantile = 0.0;
};

/** \brief Wall-clock time spent in one stage of an alignment. */
struct StageTiming {
  std::string name;      ///< e.g. "prepare", "search 4 m", "refinement"
  int calls = 0;         ///< times the stage ran (cost evaluations for a search stage)
  double total_ms = 0.0; ///< wall-clock milliseconds, summed over calls
};

/** \brief Which test of the verdict refused a result (docs/method.md, "The verdict"), so that
 * code can act on the kind without parsing Verification::reason. */
enum class Refusal {
  None,                ///< the result passed every test
  LittleSharedSurface, ///< too few source samples on the target's surfaces
  Degenerate,          ///< the surfaces leave a direction free (a corridor, a floor)
  SecondOptimum,       ///< a pose nearby scores a higher MI on the finest grid
  WeakEvidence         ///< the confidence is under the threshold
};

/** \brief Short name of a refusal: "none", "too little shared surface", "degenerate", "a
 * second optimum", "weak evidence". */
const char*
refusalName(Refusal refusal);

/** \brief The evidence for and against one result, and what it implies (docs/method.md,
 * "The verdict"). Pose increments are [tx, ty, tz, roll, pitch, yaw]: a small motion
 * applied on the left of the result (in the target frame, rotations about its origin) that
 * would carry it onto the true pose. The matrices are unaligned, so code built with other
 * vectorisation flags than the library (e.g. -march=native) shares this layout. */
struct Verification {
  /** Probability that the result is within 0.5 m and 2 degrees of the true pose, from a
   * logistic model of the evidence below fitted on real scans of several sensors; for a
   * refused result that restarts of the refinement find unsteady (restart_turn_deg), a
   * degenerate one that leaves the sensors in place (sensors_in_place), or one that the
   * alignment of the clouds swapped confirmed or did not (reverse_confirmed), the share of
   * such results that were right. A result that passed its own tests on fewer than 60
   * inliers takes that times the chance its covariance gives it to lie within the bound,
   * and where that holds it back, the share of the results the clouds swapped confirmed or
   * did not (docs/method.md, "The verdict", step 7). */
  double confidence = 0.0;
  /** Empty when the result passes the reliability test, otherwise why not. */
  std::string reason;
  /** Which test refused the result (None where reason is empty). */
  Refusal refusal = Refusal::None;
  /** Share of the source samples that fall into a target cube with a surface. */
  double overlap = 0.0;
  /** Share of those within three standard deviations of the cube's surface (inliers). */
  double inlier_fraction = 0.0;
  /** Number of inlier samples. */
  std::size_t inliers = 0;
  /** Mean share of the inliers lost by moving the result one voxel along an axis, or turning
   * it so far that a point at the source's RMS radius moves one voxel: a true optimum is a
   * sharp peak. */
  double peak_contrast = 0.0;
  /** The same in the direction that loses the fewest (near 0 where the scene leaves the
   * pose free, negative where a neighbour scores better). */
  double weakest_contrast = 0.0;
  /** MI divided by the smaller of the two marginal entropies, over the overlap. */
  double normalized_mi = 0.0;
  /** Eigenvalues (ascending) of the point-to-plane information of the inliers, rotations
   * scaled by the source's RMS radius (a unit of rotation moves a point at that radius by a
   * unit of length), each divided by the largest: small in a direction the surfaces
   * constrain little. */
  Eigen::Matrix<double, 6, 1, Eigen::DontAlign> observability =
      Eigen::Matrix<double, 6, 1, Eigen::DontAlign>::Zero();
  /** The matching unit eigenvectors (columns) in the scaled increments. Where the two least
   * eigenvalues lie within a factor of two of each other, the first two columns are turned
   * within their plane so that the first carries the least information per motion of the
   * samples and the second the most: a turn scaled at the RMS radius can look as weak as a
   * free shift, and the two eigenvectors then mix them. Where the three least lie within a
   * factor of two and neither of the first two is free, the second is the shift along an
   * axis of the target's frame that loses the fewest inliers moved a voxel, if that is free:
   * three such eigenvectors are any mix of their directions. */
  Eigen::Matrix<double, 6, 6, Eigen::DontAlign> observability_directions =
      Eigen::Matrix<double, 6, 6, Eigen::DontAlign>::Identity();
  /** The point (the target's input frame) about which those directions turn, and the
   * radius at which their turns are scaled: a column [t, omega * radius] moves a target point
   * p by t + omega x (p - observability_centre). */
  Eigen::Matrix<double, 3, 1, Eigen::DontAlign> observability_centre =
      Eigen::Matrix<double, 3, 1, Eigen::DontAlign>::Zero();
  double observability_radius = 1.0;
  /** Share of the inliers lost by moving the result either way along each of the first two
   * observability_directions, so far that the samples move one voxel (root mean square); below
   * 0.05 the direction counts as free (degenerate) unless the MI holds it
   * (free_turn_mi_loss) or, a turn, the refinement (free_turns_held). Where the result leaves
   * the sensors where they were (within a voxel, the vertical axis tilted by less than a
   * voxel at the source's RMS radius, any heading; the input frames' origins and axes stand
   * for them), only inliers on surfaces that the move crosses count: the scan patterns then
   * fall on one another by themselves. Where a scan all around is left within a voxel with
   * its vertical axis tilted further, the same holds for a direction that is mostly a shift:
   * both scans' patterns are centred on one point, and a shift moves one off the other. */
  double free_direction_contrast[2] = {0.0, 0.0};
  /** For each of those two directions that the contrast leaves free and that is mostly a turn
   * tilting the source (about an axis at least 60 degrees from the input frame's z), the
   * share of the MI on the finest grid that the same moves lose, either way on average; NaN
   * where it was not asked (and where the sensors stand where they were). At 0.1 or more the
   * MI holds the turn, and the direction does not count as free. */
  double free_turn_mi_loss[2] = {std::numeric_limits<double>::quiet_NaN(),
                                 std::numeric_limits<double>::quiet_NaN()};
  /** Narrow fields of view only, NaN otherwise: how far the MI on the finest grid of the
   * result's optimum in translation leads the highest other optimum found within six voxels
   * across, as a share of its own; negative where another scores higher, which the verdict
   * does not pass, 1 where the searches found none (docs/method.md, "Shifted optima"). */
  double lead = std::numeric_limits<double>::quiet_NaN();
  /** Results the reliability test refuses only, NaN otherwise: the largest turn (degrees)
   * and shift (of the source's centroid, in the clouds' units) from the result to where the
   * refinement ends when restarted from the result turned 2 degrees either way about each
   * axis of the target. From 1 degree or 0.25 m on (Parameters::units_per_metre), half the
   * success bound, the result is unsteady, and its confidence is the share of such results
   * that were right (docs/method.md, "The verdict"). */
  double restart_turn_deg = std::numeric_limits<double>::quiet_NaN();
  double restart_shift = std::numeric_limits<double>::quiet_NaN();
  /** True where those restarts reached half the success bound: the refinement does not hold
   * the result where it is, and confidence is the share of such results that were right. */
  bool unsteady = false;
  /** True where the surfaces leave only turns free, the restarts find the result steady and
   * it puts the sensors (the input frames' origins) more than a voxel apart: the refinement
   * holds those turns, so they do not count as free, and the result was judged again
   * without them (docs/method.md, "The verdict"). */
  bool free_turns_held = false;
  /** True where the result leaves the sensors where they were: within a voxel of each other
   * (the input frames' origins), the vertical axis tilted by less than a voxel at the
   * source's RMS radius, any heading. There the scans' own patterns (a spinning LiDAR's
   * rings) fall on one another and raise the evidence, whatever the surfaces hold; a
   * degenerate result there takes a fixed confidence (docs/method.md, "The verdict"). */
  bool sensors_in_place = false;
  /** Results the reliability test refused (or passed with its search capped) with a
   * confidence of at least 0.8, and those held back for a sparse result's spread (step 7),
   * only; NaN otherwise: how far (in the clouds' units, at the target frame's origin;
   * degrees) the alignment of the clouds swapped, from the inverse of the guess, ended from
   * the result, inverted. That alignment also weighs the result itself, as a runner-up of
   * its own search, where its search met its tolerances and ended apart from it. */
  double reverse_shift = std::numeric_limits<double>::quiet_NaN();
  double reverse_turn_deg = std::numeric_limits<double>::quiet_NaN();
  /** Where that alignment did not confirm the result, why: "it ends more than 0.25 m or 0.5
   * deg away" (2 deg where it holds a turn the result leaves free), "it shares too little
   * surface itself", "it leaves a direction free itself, and this result ..." or "its own
   * confidence, ..., is under 0.50". Empty where it confirmed the result or was not asked;
   * getLastError() ends with it. */
  std::string reverse_reason;
  /** True where that alignment confirmed the result: it ended within 0.25 m
   * (Parameters::units_per_metre) and 0.5 degrees (2 degrees where the result leaves only
   * turns free and that alignment passes every test itself, holding them), and found shared
   * surface with a confidence of at least 0.5 and no free direction (a free one only where
   * the result holds every direction itself, on enough surface, and names no second
   * optimum, or where the result is degenerate and every direction it leaves free lies at
   * least 45 degrees from the ones that alignment leaves). The result then converged, on
   * sparse evidence too (their agreement measured its spread), with the confidence of such
   * results, and, where it had none, the swapped alignment's covariance (or, where that has
   * none either, the inverse of the two sides' mean information); one it did not confirm
   * takes the share of those that were right (docs/method.md, "The verdict"). */
  bool reverse_confirmed = false;
  /** Covariance (m^2, rad^2) of the pose increment, from the point-to-plane information and
   * the inliers' residuals; zero for a result with a free direction or too few inliers. It
   * treats the samples as independent; RegistrationCore::covarianceScale() says how much
   * wider it is where the result depends on where the cells cut the surfaces, and
   * getCovariance() and Python's covariance include that. */
  Eigen::Matrix<double, 6, 6, Eigen::DontAlign> covariance =
      Eigen::Matrix<double, 6, 6, Eigen::DontAlign>::Zero();
  /** Point-to-plane information (1/m^2, 1/rad^2) of the pose increment, in the covariance's
   * frame and order, over the inliers' residual variance: where every direction is held, the
   * inverse of the covariance before the refinement's last step is added; finite (small) along
   * a free direction too. Zero with 6 inliers or fewer. As the covariance, it treats the
   * samples as independent: divided by RegistrationCore::covarianceScale(), it is the
   * information getCovariance() stands for. A result that leaves a direction free, confirmed
   * by a swapped side that leaves another free (reverse_confirmed), takes as its covariance
   * the inverse of the two sides' mean information. */
  Eigen::Matrix<double, 6, 6, Eigen::DontAlign> information =
      Eigen::Matrix<double, 6, 6, Eigen::DontAlign>::Zero();
};

/** \brief Outcome of one alignment. */
struct AlignmentResult {
  /** Source-to-target transformation (maps source points into the target frame). */
  Eigen::Matrix4d transformation = Eigen::Matrix4d::Identity();
  /** True only when the search converged and the result passed the reliability test
   * (verification.reason is empty); false when the iteration cap ended the search, the
   * evidence does not support the result, or the alignment failed. */
  bool converged = false;
  /** True when the simplex shrank below the tolerances, whatever the verification says. */
  bool search_converged = false;
  /** Nelder-Mead iterations performed. */
  int iterations = 0;
  /** Cost (mutual information) evaluations performed. */
  int evaluations = 0;
  /** Gauss-Newton iterations of the refinement, summed over its stages (0 when off or
   * discarded). */
  int refinement_iterations = 0;
  /** Stages of the refinement: 1, or 1 + RefinementParameters::narrow_view_stages for a
   * narrow field of view (0 when off or discarded). */
  int refinement_stages = 0;
  /** Further starts around the guess the coarsest level used: position_starts, or
   * narrow_view_position_starts for a narrow field of view (0 when x and y are pinned). */
  int position_starts = 0;
  /** Further starts at the guess's position turned in yaw: 2 for a narrow field of view
   * (SearchParameters::narrow_view_yaw_start), else 0. */
  int yaw_starts = 0;
  /** Further starts at turns the coarsest level scored best on a grid, for a narrow field
   * of view (SearchParameters::narrow_view_scanned_starts), else 0. */
  int scanned_starts = 0;
  /** The search turned the source about its sensor (the origin of its frame) with wider
   * roll and pitch steps, as SearchParameters::narrow_view_tilt_step says for a narrow field
   * of view; false where it turned it about its centroid. */
  bool turned_about_sensor = false;
  /** Runners-up of the search (other candidates' optima on the finest searched level, and
   * the second search's optima) that were refined and verified because the verification
   * did not trust the best one. */
  int runners_up_checked = 0;
  /** The result is one of those runners-up: it agreed better with the target on the finest
   * grid (normalised MI) than the search's best, or it lies on surfaces the clouds share
   * where the best does not (fewer than 30 inliers). */
  bool runner_up_kept = false;
  /** The wider second search ran (SearchParameters::second_search_headings); where it found
   * the result, runner_up_kept is true too. */
  bool second_search = false;
  /** The reverse search ran (SearchParameters::reverse_search): the target was searched onto
   * the source too. */
  bool reverse_search = false;
  /** The result is one of the reverse search's optima, inverted, refined and verified: it
   * lies on surface the clouds share and agreed better with the target on the finest grid
   * than the result before it. */
  bool reverse_kept = false;
  /** For a narrow field of view: the result moved to a higher optimum of the MI on the
   * finest grid a few voxels across, at the same rotation, as on a facade whose windows or
   * pillars repeat. */
  bool shifted_optimum_kept = false;
  /** The search ran along the target's up direction, read from its horizontal surfaces
   * (SearchParameters::leveling): the two clouds' ups disagreed under the guess by more than
   * 5 degrees, as between scans of a sensor carried tilted, and the search started from the
   * guess turned so that they agree; or they agree on an up more than 5 degrees from the
   * target's z, as for a sensor mounted tilted, and the guess needed no turn. */
  bool leveled = false;
  /** Mutual information (nats) at the final transformation. */
  double mutual_information = 0.0;
  /** Empty on success, otherwise why the alignment failed. */
  std::string error;
  /** What the caller should know that did not stop the alignment (e.g. a large share of a
   * cloud dropped as far outliers); the PCL adapter prints each with PCL_WARN. */
  std::vector<std::string> warnings;
  /** Where the time went, stage by stage in the order they ran. Concurrent searches are
   * one stage; its time is wall-clock. */
  std::vector<StageTiming> stages;
  /** The evidence for and against the result. */
  Verification verification;
};

} // namespace pcl_mi
