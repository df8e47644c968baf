/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_mi/registration_core.h>

#include "backend/scoring_backend.h"
#ifdef PCL_MI_WITH_OPENCL
#include "backend/opencl_backend.h"
#endif
#include "core/input_checks.h"
#include "core/mutual_information.h"
#include "core/nelder_mead.h"
#include "core/parallel.h"
#include "core/pose.h"
#include "core/refinement.h"
#include "core/voxel_grid.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <sstream>

namespace pcl_mi {

const char*
featureName(Feature feature)
{
  switch (feature) {
  case Feature::VarianceZ:
    return "VarianceZ";
  case Feature::PointCount:
    return "PointCount";
  }
  return "unknown";
}

bool
parseBackend(const std::string& name, Backend& backend)
{
  if (name == "cpu")
    backend = Backend::Cpu;
  else if (name == "opencl")
    backend = Backend::OpenCL;
  else if (name == "auto")
    backend = Backend::Auto;
  else
    return false;
  return true;
}

namespace {

/** Most restarts: each costs at least one iteration of the budget, and more than this
 * many searches around one optimum find nothing new. */
constexpr int kMaxRestarts = 100;

std::string
validateBinning(const char* what, const FeatureBinning& b)
{
  std::ostringstream s;
  if (b.num_bins < 1 || b.num_bins > 255)
    s << what << " binning needs 1..255 bins, got " << b.num_bins;
  else if (!(b.max_value > 0.0) || !std::isfinite(b.max_value))
    s << what << " binning needs a positive finite maximum value, got " << b.max_value;
  else if (!(b.range_quantile >= 0.0 && b.range_quantile <= 1.0))
    s << what << " binning's range quantile must be in [0, 1], got " << b.range_quantile;
  return s.str();
}

} // namespace

Parameters
Parameters::paper()
{
  Parameters p;
  p.symmetric_start = false;
  p.pyramid_levels = 1;
  p.source_subdivision = 0;
  p.restarts = 0;
  p.refinement = Refinement::None;
  p.narrow_view_position_starts = 0;
  p.variance_z_binning.range_quantile = 0.0;
  p.point_count_binning.range_quantile = 0.0;
  return p;
}

std::string
Parameters::validate() const
{
  std::ostringstream s;
  if (!(resolution > 0.0) || !std::isfinite(resolution))
    s << "resolution must be positive and finite, got " << resolution;
  else if (feature != Feature::VarianceZ && feature != Feature::PointCount)
    s << "unknown feature " << static_cast<int>(feature);
  else if (!validateBinning("VarianceZ", variance_z_binning).empty())
    return validateBinning("VarianceZ", variance_z_binning);
  else if (!validateBinning("PointCount", point_count_binning).empty())
    return validateBinning("PointCount", point_count_binning);
  else if (!simplex_steps.allFinite())
    s << "simplex steps must be finite";
  else if (simplex_steps.isZero())
    s << "at least one simplex step must be non-zero";
  else if (max_iterations < 1)
    s << "maximum iterations must be at least 1, got " << max_iterations;
  else if (!(translation_tolerance >= 0.0) || !std::isfinite(translation_tolerance))
    s << "translation tolerance must be finite and not negative (0 = follow the resolution), "
         "got "
      << translation_tolerance;
  else if (!(rotation_tolerance > 0.0) || !std::isfinite(rotation_tolerance))
    s << "rotation tolerance must be positive and finite, got " << rotation_tolerance;
  else if (source_subdivision < 0 || source_subdivision > 64)
    s << "source subdivision must be 0..64, got " << source_subdivision;
  else if (num_threads < 1)
    s << "number of threads must be at least 1, got " << num_threads;
  else if (heading_starts < 1 || heading_starts > 360)
    s << "heading starts must be 1..360, got " << heading_starts;
  else if (position_starts < 0 || position_starts > 360)
    s << "position starts must be 0..360, got " << position_starts;
  else if (narrow_view_position_starts < 0 || narrow_view_position_starts > 360)
    s << "narrow-view position starts must be 0..360, got " << narrow_view_position_starts;
  else if (pyramid_levels < 1 || pyramid_levels > 8)
    s << "pyramid levels must be 1..8, got " << pyramid_levels;
  else if (restarts < 0 || restarts > kMaxRestarts)
    s << "restarts must be 0.." << kMaxRestarts << ", got " << restarts;
  else if (backend != Backend::Cpu && backend != Backend::OpenCL && backend != Backend::Auto)
    s << "unknown backend " << static_cast<int>(backend);
  else if (refinement != Refinement::None && refinement != Refinement::PointToDistribution)
    s << "unknown refinement " << static_cast<int>(refinement);
  else if (!(refinement_resolution >= 0.0) || !std::isfinite(refinement_resolution))
    s << "refinement resolution must be finite and not negative (0 = follow the resolution), "
         "got "
      << refinement_resolution;
  else if (refinement_max_iterations < 1)
    s << "refinement iterations must be at least 1, got " << refinement_max_iterations;
  else if (!(restart_scale > 0.0) || !std::isfinite(restart_scale))
    s << "restart scale must be positive and finite, got " << restart_scale;
  return s.str();
}

/** Tolerance of pyramid level l > 0, relative to the finest level's: factor * 2^l. */
constexpr double kCoarseToleranceFactor = 30.0;

/** Iterations of the search from the guess on the first finer level. That candidate only
 * has to keep a good guess from being pulled off its peak by the coarse grid, which takes
 * few iterations; a search that needs more is travelling far from the guess, which the
 * search from the coarse optimum already covers. Capping it keeps the runtime from growing
 * with the initial error; a capped search that wins is finished on its own afterwards (measured: the same poses on all shared pairs, under both
 * protocols and with guesses 0.1-1 m off). */
constexpr int kGuessCandidateIterations = 25;

/** Most optima of further starts (heading_starts, position_starts) that the level after the
 * coarsest refines besides the best one: the coarse grid ranks them, the finer one decides.
 * Measured on KITTI cut to a 70 deg field of view: 3 and 6 gave the same poses. */
constexpr int kMaxStartCandidates = 3;
/** Rotation (rad) below which two coarse optima half a coarse voxel apart are one basin. */
constexpr double kCandidateSeparationRad = 0.2;

/** Azimuth coverage (degrees) below which a cloud has a narrow field of view
 * (Parameters::narrow_view_position_starts): a spinning LiDAR's scan covers 360, a
 * solid-state sensor's its field of view (70-120 for common ones). */
constexpr double kNarrowViewDegrees = 180.0;

/** Fewest points a target cube needs to give the refinement a distribution. */
constexpr int kRefinementMinimumPoints = 4;
/** Noise (standard deviation) added to the refinement's target covariances, as a fraction
 * of the MI resolution: 0.05 m at 1 m voxels, about the range noise of a spinning LiDAR. */
constexpr double kRefinementNoiseFraction = 0.05;
/** A refinement that moves the pose further than this (times the voxel size of the finest
 * level the MI search ran on, and degrees) left the MI basin and is discarded. The MI
 * optimum is quantised by that level's voxels, so it can be up to about one voxel off. */
constexpr double kRefinementMaxShift = 1.0;
constexpr double kRefinementMaxTurnDeg = 5.0;

/** Share of a cloud's usable points whose loss as far outliers is worth a warning: a few
 * stray returns are what the rule is for, a second site is not. */
constexpr double kOutlierWarningShare = 0.01;

struct RegistrationCore::Impl {
  Parameters parameters;
  PointList target_input, source_input;
  bool target_dirty = true, source_dirty = true;
  bool has_target = false, has_source = false;
  core::LocalCloud target, source;
  /** One per pyramid level, finest (the parameters' resolution) first. */
  struct Level {
    double resolution = 1.0;
    std::shared_ptr<core::TargetGrid> grid;
    std::unique_ptr<backend::ScoringBackend> backend;
    /** A second backend for a concurrent search (the mirrored start). */
    std::unique_ptr<backend::ScoringBackend> mirror_backend;
    std::shared_ptr<const core::SourceSamples> samples;
  };
  std::vector<Level> levels;
  /** Far-outlier warnings of the current target and source (see describeOutliers()). */
  std::string target_warning, source_warning;
  /** The backend the levels use, resolved with the target. */
  bool use_opencl = false;
  std::string backend_name = "cpu", backend_warning;
#ifdef PCL_MI_WITH_OPENCL
  std::shared_ptr<backend::OpenClDevice> opencl_device;
#endif
  /** The refinement's target distributions and source samples (when it is on). */
  std::unique_ptr<core::TargetDistributions> distributions;
  std::shared_ptr<const core::SourceSamples> refinement_samples;
  /** The source's samples per level (see buildSourceSamples()). */
  std::vector<std::shared_ptr<const core::SourceSamples>> source_levels;
  JointHistogram scratch;

