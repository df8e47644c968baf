/*
 * pcl_mi: the coarse-to-fine Nelder-Mead search over a voxel pyramid. It sees only a cost
 * per level and search vector, never a cloud, so it is tested on synthetic functions.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "search/nelder_mead.h"

#include <pcl_mi/types.h>

#include <Eigen/Core>

#include <vector>

namespace pcl_mi {
namespace core {

/** \brief The function the search minimises, one per pyramid level (0 = finest). */
class LevelCosts {
public:
  virtual ~LevelCosts() = default;

  /** \brief Number of pyramid levels. */
  virtual int
  levels() const = 0;

  /** \brief Voxel size of \a level: coarse optima closer than half of it are one basin. */
  virtual double
  resolution(int level) const = 0;

  /** \brief Cost of the search vector \a x on \a level, computed by evaluator \a slot
   * (0 or 1). The two slots may be called concurrently; one slot never is. */
  virtual double
  cost(int level, int slot, const Eigen::VectorXd& x) = 0;

  /** \brief Costs of several search vectors at once, by evaluator \a slot: values[i] =
   * cost(level, slot, xs[i]). By default one cost() call each. */
  virtual void
  costs(int level, int slot, const std::vector<Eigen::VectorXd>& xs, std::vector<double>& values)
  {
    for (std::size_t i = 0; i < xs.size(); ++i)
      values[i] = cost(level, slot, xs[i]);
  }

  /** \brief True when a batch costs about as much as one evaluation (a GPU round trip):
   * the search then runs a level's independent searches in lockstep, by evaluator 0, and
   * asks for each iteration's candidates together (speculatively), one batch per round. */
  virtual bool
  prefersBatches() const
  {
    return false;
  }
};

/** \brief What the search does, in the units of its search vector. */
struct CoarseToFineOptions {
  Eigen::VectorXd steps;     ///< initial simplex step per search parameter
  Eigen::VectorXd tolerance; ///< finest-level convergence tolerance per search parameter
  /** Per search parameter: a translation (true) or an angle in radians (false). */
  std::vector<bool> translational;
  /** Where x, y, roll, pitch and yaw sit in the search vector; -1 when pinned. */
  Eigen::Index x_index = -1, y_index = -1, roll_index = -1, pitch_index = -1, yaw_index = -1;
  int heading_starts = 1;   ///< headings spread over 360 degrees (only with a yaw index)
  int position_starts = 0;  ///< starts on the ellipse of half the x and y steps
  /** Further starts at the guess's position, at these yaw offsets (rad) from it (only with
   * a yaw index). */
  std::vector<double> yaw_starts;
  /** Further starts at the guess's position, turned by the best-scoring turns of a grid of
   * yaw (every 10 degrees within 60), pitch (within 30) and, with scan_roll and a roll
   * index, roll (within 30) that the coarsest level's cost scores first, at least 11
   * degrees from the guess and 17 from each other (only with yaw and pitch indices). */
  int scanned_starts = 0;
  bool scan_roll = false;
  bool symmetric_start = true;
  int first_level = 0;      ///< finest level searched (levels below are skipped)
  int restarts = 0;         ///< restarts on the finest searched level
  double restart_scale = 0.25;
  int max_iterations = 1000; ///< over every start, level and restart
  int num_threads = 2;
};

/** \brief Outcome of the search. */
struct CoarseToFineResult {
  NelderMeadResult best;  ///< best vertex of the finest searched level
  /** The other candidates' optima on the finest searched level, best first: the runners-up
   * a caller may turn to when it does not trust the best. */
  std::vector<NelderMeadResult> alternatives;
  int iterations = 0;     ///< summed over every search
  int evaluations = 0;    ///< summed over every search
  int batches = 0;        ///< requests answered (one batch each where the costs prefer
                          ///< batches), summed over every search
  /** The turns scanned_starts started from, as (roll, pitch, yaw) in rad. */
  std::vector<Eigen::Vector3d> scanned_turns;
  /** One stage per level ("search 4 m", ...) and "restarts", with its evaluations. */
  std::vector<StageTiming> stages;
};

/** \brief Searches the coarsest level from the origin of the search vector (and from the
 * further heading and position starts), then refines the best few distinct coarse optima
 * and the origin on each finer level down to options.first_level, then restarts there.
 * The result does not depend on options.num_threads. */
CoarseToFineResult
searchCoarseToFine(LevelCosts& costs, const CoarseToFineOptions& options);

/** \brief Finishes a capped search of options.first_level (one of
 * CoarseToFineResult::alternatives) from its end \a x, as the search finishes a capped
 * candidate that wins: a simplex of half that level's steps, at most \a max_iterations
 * iterations, the level's tolerance. */
NelderMeadResult
finishOnFirstLevel(LevelCosts& costs,
                   const CoarseToFineOptions& options,
                   const Eigen::VectorXd& x,
                   int max_iterations);

} // namespace core
} // namespace pcl_mi
