/*
 * pcl_mi: the engine's facade. align() reads top to bottom: check the guess, prepare the
 * problem, search coarse to fine, refine, report.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_mi/registration_core.h>

#include "engine/input_checks.h"
#include "engine/leveled_guess.h"
#include "engine/prepared_problem.h"
#include "engine/refine_optimum.h"
#include "engine/search_space.h"
#include "engine/second_optimum.h"
#include "engine/shifted_optimum.h"
#include "features/mutual_information.h"
#include "search/coarse_to_fine.h"
#include "util/stage_clock.h"
#include "verify/verification.h"
#ifdef PCL_MI_WITH_OPENCL
#include "backend/opencl_backend.h"
#endif

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <optional>
#include <sstream>

namespace pcl_mi {

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

/** The search's cost: minus the MI of the pose a search vector stands for, or minus its
 * normalised MI on \a normalized_level (-1: none). */
class MutualInformationCosts final : public core::LevelCosts {
public:
  MutualInformationCosts(core::PreparedProblem& problem,
                         const core::SearchSpace& space,
                         int normalized_level)
  : problem_(problem),
    space_(space),
    normalized_level_(normalized_level),
    prefers_batches_(problem.prefersBatches())
  {}

  int
  levels() const override
  {
    return problem_.levels();
  }

  double
  resolution(int level) const override
  {
    return problem_.levelResolution(level);
  }

  double
  cost(int level, int slot, const Eigen::VectorXd& x) override
  {
    JointHistogram& histogram = histograms_[slot];
    problem_.jointHistogram(space_.pose(x), histogram, level, slot);
    return -score(level, histogram);
  }

  void
  costs(int level, int slot, const std::vector<Eigen::VectorXd>& xs, std::vector<double>& values)
      override
  {
    if (!prefers_batches_) {
      core::LevelCosts::costs(level, slot, xs, values);
      return;
    }
    std::vector<Eigen::Matrix4d> poses;
    poses.reserve(xs.size());
    for (const Eigen::VectorXd& x : xs)
      poses.push_back(space_.pose(x));
    std::vector<JointHistogram>& histograms = batch_histograms_[slot];
    problem_.jointHistograms(poses, histograms, level, slot);
    values.resize(histograms.size());
    for (std::size_t i = 0; i < histograms.size(); ++i)
      values[i] = -score(level, histograms[i]);
  }

  bool
  prefersBatches() const override
  {
    return prefers_batches_;
  }

private:
  double
  score(int level, const JointHistogram& histogram) const
  {
    if (histogram.overlap_voxels == 0)
      return 0.0;
    return level == normalized_level_ ? core::normalizedMutualInformation(histogram)
                                      : core::mutualInformation(histogram);
  }

  core::PreparedProblem& problem_;
  const core::SearchSpace& space_;
  int normalized_level_;
  bool prefers_batches_;
  // One per slot: the two may run concurrently.
  JointHistogram histograms_[2];
  std::vector<JointHistogram> batch_histograms_[2];
};

/** Takes the trust from \a result, which passed the reliability test, where a pose a few
 * voxels along its least constrained direction scores a higher MI on the finest grid
 * (core::higherAlongLeastConstrained()). */
void
refuseASecondOptimum(core::PreparedProblem& problem, AlignmentResult& result)
{
  core::StageClock clock;
  const std::optional<Eigen::Matrix4d> higher = core::higherAlongLeastConstrained(
      problem, result.transformation, result.mutual_information, result.verification.covariance);
  clock.end(result.stages, "second optimum", core::kSecondOptimumProbes);
  if (!higher)
    return;
  const Eigen::Vector3d shift =
      higher->topRightCorner<3, 1>() - result.transformation.topRightCorner<3, 1>();
  std::ostringstream reason;
  reason << std::fixed << std::setprecision(2) << "a second optimum: the pose moved by ("
         << shift.x() << ", " << shift.y() << ", " << shift.z()
         << "), along the direction the surfaces constrain least, scores a higher MI";
  result.verification.reason = reason.str();
  result.converged = false;
}

/** Judges \a result again with \a lead, its optimum's lead over the others nearby
 * (Verification::lead). A result whose evidence passed without it has had the
 * second-optimum test, whose outcome stands while the evidence still passes; one that
 * passes only now takes that test. */