  /** First pyramid level the MI search runs on. A refinement takes the place of the
   * search on the finest level: from the next coarser level's optimum it converges to a
   * finer alignment than the quantised finest-level MI, for a fraction of the evaluations. */
  int
  firstSearchedLevel() const
  {
    return parameters.refinement != Refinement::None && parameters.pyramid_levels > 1 ? 1 : 0;
  }

  /** Brings the local clouds, the source samples, the levels' grids and the refinement's
   * target up to date; the levels' backends are made on first use (see level()). The work
   * runs as independent tasks (target and source local clouds, then the source samples,
   * the refinement's distributions and each level's grid) spread over the threads: each
   * task writes only its own outputs, so the result does not depend on the thread count. */
  bool
  prepare(std::string& error)
  {
    if (!has_target) {
      error = "no target cloud was given";
      return false;
    }
    if (!has_source) {
      error = "no source cloud was given";
      return false;
    }
    const bool new_target = target_dirty;
    // The source has samples for every level (the level count may have changed).
    const bool new_source =
        source_dirty || source_levels.size() != static_cast<std::size_t>(parameters.pyramid_levels);
    if (!new_target && !new_source)
      return true;
    if (new_target && !resolveBackend(error))
      return false;

    // A resolution too fine for the clouds is named as such before the outlier gap, which
    // follows it, would split them into fragments.
    for (const auto& [is_new, input, which] :
         {std::make_tuple(new_target, &target_input, "target"),
          std::make_tuple(new_source, &source_input, "source")}) {
      if (is_new)
        error = core::resolutionError(*input, parameters.resolution, which);
      if (!error.empty())
        return false;
    }
    // The local clouds first: everything else is built from them.
    const double gap = core::kOutlierGapVoxels * parameters.resolution;
    // Only the changed clouds are tasks, so a new source alone starts no thread.
    std::vector<std::function<void()>> local_tasks;
    if (new_target)
      local_tasks.emplace_back([&] { target = core::makeLocalCloud(target_input, gap); });
    if (new_source)
      local_tasks.emplace_back([&] { source = core::makeLocalCloud(source_input, gap); });
    core::parallelFor(static_cast<int>(local_tasks.size()), parameters.num_threads,
                      [&](int task) { local_tasks[static_cast<std::size_t>(task)](); });
    if (target.points.size() < core::kMinimumPoints) {
      error = describeTooFew("target", target);
      return false;
    }
    if (source.points.size() < core::kMinimumPoints) {
      error = describeTooFew("source", source);
      return false;
    }
    // An unchanged cloud passed at this resolution already (a new resolution marks both).
    if (new_target)
      error = core::structureError(target, parameters.resolution, "target");
    if (error.empty() && new_source)
      error = core::structureError(source, parameters.resolution, "source");
    if (!error.empty())
      return false;
    if (new_target)
      target_warning = describeOutliers("target", target, gap);
    if (new_source)
      source_warning = describeOutliers("source", source, gap);
    if (new_target) {
      // Refuse a too-fine resolution up front: no coarser level needs more voxels.
      core::GridGeometry finest;
      if (!core::makeGridGeometry(target.points, parameters.resolution, finest, error))
        return false;
      levels.clear();
      levels.resize(static_cast<std::size_t>(parameters.pyramid_levels));
      for (int l = 0; l < parameters.pyramid_levels; ++l)
        levels[l].resolution = levelResolution(l);
      distributions.reset();
    }

    // Longest first: a free thread takes the next task.
    std::vector<std::function<void()>> tasks;
    if (new_source)
      tasks.emplace_back([this] { buildSourceSamples(); });
    if (new_target && parameters.refinement == Refinement::PointToDistribution)
      tasks.emplace_back([this] {
        distributions = std::make_unique<core::TargetDistributions>(
            target.points,
            parameters.effectiveRefinementResolution(),
            kRefinementMinimumPoints,
            kRefinementNoiseFraction * parameters.resolution);
      });
    if (new_target)
      for (int l = 0; l < parameters.pyramid_levels; ++l)
        tasks.emplace_back([this, l] { buildGrid(l); });
    core::parallelFor(static_cast<int>(tasks.size()), parameters.num_threads,
                      [&](int task) { tasks[static_cast<std::size_t>(task)](); });

    target_dirty = false;
    source_dirty = false;
    // New levels need the samples; new samples need handing to the existing backends.
    for (std::size_t l = 0; l < levels.size(); ++l) {
      Level& level = levels[l];
      level.samples = source_levels[l];
      if (level.backend)
        level.backend->setSource(level.samples);
      if (level.mirror_backend)
        level.mirror_backend->setSource(level.samples);
    }
    return true;
  }

