/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "search/coarse_to_fine.h"

#include "search/two_evaluators.h"

#include "util/parallel.h"
#include "util/stage_clock.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

namespace pcl_mi {
namespace core {

namespace {

/** Tolerance of pyramid level l > 0, relative to the finest level's: factor * 2^l. */
constexpr double kCoarseToleranceFactor = 30.0;

/** Iterations of the search from the guess on the first finer level. That candidate only
 * has to keep a good guess from being pulled off its peak by the coarse grid; a search
 * that needs more is travelling far, which the search from the coarse optimum covers.
 * Capping it keeps the runtime from growing with the initial error; a capped search that
 * wins is finished on its own afterwards. */
constexpr int kGuessCandidateIterations = 25;

/** Most optima of further starts that the level after the coarsest refines besides the
 * best one: the coarse grid ranks them, the finer one decides, and where the verification
 * does not trust its choice, the finest grid decides among all of them
 * (CoarseToFineResult::alternatives). */
constexpr int kMaxStartCandidates = 8;
/** Rotation (rad) below which two coarse optima half a coarse voxel apart are one basin. */
constexpr double kCandidateSeparationRad = 0.2;

/** The grid of turns that scanned starts are chosen from: yaw, pitch and (where asked) roll
 * in steps of kScanStepRad (10 degrees), up to kScanYawSteps and kScanTiltSteps of them
 * either way. A handheld narrow view turns mostly in yaw and tilts less. */
constexpr double kScanStepRad = 0.175;
constexpr int kScanYawSteps = 6;
constexpr int kScanTiltSteps = 3;
/** A scanned turn closer to the guess than this (rad, in every angle) is the guess's own
 * start; two closer to each other than kScanSeparationRad are one. */
constexpr double kScanMinTurnRad = 0.2;
constexpr double kScanSeparationRad = 0.3;

/** One search's start: point, simplex steps and iteration cap. */
struct Start {
  Eigen::VectorXd x0;
  Eigen::VectorXd steps;
  int cap;
};

/** The searches of one alignment, with the iteration budget, the counts and the best
 * result of the current level. */
class Searcher {
public:
  Searcher(LevelCosts& costs, const CoarseToFineOptions& options)
  : costs_(costs), o_(options), budget_(options.max_iterations)
  {}

  /** One Nelder-Mead search on \a level, capped at \a cap. */
  NelderMeadResult
  search(int level, const Start& start)
  {
    return searchAll(level, {start}).front();
  }

  /** Independent searches on one level, each as search() would run it alone. Where the
   * costs prefer batches (a GPU), they run in lockstep with one batch of every search's
   * points per round; otherwise on two evaluators, one thread each where threads allow
   * (runOnTwoEvaluators()). The results are the same either way: every search's cap is fixed
   * before it starts. */
  std::vector<NelderMeadResult>
  searchAll(int level, const std::vector<Start>& starts)
  {
    std::vector<NelderMeadRun> runs;
    for (const Start& s : starts)
      runs.emplace_back(s.x0, s.steps, options(level, s.cap));
    if (costs_.prefersBatches())
      result_.batches += runTogether(runs, [&](const std::vector<Eigen::VectorXd>& xs,
                                               std::vector<double>& values) {
        costs_.costs(level, 0, xs, values);
      });
    else
      result_.batches += runOnTwoEvaluators(
          runs, [&](int slot, const Eigen::VectorXd& x) { return costs_.cost(level, slot, x); },
          o_.num_threads);
    std::vector<NelderMeadResult> results;
    for (const NelderMeadRun& run : runs)
      results.push_back(run.result());
    return results;
  }

  NelderMeadOptions
  options(int level, int cap) const
  {
    NelderMeadOptions options;
    options.speculative = costs_.prefersBatches();
    options.max_iterations = std::max(cap, 0);
    // A coarse level only has to land in the basin: the next level restarts with a larger
    // simplex than this tolerance anyway.
    options.tolerance =
        o_.tolerance * (level > 0 ? kCoarseToleranceFactor * std::ldexp(1.0, level) : 1.0);
    return options;
  }

  /** Books a finished search against the budget and the level's best. */
  void
  account(const NelderMeadResult& r)
  {
    budget_ -= r.iterations;
    result_.iterations += r.iterations;
    result_.evaluations += r.evaluations;
    if (!have_best_ || r.value < result_.best.value) {
      result_.best = r;
      have_best_ = true;
    }
  }

