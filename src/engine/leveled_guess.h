/*
 * pcl_mi: a guess turned so that the two clouds' up directions agree, and the axes to
 * search it along, for sensors carried tilted.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_mi/parameters.h>

#include <Eigen/Core>

#include <optional>

namespace pcl_mi {
namespace core {

/** \brief Disagreement of the up directions (degrees) that leveling corrects: the estimates
 * agree to about a degree on scans taken level, and the search's default roll and pitch
 * steps cover a few degrees. */
constexpr double kLevelingDegrees = 5.0;

/** \brief True where \a parameters level (SearchParameters::leveling): leveling on and no
 * parameter pinned, since pins are meant along the target's own axes. */
bool
levelingApplies(const Parameters& parameters);

/** \brief True where the unit vectors \a a and \a b lie more than kLevelingDegrees apart. */
bool
apartBeyondLeveling(const Eigen::Vector3d& a, const Eigen::Vector3d& b);

/** \brief True where both up directions are known and \a guess, turning \a source_up,
 * keeps it within kLevelingDegrees of \a target_up: the sensor did not tilt between the
 * scans, as far as the clouds show. */
bool
guessKeepsUp(const std::optional<Eigen::Vector3d>& source_up,
             const std::optional<Eigen::Vector3d>& target_up,
             const Eigen::Matrix4d& guess);

/** \brief Where to search a tilted pair from, in the target frame. */
struct Leveling {
  /** The guess turned about the pivot so that the source's up direction meets the
   * target's. */
  Eigen::Matrix4d guess;
  /** Search axes: the third is the target's up, the first the target's x made horizontal,
   * so that yaw turns about up and x, y move along the ground, as for a level sensor. */
  Eigen::Matrix3d axes;
};

/** \brief Axes whose third is \a up and whose first is the frame's x made horizontal (its y
 * where x lies within 30 degrees of up): a level frame for a tilted cloud. */
Eigen::Matrix3d
levelAxes(const Eigen::Vector3d& up);

/** \brief The leveling of \a guess about \a pivot (target frame) by the least rotation that
 * takes the source's up direction \a source_up, as the guess moves it, onto the target's
 * \a target_up. Where the two agree within kLevelingDegrees, the guess as it is with level
 * axes if \a target_up lies more than that from the frame's z (a sensor mounted tilted),
 * nothing otherwise; nothing where either is unknown. */
std::optional<Leveling>
levelGuess(const std::optional<Eigen::Vector3d>& source_up,
           const std::optional<Eigen::Vector3d>& target_up,
           const Eigen::Matrix4d& guess,
           const Eigen::Vector3d& pivot);

} // namespace core
} // namespace pcl_mi