  /** Picks the backend for the parameters: false (with \a error) only when OpenCL was
   * requested explicitly and is unavailable; Auto falls back to the CPU with a warning. */
  bool
  resolveBackend(std::string& error)
  {
    use_opencl = false;
    backend_name = "cpu";
    backend_warning.clear();
    if (parameters.backend == Backend::Cpu)
      return true;
    // Auto takes OpenCL only where it was measured to be faster (README, OpenCL backend):
    // on a GPU or accelerator, with every point in every evaluation. Evaluations of a few
    // thousand samples are too light to hide the device's per-evaluation latency, and an
    // OpenCL CPU device (PoCL) is slower than the CPU backend on the same cores.
    if (parameters.backend == Backend::Auto && parameters.source_subdivision != 0)
      return true;
    std::string why;
#ifdef PCL_MI_WITH_OPENCL
    // A CPU device is decided on before its kernels are built; no device at all falls
    // through to openClDevice(), whose error becomes the warning.
    std::string no_device;
    if (parameters.backend == Backend::Auto &&
        !backend::openClDeviceIsOffload(parameters.opencl_platform, parameters.opencl_device,
                                        no_device) &&
        no_device.empty())
      return true;
    opencl_device =
        backend::openClDevice(parameters.opencl_platform, parameters.opencl_device, why);
    if (opencl_device) {
      use_opencl = true;
      backend_name = "opencl (" + backend::openClDeviceName(*opencl_device) + ")";
      return true;
    }
#else
    why = "this pcl_mi was built without its OpenCL backend (PCL_MI_WITH_OPENCL=OFF or no "
          "OpenCL found at build time)";
#endif
    if (parameters.backend == Backend::OpenCL) {
      error = "the OpenCL backend was requested but is unavailable: " + why;
      return false;
    }
    backend_warning = "no usable OpenCL device, using the CPU backend: " + why;
    return true;
  }