  /** The best result of each start on the coarsest level (each start's pair counts as
   * one), booked. */
  std::vector<NelderMeadResult>
  searchCoarsest(int level)
  {
    const Eigen::Index n = o_.steps.size();
    const Eigen::VectorXd origin = Eigen::VectorXd::Zero(n);
    const int headings = o_.yaw_index >= 0 ? o_.heading_starts : 1;
    const int positions = o_.position_starts;
    // Turns at the guess's position: the fixed yaw offsets, then the scanned turns.
    std::vector<Eigen::Vector3d> turns_at_guess; // (roll, pitch, yaw)
    if (o_.yaw_index >= 0)
      for (const double yaw : o_.yaw_starts)
        turns_at_guess.emplace_back(0.0, 0.0, yaw);
    for (const Eigen::Vector3d& turn : scannedTurns(level))
      turns_at_guess.push_back(turn);
    const int turns = static_cast<int>(turns_at_guess.size());
    const int starts = headings + positions + turns;
    // Each start gets the same share of the budget; the mirrored simplex (all steps
    // negated) makes the pair symmetric about the start, and the fixed shares make the
    // result independent of whether the pair runs concurrently.
    const int start_budget = budget_ / starts;
    const int mirrored_cap = o_.symmetric_start ? start_budget / 2 : 0;
    const int forward_cap = start_budget - mirrored_cap;
    std::vector<Start> runs;
    for (int k = 0; k < starts; ++k) {
      Eigen::VectorXd start = origin;
      if (k > 0 && k < headings) // k * 360 / headings degrees, in (-180, 180]
        start[o_.yaw_index] = std::remainder(2.0 * M_PI * k / headings, 2.0 * M_PI);
      if (k >= headings + positions) {
        const Eigen::Vector3d& turn =
            turns_at_guess[static_cast<std::size_t>(k - headings - positions)];
        if (o_.roll_index >= 0)
          start[o_.roll_index] = turn[0];
        if (o_.pitch_index >= 0)
          start[o_.pitch_index] = turn[1];
        start[o_.yaw_index] = turn[2];
      }
      else if (k >= headings) {
        const double angle = 2.0 * M_PI * (k - headings) / positions;
        if (o_.x_index >= 0)
          start[o_.x_index] = 0.5 * o_.steps[o_.x_index] * std::cos(angle);
        if (o_.y_index >= 0)
          start[o_.y_index] = 0.5 * o_.steps[o_.y_index] * std::sin(angle);
      }
      runs.push_back({start, o_.steps, forward_cap});
      if (o_.symmetric_start)
        runs.push_back({start, -o_.steps, mirrored_cap});
    }
    const std::vector<NelderMeadResult> results = searchAll(level, runs);
    const std::size_t per_start = o_.symmetric_start ? 2 : 1;
    std::vector<NelderMeadResult> start_best;
    for (std::size_t k = 0; k < results.size(); k += per_start) {
      account(results[k]);
      if (per_start == 1) {
        start_best.push_back(results[k]);
        continue;
      }
      account(results[k + 1]);
      start_best.push_back(results[k + 1].value < results[k].value ? results[k + 1] : results[k]);
    }
    return start_best;
  }