void
judgeWithLead(core::PreparedProblem& problem, double lead, AlignmentResult& result)
{
  Verification& v = result.verification;
  Verification without = v;
  core::judge(without);
  const std::string previous = v.reason;
  v.lead = lead;
  core::judge(v);
  if (!v.reason.empty()) {
    result.converged = false;
    return;
  }
  if (without.reason.empty()) {
    v.reason = previous;
    result.converged = result.search_converged && previous.empty();
    return;
  }
  result.converged = result.search_converged;
  if (result.converged)
    refuseASecondOptimum(problem, result);
}

/** Refines \a pose and gives it the verdict, into \a result (whose search_converged is
 * set). Returns the normalised MI on the finest grid at the final pose, by which candidates
 * of different overlaps compare (takeIfAgreesBetter()). */
double
finishCandidate(core::PreparedProblem& problem,
                const core::SearchSpace& space,
                const Eigen::Matrix4d& pose,
                JointHistogram& scratch,
                AlignmentResult& result)
{
  const Parameters& p = problem.parameters();
  result.transformation = pose;
  result.refinement_iterations = 0;
  result.refinement_stages = 0;
  if (p.refinement.method == Refinement::PointToDistribution) {
    core::StageClock refinement_clock;
    const int coarser_stages = problem.narrowView() ? p.refinement.narrow_view_stages : 0;
    const core::RefinedOptimum refined =
        core::refineOptimum(problem, space, result.transformation, coarser_stages);
    refinement_clock.end(result.stages, "refinement", refined.iterations);
    if (refined.accepted) {
      result.refinement_iterations = refined.iterations;
      result.refinement_stages = 1 + coarser_stages;
      result.transformation = refined.transformation;
    }
  }

  // The verdict: the search's convergence says nothing about whether the optimum is the
  // true pose; the target's surfaces do.
  core::StageClock verification_clock;
  result.mutual_information = problem.mutualInformation(result.transformation, scratch);
  const double finest_normalized_mi =
      scratch.overlap_voxels == 0 ? 0.0 : core::normalizedMutualInformation(scratch);
  const core::LocalPose at = problem.toLocal(result.transformation);
  result.verification = core::verifyPose(
      problem.distributions(), problem.refinementSamples(), at.rotation, at.translation,
      problem.levelResolution(0), scratch, problem.target().centroid, problem.targetAxes(),
      p.num_threads);
  result.converged = result.search_converged && result.verification.reason.empty();
  verification_clock.end(result.stages, "verification", 1);
  if (result.converged)
    refuseASecondOptimum(problem, result);
  return finest_normalized_mi;
}

/** Raises the roll and pitch steps of \a options to at least \a step, keeping their signs;
 * a pinned one stays pinned. */
void
widenTilt(const core::SearchSpace& space, double step, core::CoarseToFineOptions& options)
{
  for (const int parameter : {3, 4}) {
    const Eigen::Index i = space.index(parameter);
    if (i >= 0 && std::abs(options.steps[i]) < step)
      options.steps[i] = std::copysign(step, options.steps[i]);
  }
}

/** Makes the refined and verified candidate \a other, whose normalised MI on the finest grid
 * is \a other_normalized_mi, the result: its pose, verdict and refinement, not the counts and
 * stages of the whole alignment. */
void
takeCandidate(AlignmentResult&& other,
              double other_normalized_mi,
              AlignmentResult& result,
              double& finest_normalized_mi)
{
  finest_normalized_mi = other_normalized_mi;
  result.transformation = other.transformation;
  result.converged = other.converged;
  result.search_converged = other.search_converged;
  result.refinement_iterations = other.refinement_iterations;
  result.refinement_stages = other.refinement_stages;
  result.mutual_information = other.mutual_information;
  result.verification = std::move(other.verification);
}

/** Refines and verifies \a pose, whose search's convergence is \a search_converged, and
 * makes it the result where it agrees better with the target: it lies on surfaces the
 * clouds share where the result does not, or, alike in that, it has the higher normalised MI
 * on the finest grid than the result's own, \a finest_normalized_mi (then updated). With
 * \a needs_shared_surface, a candidate that shares too little surface is never taken.
 * Returns true where it was taken. */