  std::unique_ptr<backend::ScoringBackend>
  makeBackend()
  {
#ifdef PCL_MI_WITH_OPENCL
    if (use_opencl)
      return backend::makeOpenClBackend(opencl_device, parameters.profile_device);
#endif
    return backend::makeCpuBackend();
  }

  /** Voxel size of pyramid level \a l (0 = finest). The source's samples and the target's
   * levels are built concurrently, so both derive the sizes from here. */
  double
  levelResolution(int l) const
  {
    return parameters.resolution * std::ldexp(1.0, l);
  }

  /** The target grid of level \a l. Throws std::runtime_error if it cannot be built, which
   * prepare() has ruled out. */
  void
  buildGrid(int l)
  {
    Level& level = levels[static_cast<std::size_t>(l)];
    level.grid = std::make_shared<core::TargetGrid>();
    std::string error;
    if (!core::buildTargetGrid(target.points, level.resolution, parameters.feature,
                               levelBinning(level.resolution), *level.grid, error))
      throw std::runtime_error(error);
  }

  using SamplesPtr = std::shared_ptr<const core::SourceSamples>;

  /** The source's samples for every level and the refinement's samples. */
  void
  buildSourceSamples()
  {
    const int num_levels = parameters.pyramid_levels;
    std::vector<double> cells(static_cast<std::size_t>(num_levels), 0.0); // 0: every point
    std::vector<double> needed;
    if (parameters.source_subdivision > 0)
      for (int l = 0; l < num_levels; ++l)
        needed.push_back(cells[l] = levelResolution(l) / parameters.source_subdivision);

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
      for (auto& samples : core::makeSourceSamplePyramid(source.points, base, depth))
        pyramid.push_back(std::make_shared<const core::SourceSamples>(std::move(samples)));
    SamplesPtr every_point;
    auto samplesFor = [&](double cell) -> SamplesPtr {
      if (cell <= 0.0) {
        if (!every_point)
          every_point = std::make_shared<const core::SourceSamples>(
              core::makeSourceSamples(source.points, 0.0));
        return every_point;
      }
      if (nested)
        return pyramid[static_cast<std::size_t>(octave(cell))];
      return std::make_shared<const core::SourceSamples>(
          core::makeSourceSamples(source.points, cell));
    };
    source_levels.clear();
    for (const double c : cells)
      source_levels.push_back(samplesFor(c));
    // The refinement moves the finest level's samples.
    refinement_samples = source_levels[0];
  }

  /** Pyramid level \a l with its backend made (after a successful prepare()). */
  Level&
  level(int l)
  {
    Level& level = levels[static_cast<std::size_t>(l)];
    if (!level.backend) {
      level.backend = makeBackend();
      level.backend->setTarget(level.grid);
      level.backend->setSource(level.samples);
    }
    return level;
  }

  /** The second backend of level \a l, for a search running concurrently with one on
   * the first. */
  backend::ScoringBackend&
  mirrorBackend(int l)
  {
    Level& lv = level(l);
    if (!lv.mirror_backend) {
      lv.mirror_backend = makeBackend();
      lv.mirror_backend->setTarget(lv.grid);
      lv.mirror_backend->setSource(lv.samples);
    }
    return *lv.mirror_backend;
  }

