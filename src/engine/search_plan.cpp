/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/search_plan.h"

#include "engine/candidates.h"
#include "engine/leveled_guess.h"
#include "util/stage_clock.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>
#include <vector>

namespace pcl_mi {
namespace core {

namespace {

/** Distance from the centroid, in RMS radii of the points, within which a cloud's origin
 * is taken for its sensor (SearchParameters::narrow_view_tilt_step): a scan in its sensor's
 * frame has it within two, a cloud in a far-off map frame far beyond. */
constexpr double kSensorOriginRadii = 4.0;

/** Roll and pitch steps (rad) of the wider second search, at least: a handheld or legged
 * sensor tilts by tens of degrees, a car's by a few (SearchParameters::narrow_view_tilt_step
 * has the same default for the same reason). */
constexpr double kSecondSearchTiltStep = 0.35;

/** Position starts of the wider second search, at least (SearchParameters::position_starts):
 * two lie half the x step either way along x. A fast car on a featureless road can leave
 * the first search at the guess, a whole motion short of the true pose. */
constexpr int kSecondSearchPositionStarts = 2;

/** Raises the roll and pitch steps of \a options to at least \a step, keeping their signs;
 * a pinned one stays pinned. */
void
widenTilt(const SearchSpace& space, double step, CoarseToFineOptions& options)
{
  for (const int parameter : {3, 4}) {
    const Eigen::Index i = space.index(parameter);
    if (i >= 0 && std::abs(options.steps[i]) < step)
      options.steps[i] = std::copysign(step, options.steps[i]);
  }
}

/** The first search's options: the parameters' steps and starts on \a space, capped at
 * \a max_iterations; a narrow view's wider tilt steps (where \a tilts), turned starts and
 * scanned turns. */
CoarseToFineOptions
firstSearchOptions(const PreparedProblem& problem,
                   const SearchSpace& space,
                   const Eigen::Matrix4d& guess,
                   bool tilts,
                   int max_iterations)
{
  const Parameters& p = problem.parameters();
  const bool narrow_view = problem.narrowView();
  CoarseToFineOptions options = space.searchOptions(p);
  options.first_level = problem.firstSearchedLevel();
  options.max_iterations = max_iterations;
  options.position_starts =
      options.x_index >= 0 || options.y_index >= 0
          ? std::max(p.search.position_starts,
                     narrow_view ? p.search.narrow_view_position_starts : 0)
          : 0;
  if (tilts)
    widenTilt(space, p.search.narrow_view_tilt_step, options);
  if (narrow_view && p.search.narrow_view_yaw_start > 0.0)
    options.yaw_starts = {p.search.narrow_view_yaw_start, -p.search.narrow_view_yaw_start};
  if (narrow_view) {
    options.scanned_starts = p.search.narrow_view_scanned_starts;
    // The scanned turns also look for roll, unless the clouds show that the sensor kept its
    // up: on a car's narrow view, turns in roll that score well on the coarse grid only
    // displace the right ones (docs/benchmarks.md, "Scanned turns in roll").
    options.scan_roll = !guessKeepsUp(problem.sourceUp(), problem.targetUp(), guess);
  }
  return options;
}

} // namespace

SearchPlan
planSearch(const PreparedProblem& problem, const Eigen::Matrix4d& guess, int max_iterations)
{
  const Parameters& p = problem.parameters();
  const LocalCloud& source = problem.source();
  const bool narrow_view = problem.narrowView();
  const bool tilts = narrow_view && p.search.narrow_view_tilt_step > 0.0;
  const bool about_sensor =
      tilts && source.centroid.norm() <= kSensorOriginRadii * source.rms_radius;
  const Eigen::Vector3d turned_about = about_sensor ? Eigen::Vector3d::Zero() : source.centroid;
  const Eigen::Vector3d pivot = (guess * turned_about.homogeneous()).head<3>();
  const std::optional<Leveling> leveled =
      levelingApplies(p) && !narrow_view
          ? levelGuess(problem.sourceUp(), problem.targetUp(), guess, pivot)
          : std::nullopt;
  SearchSpace space = leveled ? SearchSpace(p, leveled->guess, pivot, leveled->axes)
                              : SearchSpace(p, guess, pivot);
  CoarseToFineOptions options = firstSearchOptions(problem, space, guess, tilts, max_iterations);
  return {std::move(space), std::move(options), about_sensor, leveled.has_value()};
}

void
searchWider(PreparedProblem& problem,
            const SearchSpace& space,
            LevelCosts& costs,
            const CoarseToFineOptions& options,
            int max_iterations,
            JointHistogram& scratch,
            AlignmentResult& result,
            double& finest_normalized_mi)
{
  const int left = max_iterations - result.iterations;
  if (left <= 0)
    return;
  StageClock clock;
  CoarseToFineOptions wide = options;
  wide.max_iterations = left;
  if (wide.yaw_index >= 0)
    wide.heading_starts =
        std::max(wide.heading_starts, problem.parameters().search.second_search_headings);
  widenTilt(space, kSecondSearchTiltStep, wide);
  if (wide.x_index >= 0 || wide.y_index >= 0)
    wide.position_starts = std::max(wide.position_starts, kSecondSearchPositionStarts);
  const CoarseToFineResult again = searchCoarseToFine(costs, wide);
  result.second_search = true;
  result.iterations += again.iterations;
  result.evaluations += again.evaluations;
  std::vector<NelderMeadResult> optima{again.best};
  optima.insert(optima.end(), again.alternatives.begin(), again.alternatives.end());
  keepTheFinestGridsChoice(problem, space, optima, scratch, result, finest_normalized_mi);
  clock.end(result.stages, "second search", again.evaluations);
}

} // namespace core
} // namespace pcl_mi