bool
takeIfAgreesBetter(core::PreparedProblem& problem,
                   const core::SearchSpace& space,
                   const Eigen::Matrix4d& pose,
                   bool search_converged,
                   bool needs_shared_surface,
                   JointHistogram& scratch,
                   AlignmentResult& result,
                   double& finest_normalized_mi)
{
  AlignmentResult other; // its stages are the caller's stage's
  other.search_converged = search_converged;
  const double other_normalized_mi = finishCandidate(problem, space, pose, scratch, other);
  const bool supported = core::sharesSurface(other.verification);
  if (needs_shared_surface && !supported)
    return false;
  const bool better = supported != core::sharesSurface(result.verification)
                          ? supported
                          : other_normalized_mi > finest_normalized_mi;
  if (!better)
    return false;
  takeCandidate(std::move(other), other_normalized_mi, result, finest_normalized_mi);
  return true;
}

/** Refines and verifies each of \a optima (search vectors with their searches' convergence)
 * and puts the one with the highest normalised MI on the finest grid into \a result where
 * that is higher than the result's own, \a finest_normalized_mi (updated); counts them in
 * result.runners_up_checked. Normalised MI, as on the coarsest level, because the
 * candidates' overlaps differ. A candidate where the clouds share surface beats one where
 * they share too little whatever their MI: the MI of a few voxels at the edge of the
 * overlap can be high by chance, and such a pose aligns nothing. */
const core::NelderMeadResult*
keepTheFinestGridsChoice(core::PreparedProblem& problem,
                         const core::SearchSpace& space,
                         const std::vector<core::NelderMeadResult>& optima,
                         JointHistogram& scratch,
                         AlignmentResult& result,
                         double& finest_normalized_mi)
{
  const core::NelderMeadResult* kept = nullptr;
  for (const core::NelderMeadResult& optimum : optima) {
    ++result.runners_up_checked;
    if (takeIfAgreesBetter(problem, space, space.pose(optimum.x), optimum.converged, false,
                           scratch, result, finest_normalized_mi)) {
      result.runner_up_kept = true;
      kept = &optimum;
    }
  }
  return kept;
}

/** Finishes the search of the runner-up \a result holds, which stopped at \a from (its
 * search vector) at a candidate's share of the iteration cap, on at most \a left
 * iterations: from where it got,
 * as the search finishes a capped candidate that wins. The finished optimum is refined and
 * verified, and stands where it lies on surface the clouds share and the finest grid's
 * normalised MI prefers it at least as much. */
void
finishTheKeptRunnerUp(core::PreparedProblem& problem,
                      const core::SearchSpace& space,
                      MutualInformationCosts& costs,
                      const core::CoarseToFineOptions& options,
                      const Eigen::VectorXd& from,
                      int left,
                      JointHistogram& scratch,
                      AlignmentResult& result,
                      double& finest_normalized_mi)
{
  core::StageClock clock;
  const core::NelderMeadResult finished = core::finishOnFirstLevel(costs, options, from, left);
  result.iterations += finished.iterations;
  result.evaluations += finished.evaluations;
  AlignmentResult other; // its stages are this stage's
  other.search_converged = finished.converged;
  const double other_normalized_mi =
      finishCandidate(problem, space, space.pose(finished.x), scratch, other);
  if (core::sharesSurface(other.verification) && other_normalized_mi >= finest_normalized_mi)
    takeCandidate(std::move(other), other_normalized_mi, result, finest_normalized_mi);
  clock.end(result.stages, "runner-up finished", finished.evaluations);
}

