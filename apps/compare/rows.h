/*
 * pcl_mi_compare: one result row per (pair, method), and the CSV files that hold them.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_mi/types.h>

#include <Eigen/Core>

#include <cmath>
#include <ostream>
#include <string>
#include <vector>

namespace pcl_mi {
namespace compare {

/** One CSV row: a (pair, method) result. */
struct Row {
  std::string sequence, direction, method;
  int target = 0, source = 0;
  double true_translation = 0, true_rotation = 0;       // m, deg: the reference motion
  double initial_translation = 0, initial_rotation = 0; // m, deg: error of the guess
  double translation_error = 0, rotation_error = 0;     // m, deg: error of the result
  double seconds = 0;
  bool converged = false;
  int evaluations = 0;
  /** Signed translation error (m) in the pair's travel frame: along the reference
   * translation, to its left and up (the clouds' z is up). NaN where undefined (a reference
   * translation too short or vertical) or unknown (rows of files without these columns).
   * Kept as read rather than derived from the rounded transforms below, so -merge writes
   * back exactly what the shards wrote. */
  Eigen::Vector3d travel_error = Eigen::Vector3d::Constant(NAN);
  /** The result and the reference, source to target (NaN in rows of older files). */
  Eigen::Matrix4d estimate = Eigen::Matrix4d::Constant(NAN);
  Eigen::Matrix4d reference = Eigen::Matrix4d::Constant(NAN);
  /** MI's confidence and the standard deviations of its covariance (m, deg: x y z roll pitch
   * yaw); NaN for other methods and in rows of older files. */
  double confidence = NAN;
  double sigma[6] = {NAN, NAN, NAN, NAN, NAN, NAN};
  /** The evidence behind MI's confidence (pcl_mi::Verification), for refitting its model:
   * search converged (0/1), inliers, inlier fraction, peak contrast, weakest contrast,
   * normalised MI, the smaller free-direction contrast, the lead of a narrow view (NaN
   * for a 360-degree one), the smaller MI loss of the free turns asked of the MI (NaN
   * where none was) and how much of the direction with the smaller contrast is a turn (the
   * norm of its rotation part, scaled by the RMS radius, in [0, 1]). NaN as above; the last
   * three also in rows of files without them. */
  double evidence[10] = {NAN, NAN, NAN, NAN, NAN, NAN, NAN, NAN, NAN, NAN};
  /** Where MI's result did not converge, the kind of reason: pcl_mi::refusalName() of the
   * verdict's refusal, "the search capped" where the verdict passed but the search stopped
   * at the iteration cap or its share of it, or "failed" (an error); empty where it
   * converged, for other methods and in rows of files without the column. */
  std::string refusal;
  /** The same result's getLastError(), which says why in full. Quoted (RFC 4180), since
   * it holds commas. */
  std::string reason;
  /** MI's restarts of the refinement around a refused result
   * (pcl_mi::Verification::restart_turn_deg, restart_shift): the farthest turn (deg) and
   * shift (m) a restart ended from the result; NaN where not asked, for other methods and in
   * rows of files without the columns. */
  double restart_turn_deg = NAN, restart_shift = NAN;
  /** How far MI's alignment of the clouds swapped ended from a refused result, inverted
   * (pcl_mi::Verification::reverse_shift, reverse_turn_deg: m, deg); NaN where not asked,
   * for other methods and in rows of files without the columns. A result it confirmed says
   * converged. */
  double reverse_shift = NAN, reverse_turn_deg = NAN;
  /** MI's stages (pcl_mi::AlignmentResult::stages) of this run; not written to the CSV. */
  std::vector<pcl_mi::StageTiming> stages;
  /** With -reuse_target, whether this MI run prepared a target it had not kept (the first
   * against each map) or aligned against one it kept; kNone otherwise. Not written to the
   * CSV. */
  enum class TargetReuse { kNone, kPrepared, kKept } target_reuse = TargetReuse::kNone;
};

/** The CSV header (every column writeRow() writes). */
std::string
csvHeader();

/** \a estimate - reference translation (target frame) along the reference motion, to its
 * left and up; NaN where the motion is too short or vertical. */
Eigen::Vector3d
travelFrameError(const Eigen::Matrix4d& estimate, const Eigen::Matrix4d& reference);

void
writeRow(std::ostream& out, const Row& r);

/** Reads rows written by writeRow(); false with \a error on a malformed file. */
bool
readRows(const std::string& path, std::vector<Row>& rows, std::string& error);

} // namespace compare
} // namespace pcl_mi