  /** The options.scanned_starts best turns of the scan grid on \a level, best first and
   * distinct, into CoarseToFineResult::scanned_turns, which it returns (the evaluations
   * booked). The grid is scored in two halves, one per evaluator, or as one batch where the
   * costs prefer it. */
  const std::vector<Eigen::Vector3d>&
  scannedTurns(int level)
  {
    std::vector<Eigen::Vector3d>& turns = result_.scanned_turns;
    turns.clear();
    if (o_.scanned_starts <= 0 || o_.yaw_index < 0 || o_.pitch_index < 0)
      return turns;
    const bool roll = o_.scan_roll && o_.roll_index >= 0;
    const int roll_steps = roll ? kScanTiltSteps : 0;
    std::vector<Eigen::VectorXd> grid;
    for (int a = -kScanYawSteps; a <= kScanYawSteps; ++a)
      for (int b = -kScanTiltSteps; b <= kScanTiltSteps; ++b)
        for (int c = -roll_steps; c <= roll_steps; ++c) {
          Eigen::VectorXd x = Eigen::VectorXd::Zero(o_.steps.size());
          x[o_.yaw_index] = a * kScanStepRad;
          x[o_.pitch_index] = b * kScanStepRad;
          if (roll)
            x[o_.roll_index] = c * kScanStepRad;
          grid.push_back(x);
        }
    std::vector<double> values(grid.size());
    if (costs_.prefersBatches()) {
      costs_.costs(level, 0, grid, values);
      ++result_.batches;
    }
    else {
      const std::size_t half = grid.size() / 2;
      parallelFor(2, o_.num_threads, [&](int slot) {
        const std::size_t begin = slot == 0 ? 0 : half;
        const std::size_t end = slot == 0 ? half : grid.size();
        for (std::size_t i = begin; i < end; ++i)
          values[i] = costs_.cost(level, slot, grid[i]);
      });
    }
    result_.evaluations += static_cast<int>(grid.size());
    std::vector<std::size_t> order(grid.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return values[a] < values[b]; });
    // The guess is the grid's centre: a turn that scores no better is no lead.
    const double at_guess = values[grid.size() / 2];
    for (const std::size_t i : order) {
      if (static_cast<int>(turns.size()) == o_.scanned_starts || !(values[i] < at_guess))
        break;
      const Eigen::Vector3d turn(roll ? grid[i][o_.roll_index] : 0.0, grid[i][o_.pitch_index],
                                 grid[i][o_.yaw_index]);
      bool distinct = turn.cwiseAbs().maxCoeff() > kScanMinTurnRad;
      for (const Eigen::Vector3d& other : turns)
        distinct = distinct && (turn - other).cwiseAbs().maxCoeff() > kScanSeparationRad;
      if (distinct)
        turns.push_back(turn);
    }
    return turns;
  }

  /** What the first finer level refines: the coarse optimum; the guess (the origin) when
   * the optimum left it, since a coarse grid can pull a good guess off the fine peak; and
   * with several starts the best few optima of the others that are not the same basin (a
   * straight road looks much the same turned by 180 deg on a coarse grid). */
  std::vector<Eigen::VectorXd>
  candidates(int level, std::vector<NelderMeadResult> start_best) const
  {
    const Eigen::Index n = o_.steps.size();
    std::vector<Eigen::VectorXd> candidates{result_.best.x};
    if (level <= o_.first_level)
      return candidates;
    if ((result_.best.x.cwiseAbs().array() > o_.tolerance.array() * kCoarseToleranceFactor)
            .any())
      candidates.push_back(Eigen::VectorXd::Zero(n));
    if (start_best.size() < 2)
      return candidates;
    std::stable_sort(start_best.begin(), start_best.end(),
                     [](const NelderMeadResult& a, const NelderMeadResult& b) {
                       return a.value < b.value;
                     });
    const double half_voxel = 0.5 * costs_.resolution(level);
    int added = 0;
    for (const NelderMeadResult& r : start_best) {
      if (added == kMaxStartCandidates)
        break;
      bool distinct = true;
      for (const Eigen::VectorXd& c : candidates) {
        double shift = 0.0, turn = 0.0;
        for (Eigen::Index i = 0; i < n; ++i) {
          const double delta = r.x[i] - c[i];
          if (o_.translational[static_cast<std::size_t>(i)])
            shift += delta * delta;
          else
            turn = std::max(turn, std::abs(std::remainder(delta, 2.0 * M_PI)));
        }
        if (std::sqrt(shift) < half_voxel && turn < kCandidateSeparationRad)
          distinct = false;
      }
      if (distinct) {
        candidates.push_back(r.x);
        ++added;
      }
    }
    return candidates;
  }