/** The up direction of the target's input frame: the one its surfaces show, else z. */
Eigen::Vector3d
targetUpInInput(const core::PreparedProblem& problem)
{
  return problem.targetUp() ? Eigen::Vector3d(problem.targetAxes() * *problem.targetUp())
                            : Eigen::Vector3d::UnitZ();
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
  /** For the reverse search: align() stops after the search, with its best optimum and
   * the runners-up in search_optima. */
  bool stop_after_search = false;
  std::vector<FoundOptimum> search_optima;
  /** The reverse search's core, made on first use and kept with its backends, buffers and
   * prepared clouds; the revisions of this problem's clouds it holds (its source is this
   * target). */
  std::unique_ptr<RegistrationCore> reverse;
  std::uint64_t reverse_target_revision = 0, reverse_source_revision = 0;

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
    if (!reverse) {
      reverse = std::make_unique<RegistrationCore>();
      reverse->impl_->stop_after_search = true;
      reverse->impl_->problem.setSearchOnly(true);
    }
    Parameters reverse_parameters = parameters;
    reverse_parameters.search.reverse_search = false;
    reverse->setParameters(reverse_parameters);
    // Only a cloud that changed is handed over again, so that a reused target (a map) is not
    // prepared anew as the reverse source at every untrusted alignment. Revisions start at 1.
    if (reverse_target_revision != problem.sourceRevision()) {
      reverse->setTarget(problem.sourceInput());
      reverse_target_revision = problem.sourceRevision();
    }
    if (reverse_source_revision != problem.targetRevision()) {
      reverse->setSource(problem.targetInput());
      reverse_source_revision = problem.targetRevision();
    }
    const AlignmentResult back = reverse->align(guess.inverse(), max_iterations);
    result.reverse_search = true;
    result.iterations += back.iterations;
    result.evaluations += back.evaluations;
    if (!back.error.empty())
      reverse->impl_->search_optima.clear();
    return reverse->impl_->search_optima;
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

AlignmentResult
RegistrationCore::align(const Eigen::Matrix4d& guess, int max_iterations)
{
  AlignmentResult result;
  result.transformation = guess;
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

  // The search: rotations turn the guessed source about its centroid, or, for a narrow
  // field of view with wider tilt steps, about its sensor.
  const Parameters& p = problem.parameters();
  const core::LocalCloud& source = problem.source();
  const bool narrow_view = problem.narrowView();
  const bool tilts = narrow_view && p.search.narrow_view_tilt_step > 0.0;
  const bool about_sensor =
      tilts && source.centroid.norm() <= kSensorOriginRadii * source.rms_radius;
  const Eigen::Vector3d turned_about = about_sensor ? Eigen::Vector3d::Zero() : source.centroid;
  const Eigen::Vector3d pivot = (guess * turned_about.homogeneous()).head<3>();
  // A 360-degree pair whose up directions disagree is searched from the guess leveled, along
  // the target's up: a tilted sensor's roll and pitch are what the simplex finds least well.
  // A pair that agrees on an up far from z (a sensor mounted tilted) is searched along it too.
  const std::optional<core::Leveling> leveled =
      core::levelingApplies(p) && !narrow_view
          ? core::levelGuess(problem.sourceUp(), problem.targetUp(), guess, pivot)
          : std::nullopt;
  const core::SearchSpace space = leveled ? core::SearchSpace(p, leveled->guess, pivot, leveled->axes)
                                          : core::SearchSpace(p, guess, pivot);
  core::CoarseToFineOptions options = space.searchOptions(p);
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
    options.scan_roll = !core::guessKeepsUp(problem.sourceUp(), problem.targetUp(), guess);
  }
  // Normalised MI on the coarsest level only where finer levels follow it.
  const int coarsest = problem.levels() - 1;
  MutualInformationCosts costs(
      problem, space, p.search.coarse_normalized_mi && coarsest > options.first_level ? coarsest : -1);
  const core::CoarseToFineResult found = core::searchCoarseToFine(costs, options);
  // The first search stage also timed the overlap check at the guess.
  result.stages.insert(result.stages.end(), found.stages.begin(), found.stages.end());
  result.position_starts = options.position_starts;
  result.yaw_starts = options.yaw_index >= 0 ? static_cast<int>(options.yaw_starts.size()) : 0;
  result.scanned_starts = static_cast<int>(found.scanned_turns.size());
  result.turned_about_sensor = about_sensor;
  result.leveled = leveled.has_value();
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
      finishCandidate(problem, space, space.pose(found.best.x), impl_->scratch, result);

  // A second opinion: where the verification does not trust the search's best optimum, the
  // runners-up are refined and verified too, and the one that agrees best with the target
  // on the finest grid is kept, its capped search then finished. On sparse, narrow views the
  // coarser grids the search ranks on often put a wrong optimum first where the finest grid
  // does not (docs/method.md).
  if (!result.verification.reason.empty() && !found.alternatives.empty()) {
    core::StageClock clock;
    const core::NelderMeadResult* kept = keepTheFinestGridsChoice(
        problem, space, found.alternatives, impl_->scratch, result, finest_normalized_mi);
    clock.end(result.stages, "runners-up", result.runners_up_checked);
    const int left = max_iterations - result.iterations;
    if (kept && !result.search_converged && left > 0)
      finishTheKeptRunnerUp(problem, space, costs, options, kept->x, left, impl_->scratch, result,
                            finest_normalized_mi);
  }

  // Still not trusted, a 360-degree pair gets a wider second search: more headings, tilt
  // steps of a handheld sensor, and starts along x. A narrow view's first search is that
  // wide already.
  const int left = max_iterations - result.iterations;
  if (!result.verification.reason.empty() && !narrow_view &&
      p.search.second_search_headings > 0 && left > 0) {
    core::StageClock clock;
    core::CoarseToFineOptions wide = options;
    wide.max_iterations = left;
    if (wide.yaw_index >= 0)
      wide.heading_starts = std::max(wide.heading_starts, p.search.second_search_headings);
    widenTilt(space, kSecondSearchTiltStep, wide);
    if (wide.x_index >= 0 || wide.y_index >= 0)
      wide.position_starts = std::max(wide.position_starts, kSecondSearchPositionStarts);
    const core::CoarseToFineResult again = core::searchCoarseToFine(costs, wide);
    result.second_search = true;
    result.iterations += again.iterations;
    result.evaluations += again.evaluations;
    std::vector<core::NelderMeadResult> optima{again.best};
    optima.insert(optima.end(), again.alternatives.begin(), again.alternatives.end());
    keepTheFinestGridsChoice(problem, space, optima, impl_->scratch, result, finest_normalized_mi);
    clock.end(result.stages, "second search", again.evaluations);
  }

  // Still not trusted: the target searched onto the source. The cost samples one cloud and
  // bins the other, so the reverse is another problem, and on sparse, narrow views its
  // search often finds the pose where this one missed it (docs/benchmarks.md, "The reverse
  // search"). Its optima, inverted, are judged here as runners-up are, on shared surface only.
  const int reverse_left = max_iterations - result.iterations;
  if (!result.verification.reason.empty() && p.search.reverse_search && reverse_left > 0) {
    core::StageClock clock;
    const int evaluations_before = result.evaluations;
    Eigen::Matrix4d kept_pose;
    for (const FoundOptimum& optimum :
         impl_->reverseSearchOptima(p, guess, reverse_left, result)) {
      const Eigen::Matrix4d pose = optimum.pose.inverse(); // source onto target
      if (takeIfAgreesBetter(problem, space, pose, optimum.converged, true, impl_->scratch,
                             result, finest_normalized_mi)) {
        result.reverse_kept = true;
        kept_pose = pose;
      }
    }
    clock.end(result.stages, "reverse search", result.evaluations - evaluations_before);
    // A kept optimum whose search was capped is finished in this direction's search, as a
    // kept runner-up is, where the cap leaves room.
    const int left_after = max_iterations - result.iterations;
    if (result.reverse_kept && !result.search_converged && left_after > 0)
      finishTheKeptRunnerUp(problem, space, costs, options, space.vector(kept_pose), left_after,
                            impl_->scratch, result, finest_normalized_mi);
  }

  // A narrow view of a repeating facade: the coarser grids the search ranks on cannot tell
  // optima a bay apart, the finest grid can (docs/method.md).
  if (narrow_view) {
    core::StageClock clock;
    int evaluations = 0;
    const core::ShiftedOptima shifted = core::shiftedOptima(
        problem, result.transformation, targetUpInInput(problem), p.num_threads, evaluations);
    // Judged as a runner-up is, and on shared surface only: between two places, a shift to
    // the edge of the overlap can raise the MI of the few voxels left there.
    const std::optional<core::ShiftedOptimum>& higher = shifted.higher;
    if (higher && takeIfAgreesBetter(problem, space, higher->pose, higher->converged, true,
                                     impl_->scratch, result, finest_normalized_mi))
      result.shifted_optimum_kept = true;
    // How far the result's optimum leads the others nearby is evidence for the verdict.
    judgeWithLead(problem, result.shifted_optimum_kept ? higher->lead : shifted.lead, result);
    result.evaluations += evaluations;
    clock.end(result.stages, "shifted optima", evaluations);
  }
  return result;
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
  if (result.search_converged)
    return evidence;
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
  return evidence.empty() ? search : evidence + "; and " + search;
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
