/*
 * pcl_mi: the engine's facade. align() reads top to bottom: check the guess, prepare the
 * problem, search coarse to fine, refine, report.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_mi/registration_core.h>

#include "engine/candidates.h"
#include "engine/input_checks.h"
#include "engine/mutual_information_costs.h"
#include "engine/phase_spread.h"
#include "engine/prepared_problem.h"
#include "engine/reverse_confirmation.h"
#include "engine/search_plan.h"
#include "engine/search_space.h"
#include "engine/shifted_optimum.h"
#include "engine/steadiness.h"
#include "features/mutual_information.h"
#include "search/coarse_to_fine.h"
#include "util/stage_clock.h"
#include "verify/bound_chance.h"
#ifdef PCL_MI_WITH_OPENCL
#include "backend/opencl_backend.h"
#endif

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <sstream>

namespace pcl_mi {

namespace {

/** The up direction of the target's input frame: the one its surfaces show, else z. */
Eigen::Vector3d
targetUpInInput(const core::PreparedProblem& problem)
{
  return problem.targetUp() ? Eigen::Vector3d(problem.targetAxes() * *problem.targetUp())
                            : Eigen::Vector3d::UnitZ();
}

/** A narrow view of a repeating facade: the coarser grids the search ranks on cannot tell
 * optima a bay apart, the finest grid can (docs/method.md). Takes a higher optimum found
 * across where it agrees better, and judges the result again with its lead. */
void
lookAcross(core::PreparedProblem& problem,
           const core::SearchSpace& space,
           JointHistogram& scratch,
           AlignmentResult& result,
           double& finest_normalized_mi)
{
  core::StageClock clock;
  int evaluations = 0;
  const core::ShiftedOptima shifted =
      core::shiftedOptima(problem, result.transformation, targetUpInInput(problem),
                          problem.parameters().num_threads, evaluations);
  // Judged as a runner-up is, and on shared surface only: between two places, a shift to
  // the edge of the overlap can raise the MI of the few voxels left there.
  const std::optional<core::ShiftedOptimum>& higher = shifted.higher;
  if (higher && core::takeIfAgreesBetter(problem, space, higher->pose, higher->converged, true,
                                         scratch, result, finest_normalized_mi))
    result.shifted_optimum_kept = true;
  // How far the result's optimum leads the others nearby is evidence for the verdict.
  core::judgeWithLead(problem, result.shifted_optimum_kept ? higher->lead : shifted.lead, result);
  result.evaluations += evaluations;
  clock.end(result.stages, "shifted optima", evaluations);
}

/** A search's optimum as a pose, with whether its search converged. */
struct FoundOptimum {
  Eigen::Matrix4d pose;
  bool converged;
};

} // namespace

struct RegistrationCore::Impl {
  core::PreparedProblem problem;
  JointHistogram scratch;
  /** The last align()'s result, for covarianceScale(): its pose and covariance, the
   * preparation they were found on, and the scale once computed. */
  struct LastResult {
    Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
    Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
    std::uint64_t preparation = 0;
    Parameters parameters; // in use
    std::optional<double> covariance_scale;
  } last;

  /** Keeps \a result's pose and covariance, and what they were found on, for
   * covarianceScale(); the scale, once computed, stays. */
  void
  remember(const AlignmentResult& result)
  {
    last.pose = result.transformation;
    last.covariance = result.verification.covariance;
    last.preparation = problem.preparations();
    last.parameters = problem.parameters();
  }

  /** True where the problem still holds the cells and the parameters the last result was
   * found with: no new clouds prepared, no grid, sampling, refinement or pinned parameter
   * changed. */
  bool
  lastResultsCellsKept() const
  {
    const Parameters& now = problem.parameters();
    const Parameters& then = last.parameters;
    return last.preparation == problem.preparations() && now.grid == then.grid &&
           now.sampling == then.sampling && now.refinement == then.refinement &&
           now.search.searched() == then.search.searched();
  }
  /** For the reverse search: align() stops after the search, with its best optimum and
   * the runners-up in search_optima. */
  bool stop_after_search = false;
  std::vector<FoundOptimum> search_optima;
  /** A core of its own that aligns this problem's clouds swapped, made on first use and kept
   * with its backends, buffers and prepared clouds, and the revisions of this problem's
   * clouds it holds. */
  struct SwappedCore {
    std::unique_ptr<RegistrationCore> aligner;
    std::uint64_t target_revision = 0, source_revision = 0;

