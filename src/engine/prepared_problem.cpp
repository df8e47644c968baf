/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/prepared_problem.h"

#include "engine/derived_defaults.h"
#include "engine/input_checks.h"
#include "engine/leveled_guess.h"
#include "features/mutual_information.h"
#include "features/up_direction.h"
#include "util/parallel.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <tuple>

namespace pcl_mi {
namespace core {

namespace {

/** Fewest points a target cube needs to give the refinement a distribution: enough for a
 * plane of its own. */
constexpr int kRefinementMinimumPoints = 4;
/** The same in a sparse target (kSparseTargetShare), on the finest refinement cubes; such
 * a cube is mostly a strip (two points always are), which takes its surface from its
 * neighbours where those hold one (TargetDistributions). A scan of a few thousand points
 * leaves most of its small cubes with fewer than four, and without them the samples there
 * find no surface (docs/benchmarks.md, "Sparse cubes"). The coarser stages of a narrow
 * view keep kRefinementMinimumPoints: in their larger cubes two or three points are stray
 * returns, whose wide pull moved results onto the wrong stretch of a repeated facade. */
constexpr int kSparseRefinementMinimumPoints = 2;
/** Share of the target's points in cubes of fewer than kRefinementMinimumPoints from which
 * the target counts as sparse: 3-13 % in the shared KITTI, Seosan and PCL room scans, where
 * the sparse cubes are stray far returns that cost time and add no accuracy; about 40-80 %
 * in the shared Livox and Riverside scans. */
constexpr double kSparseTargetShare = 0.25;
/** Noise (standard deviation) added to the refinement's target covariances, as a fraction
 * of the MI resolution: about the range noise of a spinning LiDAR at 1 m voxels. */
constexpr double kRefinementNoiseFraction = 0.05;

/** Share of a cloud's usable points whose loss as far outliers is worth a warning: a few
 * stray returns are what the rule is for, a second site is not. */
constexpr double kOutlierWarningShare = 0.01;

std::string
describeTooFew(const char* which, const LocalCloud& cloud)
{
  std::ostringstream s;
  s << "the " << which << " has " << cloud.points.size() << " usable points ("
    << cloud.non_finite << " non-finite, " << cloud.no_return << " at (0, 0, 0) and "
    << cloud.outliers << " far outliers dropped); at least " << kMinimumPoints
    << " are needed";
  return s.str();
}

/** A warning when far outliers took more than kOutlierWarningShare of a cloud's usable
 * points; empty otherwise. */
std::string
describeOutliers(const char* which, const LocalCloud& cloud, double gap)
{
  const std::size_t usable = cloud.points.size() + cloud.outliers;
  if (static_cast<double>(cloud.outliers) <= kOutlierWarningShare * static_cast<double>(usable))
    return {};
  std::ostringstream s;
  s << "dropped " << cloud.outliers << " of the " << which << "'s " << usable
    << " usable points as far outliers: an empty gap of " << gap
    << " (64 voxels) or more parts them from its largest group of points along x, y or z";
  return s.str();
}

/** kSparseRefinementMinimumPoints where the target is sparse (kSparseTargetShare of its
 * points in \a cubes of fewer than kRefinementMinimumPoints), else kRefinementMinimumPoints. */
int
finestRefinementMinimumPoints(const SourceSamples& cubes)
{
  std::size_t sparse = 0, all = 0;
  for (const SourceSample& c : cubes.samples) {
    all += c.count;
    if (c.count < static_cast<std::uint32_t>(kRefinementMinimumPoints))
      sparse += c.count;
  }
  return static_cast<double>(sparse) >= kSparseTargetShare * static_cast<double>(all)
             ? kSparseRefinementMinimumPoints
             : kRefinementMinimumPoints;
}

} // namespace

void
PreparedProblem::setParameters(const Parameters& p)
{
  const bool derive = p.grid.resolution == 0.0;
  if (derive && requested_.grid.resolution != 0.0 && has_target_)
    derived_resolution_ = deriveResolution(target_input_);
  requested_ = p;
  resolveParameters();
}

void
PreparedProblem::resolveParameters()
{
  // A target with no extent gets a placeholder resolution: prepare()'s checks then say what
  // is wrong with it (no usable points, all at one position). Without a target it stays 0.
  const double derived = derived_resolution_ > 0.0 || !has_target_ ? derived_resolution_ : 1.0;
  const Parameters p = core::resolveParameters(requested_, derived);
  const Parameters& old = parameters_;
  // What each group feeds: the grid everything, the sampling the source's samples, the
  // refinement the target's distributions, the backend the target's backends (and
  // Backend::Auto's choice depends on the sampling).
  const bool grid = old.grid != p.grid;
  const bool sampling = old.sampling != p.sampling;
  const bool backend = old.backend != p.backend ||
                       (p.backend.type == Backend::Auto && sampling);
  target_dirty_ = target_dirty_ || grid || old.refinement != p.refinement || backend ||
                  levelingApplies(old) != levelingApplies(p);
  source_dirty_ = source_dirty_ || grid || sampling;
  parameters_ = p;
}

void
PreparedProblem::setTargetView(PointView points)
{
  target_input_ = std::move(points);
  has_target_ = true;
  ++target_revision_;
  target_dirty_ = true;
  if (requested_.grid.resolution == 0.0) {
    derived_resolution_ = deriveResolution(target_input_);
    resolveParameters(); // a new resolution also makes the source's samples stale
  }
}

void
PreparedProblem::setSourceView(PointView points)
{
  source_input_ = std::move(points);
  has_source_ = true;
  ++source_revision_;
  source_dirty_ = true;
}

bool
PreparedProblem::prepare(std::string& error)
{
  if (!has_target_) {
    error = "no target cloud was given";
    return false;
  }
  if (!has_source_) {
    error = "no source cloud was given";
    return false;
  }
  const bool new_target = target_dirty_;
  const bool new_source = source_dirty_;
  if (!new_target && !new_source)
    return true;
  if (new_target && !backends_.choose(parameters_.backend, parameters_.sampling, error))
    return false;
  if (!prepareLocalClouds(new_target, new_source, error))
    return false;
  if (new_target) {
    // Refuse a too-fine resolution up front: no coarser level needs more voxels.
    GridGeometry finest;
    if (!makeGridGeometry(target_.points, parameters_.grid.resolution, finest, error,
                          &target_.box)) {
      // A derived resolution is the engine's choice, so it coarsens where the points that
      // survive the outlier rule do not fit; each doubling shrinks the grid eightfold.
      if (requested_.grid.resolution != 0.0 || derived_resolution_ <= 0.0)
        return false;
      error.clear();
      derived_resolution_ *= 2.0;
      resolveParameters();
      return prepare(error);
    }
  }
  buildFromLocalClouds(new_target, new_source);
  target_dirty_ = false;
  source_dirty_ = false;
  ++preparations_;
  return true;
}

bool
PreparedProblem::prepareLocalClouds(bool new_target, bool new_source, std::string& error)
{
  // Only the changed clouds are tasks; a new source alone reads its points on the threads
  // itself. A resolution too fine for a cloud is named as such before the outlier gap,
  // which follows it, would split the cloud into fragments.
  const double resolution = parameters_.grid.resolution;
  const double gap = kOutlierGapVoxels * resolution;
  const int alone = new_target != new_source ? parameters_.num_threads : 1;
  std::string target_error, source_error;
  const auto localCloud = [&](const PointView& input, const char* which, LocalCloud& cloud,
                              std::string& why) {
    why = resolutionError(input, resolution, which);
    if (why.empty())
      makeLocalCloud(input, gap, alone, cloud);
  };
  std::vector<std::function<void()>> local_tasks;
  if (new_target)
    local_tasks.emplace_back(
        [&] { localCloud(target_input_, "target", target_, target_error); });
  if (new_source)
    local_tasks.emplace_back(
        [&] { localCloud(source_input_, "source", source_, source_error); });
  parallelFor(static_cast<int>(local_tasks.size()), parameters_.num_threads,
              [&](int task) { local_tasks[static_cast<std::size_t>(task)](); });
  error = target_error.empty() ? source_error : target_error;
  if (!error.empty())
    return false;
  if (target_.points.size() < kMinimumPoints) {
    error = describeTooFew("target", target_);
    return false;
  }
  if (source_.points.size() < kMinimumPoints) {
    error = describeTooFew("source", source_);
    return false;
  }
  // An unchanged cloud passed at this resolution already (a new resolution marks both).
  if (new_target)
    error = structureError(target_, resolution, "target");
  if (error.empty() && new_source)
    error = structureError(source_, resolution, "source");
  if (!error.empty())
    return false;
  if (new_target)
    target_warning_ = describeOutliers("target", target_, gap);
  if (new_source)
    source_warning_ = describeOutliers("source", source_, gap);
  return true;
}

void
PreparedProblem::buildFromLocalClouds(bool new_target, bool new_source)
{
  if (new_target) {
    levels_.clear();
    levels_.resize(static_cast<std::size_t>(parameters_.grid.pyramid_levels));
    distributions_.reset();
    coarser_distributions_.clear();
    shifted_distributions_.reset();
    target_axes_.setIdentity();
  }
  // Longest first: a free thread takes the next task. A new source alone (a scan against a
  // kept map) is the only task, and splits its summaries over the threads instead.
  std::vector<std::function<void()>> tasks;
  if (new_source)
    tasks.emplace_back([this, threads = new_target ? 1 : parameters_.num_threads] {
      buildSourceSamples(threads);
    });
  if (new_target)
    appendTargetTasks(tasks, true);
  parallelFor(static_cast<int>(tasks.size()), parameters_.num_threads,
              [&](int task) { tasks[static_cast<std::size_t>(task)](); });
  if (new_target)
    levelTarget();
  // New levels need the samples; new samples need handing to the existing backends.
  for (std::size_t l = 0; l < levels_.size(); ++l) {
    Level& level = levels_[l];
    level.samples = source_levels_[l];
    for (auto& slot : level.slots)
      if (slot)
        slot->setSource(level.samples);
  }
}

double
PreparedProblem::levelResolution(int level) const
{
  // The source's samples and the target's levels are built concurrently: both take the
  // sizes from here.
  return parameters_.grid.resolution * std::ldexp(1.0, level);
}

int
PreparedProblem::firstSearchedLevel() const
{
  return parameters_.refinement.method != Refinement::None &&
                 parameters_.grid.pyramid_levels > 1
             ? 1
             : 0;
}

backend::ScoringBackend&
PreparedProblem::backend(int level, int slot)
{
  Level& l = levels_[static_cast<std::size_t>(level)];
  std::unique_ptr<backend::ScoringBackend>& b = l.slots[slot];
  if (!b) {
    b = backends_.make();
    b->setTarget(l.grid);
    b->setSource(l.samples);
  }
  return *b;
}

LocalPose
PreparedProblem::toLocal(const Eigen::Matrix4d& pose) const
{
  // target_local = A^T (R * source_local + R c_s + t - c_t), A the target's axes.
  LocalPose local;
  local.rotation = pose.topLeftCorner<3, 3>();
  local.translation =
      local.rotation * source_.centroid + pose.topRightCorner<3, 1>() - target_.centroid;
  if (!target_axes_.isIdentity(0.0)) {
    local.rotation = target_axes_.transpose() * local.rotation;
    local.translation = target_axes_.transpose() * local.translation;
  }
  return local;
}

Eigen::Matrix4d
PreparedProblem::fromLocal(const LocalPose& local) const
{
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  pose.topLeftCorner<3, 3>() = target_axes_ * local.rotation;
  pose.topRightCorner<3, 1>() = target_axes_ * local.translation -
                                pose.topLeftCorner<3, 3>() * source_.centroid + target_.centroid;
  return pose;
}

void
PreparedProblem::jointHistogram(const Eigen::Matrix4d& pose,
                                JointHistogram& histogram,
                                int level,
                                int slot)
{
  const LocalPose local = toLocal(pose);
  if (!local.rotation.allFinite() || !local.translation.allFinite()) {
    histogram.overlap_voxels = 0;
    return;
  }
  backend(level, slot)
      .jointHistogram(local.rotation.cast<float>(), local.translation.cast<float>(), histogram);
}

double
PreparedProblem::mutualInformation(const Eigen::Matrix4d& pose,
                                   JointHistogram& histogram,
                                   int level,
                                   int slot)
{
  jointHistogram(pose, histogram, level, slot);
  return histogram.overlap_voxels == 0 ? 0.0 : core::mutualInformation(histogram);
}

void
PreparedProblem::jointHistograms(const std::vector<Eigen::Matrix4d>& poses,
                                 std::vector<JointHistogram>& histograms,
                                 int level,
                                 int slot)
{
  // Poses that do not map to finite local ones get no overlap without reaching the backend.
  std::vector<Eigen::Matrix3f> rotations;
  std::vector<Eigen::Vector3f> translations;
  std::vector<std::size_t> scored;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const LocalPose local = toLocal(poses[i]);
    if (!local.rotation.allFinite() || !local.translation.allFinite())
      continue;
    rotations.push_back(local.rotation.cast<float>());
    translations.push_back(local.translation.cast<float>());
    scored.push_back(i);
  }
  std::vector<JointHistogram> computed;
  backend(level, slot).jointHistograms(rotations, translations, computed);
  histograms.resize(poses.size());
  for (JointHistogram& h : histograms)
    h.overlap_voxels = 0;
  for (std::size_t k = 0; k < scored.size(); ++k)
    histograms[scored[k]] = std::move(computed[k]);
}

bool
PreparedProblem::prefersBatches()
{
  return !levels_.empty() && backend(levels() - 1, 0).prefersBatches();
}

std::vector<std::string>
PreparedProblem::warnings() const
{
  std::vector<std::string> warnings;
  for (const std::string* warning : {&target_warning_, &source_warning_})
    if (!warning->empty())
      warnings.push_back(*warning);
  return warnings;
}

std::vector<StageTiming>
PreparedProblem::backendProfile() const
{
  std::vector<StageTiming> stages;
  for (const Level& level : levels_)
    for (const auto& slot : level.slots)
      if (slot)
        slot->appendProfile(stages);
  return stages;
}

void
PreparedProblem::resetBackendProfile()
{
  for (Level& level : levels_)
    for (auto& slot : level.slots)
      if (slot)
        slot->resetProfile();
}

void
PreparedProblem::appendTargetTasks(std::vector<std::function<void()>>& tasks, bool estimate_up)
{
  // The distributions also serve the verification, which runs with or without a refinement.
  // A search-only problem builds their cubes for the up direction alone.
  if (!search_only_ || estimate_up)
    tasks.emplace_back([this, estimate_up] {
      const SourceSamples cubes =
          makeSourceSamples(target_.points, parameters_.effectiveRefinementResolution(),
                            &target_.box);
      const int min_points = finestRefinementMinimumPoints(cubes);
      // The distributions decompose every cube the up direction looks at: it takes their
      // principal axes instead of decomposing them again.
      UpDirectionFromAxes up(cubes);
      const bool shared = estimate_up && !search_only_ &&
                          static_cast<std::uint32_t>(min_points) <= kUpMinimumCellPoints;
      TargetDistributions::AxesVisitor on_axes;
      if (shared)
        on_axes = [&up](std::size_t i, const auto& axes) { up.look(i, axes); };
      if (!search_only_)
        distributions_ = makeDistributions(cubes, min_points, on_axes);
      if (estimate_up)
        target_up_ = shared ? up.estimate() : estimateUpDirection(cubes);
    });
  for (int l = 0; l < static_cast<int>(levels_.size()); ++l)
    tasks.emplace_back([this, l] { buildGrid(l); });
}

const TargetDistributions&
PreparedProblem::distributions(int stage)
{
  if (stage == 0)
    return *distributions_;
  const std::size_t i = static_cast<std::size_t>(stage - 1);
  if (coarser_distributions_.size() <= i)
    coarser_distributions_.resize(i + 1);
  if (!coarser_distributions_[i])
    coarser_distributions_[i] = makeDistributions(
        makeSourceSamples(target_.points,
                          std::ldexp(parameters_.effectiveRefinementResolution(), stage),
                          &target_.box),
        kRefinementMinimumPoints);
  return *coarser_distributions_[i];
}

namespace {

/** \a box with its lower corner moved by half of \a cell along every axis: cells of that
 * size from there cut the points half a cell further on. */
Box
halfCellShifted(Box box, double cell)
{
  box.min -= Eigen::Vector3f::Constant(static_cast<float>(0.5 * cell));
  return box;
}

} // namespace

const TargetDistributions&
PreparedProblem::shiftedDistributions()
{
  if (!shifted_distributions_) {
    const double cell = parameters_.effectiveRefinementResolution();
    const Box box = halfCellShifted(target_.box, cell);
    const SourceSamples cubes = makeSourceSamples(target_.points, cell, &box);
    shifted_distributions_ = makeDistributions(cubes, finestRefinementMinimumPoints(cubes));
  }
  return *shifted_distributions_;
}

SourceSamples
PreparedProblem::shiftedRefinementSamples() const
{
  const SourceSamples& samples = refinementSamples();
  if (!(samples.cell_size > 0.0))
    return samples;
  const Box box = halfCellShifted(source_.box, samples.cell_size);
  return makeSourceSamples(source_.points, samples.cell_size, &box);
}

std::unique_ptr<TargetDistributions>
PreparedProblem::makeDistributions(const SourceSamples& cubes,
                                   int min_points,
                                   const TargetDistributions::AxesVisitor& on_axes) const
{
  return std::make_unique<TargetDistributions>(
      cubes, min_points, kRefinementNoiseFraction * parameters_.grid.resolution, on_axes);
}

bool
PreparedProblem::narrowView() const
{
  return std::min(target_.azimuth_coverage_deg, source_.azimuth_coverage_deg) <
         kNarrowViewDegrees;
}

void
PreparedProblem::levelTarget()
{
  if (!levelingApplies(parameters_) || !target_up_ ||
      target_.azimuth_coverage_deg < kNarrowViewDegrees ||
      !apartBeyondLeveling(*target_up_, Eigen::Vector3d::UnitZ()))
    return;
  const Eigen::Matrix3d axes = levelAxes(*target_up_);
  PointList turned(target_.points.size());
  const Eigen::Matrix3f to_local = axes.transpose().cast<float>();
  for (std::size_t i = 0; i < turned.size(); ++i)
    turned[i] = to_local * target_.points[i];
  const Box turned_box = boundingBox(turned);
  GridGeometry finest;
  std::string error;
  if (!makeGridGeometry(turned, parameters_.grid.resolution, finest, error, &turned_box))
    return;
  target_.points = std::move(turned);
  target_.box = turned_box;
  target_axes_ = axes;
  // Up, in the input frame, stays as estimated there.
  std::vector<std::function<void()>> tasks;
  appendTargetTasks(tasks, false);
  parallelFor(static_cast<int>(tasks.size()), parameters_.num_threads,
              [&](int task) { tasks[static_cast<std::size_t>(task)](); });
}

void
PreparedProblem::buildGrid(int level)
{
  const double resolution = levelResolution(level);
  auto grid = std::make_shared<TargetGrid>();
  std::string error;
  // prepare() has ruled out every reason this could fail.
  if (!buildTargetGrid(target_.points, resolution, parameters_.grid.feature,
                       levelBinning(resolution), *grid, error, &target_.box))
    throw std::runtime_error(error);
  levels_[static_cast<std::size_t>(level)].grid = std::move(grid);
}

FeatureBinning
PreparedProblem::levelBinning(double level_resolution) const
{
  // Point counts grow with the voxel's surface area, so the PointCount range scales with
  // the square of the resolution ratio; VarianceZ is already normalised by the resolution.
  FeatureBinning b = parameters_.grid.binning();
  if (parameters_.grid.feature == Feature::PointCount) {
    const double ratio = level_resolution / parameters_.grid.resolution;
    b.max_value *= ratio * ratio;
  }
  return b;
}

void
PreparedProblem::buildSourceSamples(int threads)
{
  using SamplesPtr = std::shared_ptr<const SourceSamples>;
  const int num_levels = parameters_.grid.pyramid_levels;
  const int subdivision = parameters_.sampling.source_subdivision;
  std::vector<double> cells(static_cast<std::size_t>(num_levels), 0.0); // 0: every point
  std::vector<double> needed;
  if (subdivision > 0)
    for (int l = 0; l < num_levels; ++l)
      needed.push_back(cells[static_cast<std::size_t>(l)] = levelResolution(l) / subdivision);

  // When every cell size is the smallest one times a power of two (the usual case), one
  // sort of the points serves them all: the coarser samples merge the finer.
  const double base = needed.empty() ? 0.0 : *std::min_element(needed.begin(), needed.end());
  auto octave = [&](double cell) {
    const double k = std::log2(cell / base);
    const long rounded = std::lround(k);
    return std::abs(k - static_cast<double>(rounded)) < 1e-9 ? static_cast<int>(rounded) : -1;
  };
  int depth = 0;
  bool nested = !needed.empty();
  for (const double c : needed) {
    nested = nested && octave(c) >= 0;
    depth = std::max(depth, octave(c));
  }
  std::vector<SamplesPtr> pyramid;
  if (nested)
    for (auto& samples :
         makeSourceSamplePyramid(source_.points, base, depth, threads, &source_.box))
      pyramid.push_back(std::make_shared<const SourceSamples>(std::move(samples)));
  SamplesPtr every_point;
  auto samplesFor = [&](double cell) -> SamplesPtr {
    if (cell <= 0.0) {
      if (!every_point)
        every_point =
            std::make_shared<const SourceSamples>(makeSourceSamples(source_.points, 0.0));
      return every_point;
    }
    if (nested)
      return pyramid[static_cast<std::size_t>(octave(cell))];
    return std::make_shared<const SourceSamples>(
        makeSourceSamples(source_.points, cell, &source_.box));
  };
  source_levels_.clear();
  for (const double c : cells)
    source_levels_.push_back(samplesFor(c));
  source_up_ = estimateUpDirection(*source_levels_.front(), threads);
}

} // namespace core
} // namespace pcl_mi