  /** Binning at a pyramid level. Point counts grow with the voxel's surface area, so the
   * PointCount range scales with the square of the resolution ratio; VarianceZ is already
   * normalised by the resolution. */
  FeatureBinning
  levelBinning(double level_resolution) const
  {
    FeatureBinning b = parameters.binning();
    if (parameters.feature == Feature::PointCount) {
      const double ratio = level_resolution / parameters.resolution;
      b.max_value *= ratio * ratio;
    }
    return b;
  }

  static std::string
  describeTooFew(const char* which, const core::LocalCloud& cloud)
  {
    std::ostringstream s;
    s << "the " << which << " has " << cloud.points.size() << " usable points ("
      << cloud.non_finite << " non-finite, " << cloud.no_return << " at (0, 0, 0) and "
      << cloud.outliers << " far outliers dropped); at least " << core::kMinimumPoints
      << " are needed";
    return s.str();
  }

  /** A warning when far outliers took more than kOutlierWarningShare of a cloud's usable
   * points; empty otherwise. */
  static std::string
  describeOutliers(const char* which, const core::LocalCloud& cloud, double gap)
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

  /** MI at a source-to-target transformation in the input frames, on pyramid level
   * \a level (0 = finest). */
  double
  mutualInformation(const Eigen::Matrix4d& pose, JointHistogram& histogram, int level = 0)
  {
    return mutualInformation(pose, histogram, *this->level(level).backend);
  }