  /** Refines \a candidates on \a level with simplices of \a scale times the steps: the
   * first (the coarser level's optimum) gets the budget, the others a capped search each.
   * The level's best is its own: costs of two levels do not compare. */
  void
  searchFiner(int level, const std::vector<Eigen::VectorXd>& candidates, double scale)
  {
    have_best_ = false;
    const Eigen::VectorXd steps = scale * o_.steps;
    if (candidates.size() == 1) {
      account(search(level, {candidates[0], steps, budget_}));
      return;
    }
    // The others share the rest of the budget, so that the level keeps within it.
    const int cap = std::max(budget_ / 2, 0);
    const int others = static_cast<int>(candidates.size()) - 1;
    const int capped = std::min((budget_ - cap) / others, kGuessCandidateIterations);
    std::vector<Start> runs;
    for (std::size_t i = 0; i < candidates.size(); ++i)
      runs.push_back({candidates[i], steps, i == 0 ? cap : capped});
    const std::vector<NelderMeadResult> from = searchAll(level, runs);
    std::size_t winner = 0;
    for (std::size_t i = 0; i < from.size(); ++i) {
      account(from[i]);
      if (from[i].value < from[winner].value)
        winner = i;
    }
    if (level == o_.first_level) {
      for (std::size_t i = 0; i < from.size(); ++i)
        if (i != winner)
          result_.alternatives.push_back(from[i]);
      std::stable_sort(result_.alternatives.begin(), result_.alternatives.end(),
                       [](const NelderMeadResult& a, const NelderMeadResult& b) {
                         return a.value < b.value;
                       });
    }
    // A capped candidate that wins before its search converged is finished from where it
    // got; its result stands even where it only ties, since it carries the convergence.
    if (winner > 0 && !from[winner].converged && budget_ > 0) {
      const NelderMeadResult finished = search(level, {from[winner].x, 0.5 * steps, budget_});
      account(finished);
      if (finished.value <= result_.best.value)
        result_.best = finished;
    }
  }

  /** Restarts around the best vertex with simplices of alternating orientation. */
  void
  restart(int level, double scale)
  {
    for (int k = 0; k < o_.restarts && budget_ > 0; ++k) {
      const NelderMeadResult r =
          search(level, {result_.best.x, (k % 2 ? scale : -scale) * o_.steps, budget_});
      account(r);
      // A restart that starts inside the tolerance takes no iteration; it still costs one,
      // so that the budget ends the loop.
      budget_ -= r.iterations == 0 ? 1 : 0;
    }
  }

  /** Closes a stage with the evaluations since the previous one. */
  void
  endStage(std::string name)
  {
    clock_.end(result_.stages, std::move(name), result_.evaluations - stage_evaluations_);
    stage_evaluations_ = result_.evaluations;
  }

  std::string
  levelName(int level) const
  {
    std::ostringstream s;
    s << "search " << costs_.resolution(level) << " m";
    return s.str();
  }

  CoarseToFineResult&
  result()
  {
    return result_;
  }

private:
  LevelCosts& costs_;
  const CoarseToFineOptions& o_;
  int budget_;
  CoarseToFineResult result_;
  bool have_best_ = false;
  int stage_evaluations_ = 0;
  StageClock clock_;
};

} // namespace

CoarseToFineResult
searchCoarseToFine(LevelCosts& costs, const CoarseToFineOptions& options)
{
  Searcher searcher(costs, options);
  int level = costs.levels() - 1;
  std::vector<NelderMeadResult> start_best = searcher.searchCoarsest(level);
  searcher.endStage(searcher.levelName(level));
  std::vector<Eigen::VectorXd> candidates = searcher.candidates(level, std::move(start_best));
  // Each finer level refines with a simplex half the size of the previous level's.
  double scale = options.restart_scale;
  while (level > options.first_level) {
    --level;
    searcher.searchFiner(level, candidates, scale);
    candidates = {searcher.result().best.x};
    if (level > options.first_level)
      scale *= 0.5;
    searcher.endStage(searcher.levelName(level));
  }
  searcher.restart(level, scale);
  if (options.restarts > 0)
    searcher.endStage("restarts");
  return std::move(searcher.result());
}

NelderMeadResult
finishOnFirstLevel(LevelCosts& costs,
                   const CoarseToFineOptions& options,
                   const Eigen::VectorXd& x,
                   int max_iterations)
{
  CoarseToFineOptions capped = options;
  capped.max_iterations = max_iterations;
  Searcher searcher(costs, capped);
  // The scale the first level's candidates were searched with (searchCoarseToFine()).
  const int halvings = std::max(costs.levels() - 2 - options.first_level, 0);
  const double scale = options.restart_scale * std::ldexp(1.0, -halvings);
  return searcher.search(options.first_level, {x, 0.5 * scale * options.steps, max_iterations});
}

} // namespace core
} // namespace pcl_mi