    /** The core, handed \a problem's clouds swapped (its source as the target, its target as
     * the source): only a cloud that changed since the last call, so that a reused target (a
     * map) is not prepared anew at every alignment. Revisions start at 1. */
    RegistrationCore&
    holding(const core::PreparedProblem& problem)
    {
      if (target_revision != problem.sourceRevision()) {
        aligner->setTargetView(problem.sourceInput());
        target_revision = problem.sourceRevision();
      }
      if (source_revision != problem.targetRevision()) {
        aligner->setSourceView(problem.targetInput());
        source_revision = problem.targetRevision();
      }
      return *aligner;
    }
  };

  /** The reverse search's core. */
  SwappedCore reverse;

  /** Searches the target onto the source from the inverse of \a guess, with \a parameters
   * (those in use, so that the source's extent derives nothing) on at most
   * \a max_iterations, and returns that search's optima (source-to-target poses of the
   * reverse problem, best first), empty where it failed; adds its counts to \a result. */
  const std::vector<FoundOptimum>&
  reverseSearchOptima(const Parameters& parameters,
                      const Eigen::Matrix4d& guess,
                      int max_iterations,
                      AlignmentResult& result)
  {
    if (!reverse.aligner) {
      reverse.aligner = std::make_unique<RegistrationCore>();
      reverse.aligner->impl_->stop_after_search = true;
      reverse.aligner->impl_->problem.setSearchOnly(true);
    }
    Parameters reverse_parameters = parameters;
    reverse_parameters.search.reverse_search = false;
    reverse.aligner->setParameters(reverse_parameters);
    RegistrationCore& searched = reverse.holding(problem);
    const AlignmentResult back = searched.align(guess.inverse(), max_iterations);
    result.reverse_search = true;
    result.iterations += back.iterations;
    result.evaluations += back.evaluations;
    if (!back.error.empty())
      searched.impl_->search_optima.clear();
    return searched.impl_->search_optima;
  }

  /** The target searched onto the source, on what the cap (\a max_iterations) leaves. The
   * cost samples one cloud and bins the other, so the reverse is another problem, and on
   * sparse, narrow views its search often finds the pose where this one missed it
   * (docs/benchmarks.md, "The reverse search"). Its optima, inverted, are judged as
   * runners-up are, on shared surface only; a kept one whose search was capped is finished
   * in this direction's search (\a costs, \a options), as a kept runner-up is. */
  void
  judgeTheReverseOptima(const core::SearchSpace& space,
                        core::LevelCosts& costs,
                        const core::CoarseToFineOptions& options,
                        const Eigen::Matrix4d& guess,
                        int max_iterations,
                        AlignmentResult& result,
                        double& finest_normalized_mi)
  {
    const int left = max_iterations - result.iterations;
    if (left <= 0)
      return;
    core::StageClock clock;
    const int evaluations_before = result.evaluations;
    Eigen::Matrix4d kept_pose;
    for (const FoundOptimum& optimum :
         reverseSearchOptima(problem.parameters(), guess, left, result)) {
      const Eigen::Matrix4d pose = optimum.pose.inverse(); // source onto target
      if (core::takeIfAgreesBetter(problem, space, pose, optimum.converged, true, scratch, result,
                                   finest_normalized_mi)) {
        result.reverse_kept = true;
        kept_pose = pose;
      }
    }
    clock.end(result.stages, "reverse search", result.evaluations - evaluations_before);
    if (result.reverse_kept)
      core::finishTheKeptRunnerUp(problem, space, costs, options, space.vector(kept_pose),
                                  max_iterations, scratch, result, finest_normalized_mi);
  }

  /** The alignment of the clouds swapped, a core of its own with the parameters as set, which
   * confirms none itself; made on first use and kept with its prepared clouds. */
  bool confirming = false;
  SwappedCore confirmation;
  /** In that core: the result it is asked about, inverted (a pose of its own problem). */
  std::optional<Eigen::Matrix4d> asked_about;