  /** The same on a given backend (each concurrent search owns one). */
  double
  mutualInformation(const Eigen::Matrix4d& pose,
                    JointHistogram& histogram,
                    backend::ScoringBackend& backend)
  {
    // Into the local frames: target_local = R * source_local + R c_s + t - c_t.
    const Eigen::Matrix3d r = pose.topLeftCorner<3, 3>();
    const Eigen::Vector3d t =
        r * source.centroid + pose.topRightCorner<3, 1>() - target.centroid;
    if (!r.allFinite() || !t.allFinite()) {
      histogram.overlap_voxels = 0;
      return 0.0;
    }
    backend.jointHistogram(r.cast<float>(), t.cast<float>(), histogram);
    return histogram.overlap_voxels == 0 ? 0.0 : core::mutualInformation(histogram);
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
  if (!error.empty())
    return error;
  const Parameters& old = impl_->parameters;
  const bool grid_changed = old.resolution != parameters.resolution ||
                            old.pyramid_levels != parameters.pyramid_levels ||
                            old.feature != parameters.feature ||
                            old.binning().num_bins != parameters.binning().num_bins ||
                            old.binning().max_value != parameters.binning().max_value ||
                            old.binning().range_quantile != parameters.binning().range_quantile;
  if (grid_changed) {
    impl_->target_dirty = true;
    // The outlier gap scales with the resolution.
    impl_->source_dirty = impl_->source_dirty || old.resolution != parameters.resolution;
  }
  if (old.source_subdivision != parameters.source_subdivision)
    impl_->source_dirty = true;
  if (old.backend != parameters.backend || old.opencl_platform != parameters.opencl_platform ||
      old.opencl_device != parameters.opencl_device ||
      old.profile_device != parameters.profile_device ||
      (parameters.backend == Backend::Auto &&
       old.source_subdivision != parameters.source_subdivision)) {
    impl_->target_dirty = true;
    impl_->source_dirty = true;
  }
  if (old.refinement != parameters.refinement ||
      old.effectiveRefinementResolution() != parameters.effectiveRefinementResolution()) {
    impl_->target_dirty = true;
    impl_->source_dirty = true;
  }
  impl_->parameters = parameters;
  return {};
}

const Parameters&
RegistrationCore::parameters() const
{
  return impl_->parameters;
}

void
RegistrationCore::setTarget(PointList points)
{
  impl_->target_input = std::move(points);
  impl_->has_target = true;
  impl_->target_dirty = true;
}

void
RegistrationCore::setSource(PointList points)
{
  impl_->source_input = std::move(points);
  impl_->has_source = true;
  impl_->source_dirty = true;
}

std::vector<StageTiming>
RegistrationCore::backendProfile() const
{
  std::vector<StageTiming> stages;
  for (const auto& level : impl_->levels) {
    if (level.backend)
      level.backend->appendProfile(stages);
    if (level.mirror_backend)
      level.mirror_backend->appendProfile(stages);
  }
  return stages;
}

void
RegistrationCore::resetBackendProfile()
{
  for (auto& level : impl_->levels) {
    if (level.backend)
      level.backend->resetProfile();
    if (level.mirror_backend)
      level.mirror_backend->resetProfile();
  }
}

const std::string&
RegistrationCore::backendName() const
{
  return impl_->backend_name;
}

const std::string&
RegistrationCore::backendWarning() const
{
  return impl_->backend_warning;
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

std::size_t
RegistrationCore::droppedTargetPoints() const
{
  return impl_->target.non_finite + impl_->target.no_return + impl_->target.outliers;
}

std::size_t
RegistrationCore::droppedSourcePoints() const
{
  return impl_->source.non_finite + impl_->source.no_return + impl_->source.outliers;
}

bool
RegistrationCore::jointHistogram(const Eigen::Matrix4d& pose,
                                 JointHistogram& histogram,
                                 std::string* error)
{
  std::string why;
  if (!impl_->prepare(why)) {
    if (error)
      *error = why;
    return false;
  }
  impl_->mutualInformation(pose, histogram);
  return true;
}

double
RegistrationCore::evaluate(const Eigen::Matrix4d& pose, std::string* error)
{
  std::string why;
  if (!impl_->prepare(why)) {
    if (error)
      *error = why;
    return -1.0;
  }
  return impl_->mutualInformation(pose, impl_->scratch);
}

AlignmentResult
RegistrationCore::align(const Eigen::Matrix4d& guess)
{
  AlignmentResult result;
  result.transformation = guess;
  const std::string guess_error = core::rigidTransformError(guess);
  if (!guess_error.empty()) {
    result.error = "the initial guess " + guess_error;
    return result;
  }
  Impl& d = *impl_;
  using Clock = std::chrono::steady_clock;
  auto stage_start = Clock::now();
  auto endStage = [&](std::string name, int calls) {
    const auto now = Clock::now();
    result.stages.push_back(
        {std::move(name), calls, std::chrono::duration<double, std::milli>(now - stage_start).count()});
    stage_start = now;
  };
  if (!d.prepare(result.error))
    return result;
  for (const std::string* warning : {&d.target_warning, &d.source_warning})
    if (!warning->empty())
      result.warnings.push_back(*warning);
  endStage("prepare", 1);

  JointHistogram& histogram = d.scratch;
  if (d.mutualInformation(guess, histogram) <= 0.0 && histogram.overlap_voxels == 0) {
    result.error = "the bounding boxes of source and target do not overlap at the initial "
                   "guess";
    return result;
  }

  // Only parameters with a non-zero step are searched (a zero step pins one, e.g. for
  // planar motion).
  const Parameters& p = d.parameters;
  std::vector<int> active;
  for (int i = 0; i < 6; ++i)
    if (p.simplex_steps[i] != 0.0)
      active.push_back(i);
  const Eigen::Index n = static_cast<Eigen::Index>(active.size());
  const Eigen::Vector3d pivot = (guess * d.source.centroid.homogeneous()).head<3>();

  auto fullParameters = [&](const Eigen::VectorXd& x) {
    core::Vector6d full = core::Vector6d::Zero();
    for (Eigen::Index i = 0; i < n; ++i)
      full[active[i]] = x[i];
    return full;
  };
  Eigen::VectorXd steps(n), tolerance(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    steps[i] = p.simplex_steps[active[i]];
    tolerance[i] = active[i] < 3 ? p.effectiveTranslationTolerance() : p.rotation_tolerance;
  }

  /** One Nelder-Mead search on one level and backend, capped at \a cap iterations. */
  auto search = [&](int level,
                    backend::ScoringBackend& backend,
                    const Eigen::VectorXd& x0,
                    const Eigen::VectorXd& s,
                    int cap) {
    JointHistogram h;
    auto cost = [&](const Eigen::VectorXd& x) {
      return -d.mutualInformation(
          core::transformFromParameters(fullParameters(x), guess, pivot), h, backend);
    };
    core::NelderMeadOptions options;
    options.max_iterations = std::max(cap, 0);
    // A coarse level only has to land in the basin: the next level restarts with a larger
    // simplex than this tolerance anyway.
    options.tolerance =
        tolerance * (level > 0 ? kCoarseToleranceFactor * std::ldexp(1.0, level) : 1.0);
    return core::minimizeNelderMead(cost, x0, s, options);
  };

  /** Two independent searches on one level, each (start, simplex, iteration cap) on its
   * own backend and concurrent when threads allow: the same results either way. */
  struct Start {
    const Eigen::VectorXd& x0;
    Eigen::VectorXd steps;
    int cap;
  };
  auto searchBoth = [&](int level, const Start& a, const Start& b) {
    std::array<core::NelderMeadResult, 2> results;
    backend::ScoringBackend& first = *d.level(level).backend;
    backend::ScoringBackend& second = d.mirrorBackend(level);
    core::parallelFor(2, p.num_threads, [&](int k) {
      const Start& start = k == 0 ? a : b;
      results[static_cast<std::size_t>(k)] =
          search(level, k == 0 ? first : second, start.x0, start.steps, start.cap);
    });
    return results;
  };

  int budget = p.max_iterations;
  core::NelderMeadResult best;
  bool have_best = false;
  auto account = [&](const core::NelderMeadResult& r) {
    budget -= r.iterations;
    result.iterations += r.iterations;
    result.evaluations += r.evaluations;
    if (!have_best || r.value < best.value) {
      best = r;
      have_best = true;
    }
  };

  // Coarsest level first: the paper's simplex from the guess. Its simplex reaches mostly
  // along the positive steps, so the mirrored start (all steps negated) makes the search
  // symmetric about the guess: backward motion is found as well as forward motion. The two
  // starts are independent and split the iteration budget in fixed shares, so running them
  // on two threads gives the same result as running them one after the other.
  // With several heading or position starts, each gets the same share of the budget and its
  // own pair of starts, turned by its heading about the source's centroid or moved by its
  // offset; the best of all goes on, together with the best few distinct others.
  const int first_level = d.firstSearchedLevel();
  int level = static_cast<int>(d.levels.size()) - 1;
  const Eigen::VectorXd origin = Eigen::VectorXd::Zero(n);
  // Where parameter 0..5 sits in the search vector, -1 when pinned.
  auto searchIndex = [&](int parameter) -> Eigen::Index {
    const auto it = std::find(active.begin(), active.end(), parameter);
    return it == active.end() ? -1 : static_cast<Eigen::Index>(it - active.begin());
  };
  const Eigen::Index x_index = searchIndex(0), y_index = searchIndex(1),
                     yaw_index = searchIndex(5);
  const int headings = yaw_index >= 0 ? p.heading_starts : 1;
  // Position starts lie on the ellipse of half the x and y steps around the guess.
  const bool narrow_view = std::min(d.target.azimuth_coverage_deg,
                                     d.source.azimuth_coverage_deg) < kNarrowViewDegrees;
  const int positions =
      x_index >= 0 || y_index >= 0
          ? std::max(p.position_starts, narrow_view ? p.narrow_view_position_starts : 0)
          : 0;
  result.position_starts = positions;
  const int starts = headings + positions;
  const int start_budget = budget / starts;
  const int mirrored_cap = p.symmetric_start ? start_budget / 2 : 0;
  const int forward_cap = start_budget - mirrored_cap;
  std::vector<core::NelderMeadResult> start_best; // the better of each start's pair
  for (int k = 0; k < starts; ++k) {
    Eigen::VectorXd start = origin;
    if (k > 0 && k < headings) // k * 360 / headings degrees, in (-180, 180]
      start[yaw_index] = std::remainder(2.0 * M_PI * k / headings, 2.0 * M_PI);
    if (k >= headings) {
      const double angle = 2.0 * M_PI * (k - headings) / positions;
      if (x_index >= 0)
        start[x_index] = 0.5 * steps[x_index] * std::cos(angle);
      if (y_index >= 0)
        start[y_index] = 0.5 * steps[y_index] * std::sin(angle);
    }
    if (p.symmetric_start) {
      const auto both =
          searchBoth(level, {start, steps, forward_cap}, {start, -steps, mirrored_cap});
      account(both[0]);
      account(both[1]);
      start_best.push_back(both[1].value < both[0].value ? both[1] : both[0]);
    }
    else {
      start_best.push_back(search(level, *d.level(level).backend, start, steps, forward_cap));
      account(start_best.back());
    }
  }
  int stage_evaluations = 0;
  auto endSearchStage = [&](const std::string& name) {
    endStage(name, result.evaluations - stage_evaluations);
    stage_evaluations = result.evaluations;
  };
  auto levelName = [&](int l) {
    std::ostringstream s;
    s << "search " << d.levels[static_cast<std::size_t>(l)].resolution << " m";
    return s.str();
  };
  endSearchStage(levelName(level));
  // The coarse optimum need not be the fine one, and a coarse grid can pull a good guess
  // away from the fine peak: the first finer level refines both the coarse optimum and the
  // guess itself.
  std::vector<Eigen::VectorXd> candidates{best.x};
  if (level > first_level &&
      (best.x.cwiseAbs().array() > tolerance.array() * kCoarseToleranceFactor).any())
    candidates.push_back(origin);
  // With several starts the coarse grid can rank a wrong optimum first (a straight road
  // looks much the same turned by 180 deg at 4 m; a narrow field of view's edges agree
  // best near the guess): the best few optima of the other starts that are not the same
  // basin (half a coarse voxel and kCandidateSeparationRad apart) go on as well.
  if (starts > 1 && level > first_level) {
    std::stable_sort(start_best.begin(), start_best.end(),
                     [](const core::NelderMeadResult& a, const core::NelderMeadResult& b) {
                       return a.value < b.value;
                     });
    const double half_voxel = 0.5 * d.levels[static_cast<std::size_t>(level)].resolution;
    int added = 0;
    for (const core::NelderMeadResult& r : start_best) {
      if (added == kMaxStartCandidates)
        break;
      bool distinct = true;
      for (const Eigen::VectorXd& c : candidates) {
        double shift = 0.0, turn = 0.0;
        for (Eigen::Index i = 0; i < n; ++i) {
          const double delta = r.x[i] - c[i];
          if (active[static_cast<std::size_t>(i)] < 3)
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
  }

  // Each finer level refines the candidates with a simplex half the size of the previous
  // level's; the costs of two levels are not comparable, so each level keeps its own best,
  // which the next level refines. Restarts around the best vertex, with simplices of
  // alternating orientation, then lift the finest search out of the small local optima that
  // voxel quantisation scatters near the peak.
  double scale = p.restart_scale;
  while (level > first_level) {
    --level;
    have_best = false;
    if (candidates.size() == 1) {
      account(search(level, *d.level(level).backend, candidates[0], scale * steps, budget));
    }
    else {
      // The coarse optimum gets the budget, the other candidates (the guess, other starts'
      // optima) a capped search each; two at a time, concurrently.
      const int cap = std::max(budget / 2, 0);
      const int capped = std::min(cap, kGuessCandidateIterations);
      std::vector<core::NelderMeadResult> from(candidates.size());
      for (std::size_t i = 0; i < candidates.size(); i += 2) {
        const int first_cap = i == 0 ? cap : capped;
        if (i + 1 < candidates.size()) {
          const auto both = searchBoth(level, {candidates[i], scale * steps, first_cap},
                                       {candidates[i + 1], scale * steps, capped});
          from[i] = both[0];
          from[i + 1] = both[1];
        }
        else {
          from[i] = search(level, *d.level(level).backend, candidates[i], scale * steps,
                           first_cap);
        }
      }
      std::size_t winner = 0;
      for (std::size_t i = 0; i < from.size(); ++i) {
        account(from[i]);
        if (from[i].value < from[winner].value)
          winner = i;
      }
      // A capped candidate that wins before its search converged is finished from where it
      // got.
      if (winner > 0 && !from[winner].converged && budget > 0)
        account(search(level, *d.level(level).backend, from[winner].x, 0.5 * scale * steps,
                       budget));
    }
    candidates = {best.x};
    if (level > first_level)
      scale *= 0.5;
    endSearchStage(levelName(level));
  }
  for (int k = 0; k < p.restarts && budget > 0; ++k) {
    const core::NelderMeadResult restart =
        search(level, *d.level(level).backend, best.x, (k % 2 ? scale : -scale) * steps, budget);
    account(restart);
    // A restart that starts inside the tolerance takes no iteration; it still costs one, so
    // that the budget ends the loop.
    budget -= restart.iterations == 0 ? 1 : 0;
  }
  if (p.restarts > 0)
    endSearchStage("restarts");

  result.converged = best.converged;
  result.mutual_information = -best.value;
  result.transformation = core::transformFromParameters(fullParameters(best.x), guess, pivot);
  if (p.refinement == Refinement::PointToDistribution) {
    // In the local frames: target_local = R * source_local + t.
    const Eigen::Matrix3d r = result.transformation.topLeftCorner<3, 3>();
    const Eigen::Vector3d t =
        r * d.source.centroid + result.transformation.topRightCorner<3, 1>() - d.target.centroid;
    core::RefinementOptions options;
    options.max_iterations = p.refinement_max_iterations;
    options.num_threads = p.num_threads;
    for (int i = 0; i < 6; ++i)
      options.active[i] = p.simplex_steps[i] != 0.0;
    const core::RefinementResult refined =
        core::refineToDistributions(*d.distributions, *d.refinement_samples, r, t, options);
    endStage("refinement", refined.iterations);
    const double turn_deg =
        Eigen::AngleAxisd(refined.rotation * r.transpose()).angle() * 180.0 / M_PI;
    const double searched_resolution = d.levels[static_cast<std::size_t>(first_level)].resolution;
    if ((refined.translation - t).norm() <= kRefinementMaxShift * searched_resolution &&
        turn_deg <= kRefinementMaxTurnDeg) {
      result.refinement_iterations = refined.iterations;
      result.transformation.topLeftCorner<3, 3>() = refined.rotation;
      result.transformation.topRightCorner<3, 1>() =
          refined.translation - refined.rotation * d.source.centroid + d.target.centroid;
      result.mutual_information = d.mutualInformation(result.transformation, histogram);
    }
  }
  return result;
}

} // namespace pcl_mi