  /** In the confirming core: where its own search met its tolerances and ended apart from
   * the result it is asked about (\a result), weighs that result too, refined and judged as
   * a runner-up is, on shared surface only. The search may have settled in another optimum
   * than the pose the other side found, as the reverse search often finds one this side
   * missed; the finest grid's normalised MI, not the search, then says which of the two this
   * side prefers. A capped search ended where the cap stopped it, which says nothing
   * (docs/method.md, step 6). */
  void
  weighTheResultAskedAbout(const core::SearchSpace& space,
                           AlignmentResult& result,
                           double& finest_normalized_mi)
  {
    if (!result.search_converged ||
        core::endsTogether(result.transformation, *asked_about,
                           problem.parameters().units_per_metre))
      return;
    core::StageClock clock;
    core::takeIfAgreesBetter(problem, space, *asked_about, result.search_converged, true, scratch,
                             result, finest_normalized_mi);
    clock.end(result.stages, "result asked about", 1);
  }

  /** Aligns the target onto the source from the inverse of \a guess, with the parameters
   * as set (\a requested) under a cap of its own (\a max_iterations: what this alignment's
   * searches left is often too little), and lets that alignment confirm \a result
   * (confirmWithTheReverse()). Its evaluations count in its stage, not in \a result's
   * iterations and evaluations, which stay within the cap. A sparse or narrow view's verdict
   * often holds back a right result that the other direction finds again, while two wrong
   * results rarely meet (docs/benchmarks.md, "Confirmed by the clouds swapped"). */
  void
  confirmWithTheCloudsSwapped(const Parameters& requested,
                              const Eigen::Matrix4d& guess,
                              int max_iterations,
                              AlignmentResult& result)
  {
    core::StageClock clock;
    if (!confirmation.aligner) {
      confirmation.aligner = std::make_unique<RegistrationCore>();
      confirmation.aligner->impl_->confirming = true;
    }
    confirmation.aligner->setParameters(requested);
    confirmation.aligner->impl_->asked_about = result.transformation.inverse();
    const AlignmentResult back =
        confirmation.holding(problem).align(guess.inverse(), max_iterations);
    confirmation.aligner->impl_->asked_about.reset();
    core::confirmWithTheReverse(back, requested.units_per_metre, result);
    clock.end(result.stages, "reverse confirmation", back.evaluations);
  }
};

RegistrationCore::RegistrationCore() : impl_(std::make_unique<Impl>()) {}
RegistrationCore::~RegistrationCore() = default;
RegistrationCore::RegistrationCore(RegistrationCore&&) noexcept = default;
RegistrationCore&
RegistrationCore::operator=(RegistrationCore&&) noexcept = default;

std::string
RegistrationCore::setParameters(const Parameters& parameters)
{
  std::string error = parameters.validate();
  if (error.empty())
    impl_->problem.setParameters(parameters);
  return error;
}

const Parameters&
RegistrationCore::parameters() const
{
  return impl_->problem.requestedParameters();
}

const Parameters&
RegistrationCore::effectiveParameters() const
{
  return impl_->problem.parameters();
}

void
RegistrationCore::setTarget(PointList points)
{
  impl_->problem.setTarget(std::move(points));
}

void
RegistrationCore::setSource(PointList points)
{
  impl_->problem.setSource(std::move(points));
}

void
RegistrationCore::setTargetView(PointView points)
{
  impl_->problem.setTargetView(std::move(points));
}

void
RegistrationCore::setSourceView(PointView points)
{
  impl_->problem.setSourceView(std::move(points));
}

AlignmentResult
RegistrationCore::align(const Eigen::Matrix4d& guess, int max_iterations)
{
  AlignmentResult result;
  result.transformation = guess;
  impl_->last = {};
  const std::string guess_error = core::rigidTransformError(guess);
  if (!guess_error.empty()) {
    result.error = "the initial guess " + guess_error;
    return result;
  }
  result.error = maxIterationsError(max_iterations);
  if (!result.error.empty())
    return result;

  core::PreparedProblem& problem = impl_->problem;
  core::StageClock clock;
  if (!problem.prepare(result.error))
    return result;
  result.warnings = problem.warnings();
  clock.end(result.stages, "prepare", 1);
  if (problem.mutualInformation(guess, impl_->scratch) <= 0.0 &&
      impl_->scratch.overlap_voxels == 0) {
    result.error = "the bounding boxes of source and target do not overlap at the initial "
                   "guess";
    return result;
  }

  const Parameters& p = problem.parameters();
  const bool narrow_view = problem.narrowView();
  const core::SearchPlan plan = core::planSearch(problem, guess, max_iterations);
  const core::SearchSpace& space = plan.space;
  const core::CoarseToFineOptions& options = plan.options;
  // Normalised MI on the coarsest level only where finer levels follow it.
  const int coarsest = problem.levels() - 1;
  core::MutualInformationCosts costs(
      problem, space,
      p.search.coarse_normalized_mi && coarsest > options.first_level ? coarsest : -1);
  const core::CoarseToFineResult found = core::searchCoarseToFine(costs, options);
  // The first search stage also timed the overlap check at the guess.
  result.stages.insert(result.stages.end(), found.stages.begin(), found.stages.end());
  result.position_starts = options.position_starts;
  result.yaw_starts = options.yaw_index >= 0 ? static_cast<int>(options.yaw_starts.size()) : 0;
  result.scanned_starts = static_cast<int>(found.scanned_turns.size());
  result.turned_about_sensor = plan.about_sensor;
  result.leveled = plan.leveled;
  result.iterations = found.iterations;
  result.evaluations = found.evaluations;
  result.search_converged = found.best.converged;
  if (impl_->stop_after_search) {
    impl_->search_optima.clear();
    impl_->search_optima.push_back({space.pose(found.best.x), found.best.converged});
    for (const core::NelderMeadResult& optimum : found.alternatives)
      impl_->search_optima.push_back({space.pose(optimum.x), optimum.converged});
    return result;
  }
  double finest_normalized_mi =
      core::finishCandidate(problem, space, space.pose(found.best.x), impl_->scratch, result);

  // Second opinions, each only while the result is not trusted and the cap leaves room.
  // First the search's runners-up: on sparse, narrow views the coarser grids the search ranks
  // on often put a wrong optimum first where the finest grid does not (docs/method.md).
  if (!result.verification.reason.empty() && !found.alternatives.empty()) {
    core::StageClock clock;
    const core::NelderMeadResult* kept = core::keepTheFinestGridsChoice(
        problem, space, found.alternatives, impl_->scratch, result, finest_normalized_mi);
    clock.end(result.stages, "runners-up", result.runners_up_checked);
    if (kept)
      core::finishTheKeptRunnerUp(problem, space, costs, options, kept->x, max_iterations,
                                  impl_->scratch, result, finest_normalized_mi);
  }
  // A narrow view's first search is as wide as the second one already.
  if (!result.verification.reason.empty() && !narrow_view && p.search.second_search_headings > 0)
    core::searchWider(problem, space, costs, options, max_iterations, impl_->scratch, result,
                      finest_normalized_mi);
  if (!result.verification.reason.empty() && p.search.reverse_search)
    impl_->judgeTheReverseOptima(space, costs, options, guess, max_iterations, result,
                                 finest_normalized_mi);
  if (impl_->asked_about)
    impl_->weighTheResultAskedAbout(space, result, finest_normalized_mi);
  if (narrow_view)
    lookAcross(problem, space, impl_->scratch, result, finest_normalized_mi);
  core::judgeSteadiness(problem, space, result);
  impl_->remember(result);
  // A result that passed its own tests on sparse evidence asks its covariance first, as
  // getCovariance() widens it; held back there, it is asked of the clouds swapped as any
  // held-back result is, whose agreement measures its spread (docs/method.md, step 7).
  bool held_for_spread = false;
  if (!impl_->confirming && core::spreadMatters(result)) {
    core::StageClock clock;
    core::weighTheSpread(covarianceScale(), p.units_per_metre, result);
    clock.end(result.stages, "sparse spread", 1);
    held_for_spread = !result.converged;
  }
  if (!impl_->confirming && (held_for_spread || core::mayBeConfirmed(result))) {
    impl_->confirmWithTheCloudsSwapped(problem.requestedParameters(), guess, max_iterations,
                                       result);
    impl_->remember(result); // with the covariance the clouds swapped may have supplied
  }
  return result;
}

double
RegistrationCore::covarianceScale() const
{
  Impl::LastResult& last = impl_->last;
  if (!last.covariance_scale)
    last.covariance_scale =
        impl_->lastResultsCellsKept()
            ? core::phaseSpreadScale(impl_->problem, last.pose, last.covariance)
            : 1.0;
  return *last.covariance_scale;
}

double
RegistrationCore::evaluate(const Eigen::Matrix4d& pose, std::string* error)
{
  std::string why;
  if (!impl_->problem.prepare(why)) {
    if (error)
      *error = why;
    return -1.0;
  }
  return impl_->problem.mutualInformation(pose, impl_->scratch);
}

bool
RegistrationCore::jointHistogram(const Eigen::Matrix4d& pose,
                                 JointHistogram& histogram,
                                 std::string* error)
{
  std::string why;
  if (!impl_->problem.prepare(why)) {
    if (error)
      *error = why;
    return false;
  }
  impl_->problem.mutualInformation(pose, histogram);
  return true;
}

std::vector<StageTiming>
RegistrationCore::backendProfile() const
{
  return impl_->problem.backendProfile();
}

void
RegistrationCore::resetBackendProfile()
{
  impl_->problem.resetBackendProfile();
}

const std::string&
RegistrationCore::backendName() const
{
  return impl_->problem.backends().name();
}

const std::string&
RegistrationCore::backendWarning() const
{
  return impl_->problem.backends().warning();
}

std::size_t
RegistrationCore::droppedTargetPoints() const
{
  const core::LocalCloud& c = impl_->problem.target();
  return c.non_finite + c.no_return + c.outliers;
}

std::size_t
RegistrationCore::droppedSourcePoints() const
{
  const core::LocalCloud& c = impl_->problem.source();
  return c.non_finite + c.no_return + c.outliers;
}

std::string
notConvergedCause(const AlignmentResult& result, int max_iterations, const std::string& cap_name)
{
  if (result.converged)
    return {};
  const std::string& evidence = result.verification.reason;
  const std::string& unconfirmed = result.verification.reverse_reason;
  const std::string swapped =
      unconfirmed.empty()
          ? std::string()
          : "; the alignment of the clouds swapped does not confirm it: " + unconfirmed;
  if (result.search_converged)
    return evidence + swapped;
  const std::string cap = "(" + cap_name + ")";
  const std::string search =
      result.reverse_kept
          ? "the result is an optimum of the reverse search (the target searched onto the "
            "source), kept because the finest grid prefers it to an untrusted one; that search "
            "stopped at its share of what the iteration cap " +
                cap +
                " left before the simplex met its tolerances, and finishing it, where the cap "
                "left room, gave no optimum the finest grid prefers as much"
      : result.runner_up_kept
          ? "the result is a runner-up of the search, kept because the finest grid prefers it "
            "to an untrusted best; its search was capped at a candidate's share of the "
            "iteration cap " +
                cap +
                " before the simplex met its tolerances, and finishing it, where the cap left "
                "room, gave no optimum the finest grid prefers as much"
          : (result.iterations >= max_iterations
                 ? "the iteration cap " + cap + " ended the search"
                 : "the best search stopped at its share of the iteration cap " + cap) +
                " before the simplex met its tolerances";
  // What the scene says first: more iterations would not change it.
  return (evidence.empty() ? search : evidence + "; and " + search) + swapped;
}

bool
openClAvailable(std::string* reason)
{
#ifdef PCL_MI_WITH_OPENCL
  std::string why;
  const bool ok = backend::openClDevice(-1, -1, why) != nullptr;
  if (reason)
    *reason = ok ? std::string() : why;
  return ok;
#else
  if (reason)
    *reason = "built without the OpenCL backend";
  return false;
#endif
}

} // namespace pcl_mi
