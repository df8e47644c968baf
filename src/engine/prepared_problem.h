/*
 * pcl_mi: one registration problem made ready to score: both clouds in local frames, the
 * target's grid and the source's samples per pyramid level, the refinement's target
 * distributions and the backends. What a parameter change makes stale follows from the
 * parameter group that changed.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "engine/backend_factory.h"
#include "features/local_cloud.h"
#include "features/source_samples.h"
#include "features/voxel_grid.h"
#include "refine/refinement.h"

#include <pcl_mi/parameters.h>

#include <Eigen/Core>

#include <algorithm>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace pcl_mi {
namespace core {

/** \brief A source-to-target pose between the local frames:
 * target_local = rotation * source_local + translation. */
struct LocalPose {
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
};

/** \brief The clouds and everything built from them for one parameter set. */
class PreparedProblem {
public:
  /** \brief Replaces the (validated) parameters as the caller gave them, derived values
   * unresolved, and marks what their change made stale. */
  void
  setParameters(const Parameters& parameters);
  /** \brief The parameters as given (0 and negative steps where values are derived). */
  const Parameters&
  requestedParameters() const
  {
    return requested_;
  }
  /** \brief The parameters in use: derived values resolved for the current target
   * (derived_defaults.h); a derived resolution stays 0 until a target is set. */
  const Parameters&
  parameters() const
  {
    return parameters_;
  }

  /** \brief The clouds to align, kept. */
  void
  setTarget(PointList points)
  {
    setTargetView(ownedView(std::move(points)));
  }
  void
  setSource(PointList points)
  {
    setSourceView(ownedView(std::move(points)));
  }
  /** \brief The clouds to align, read through \a points when prepare() needs them (and, for
   * a derived resolution, the target's extent at once), as RegistrationCore::setTargetView()
   * says. */
  void
  setTargetView(PointView points);
  void
  setSourceView(PointView points);
  /** A temporary list would be gone before it is read. */
  void
  setTargetView(PointList&&) = delete;
  void
  setSourceView(PointList&&) = delete;
  /** \brief How many times setTarget() and setSource() were called: a copy of a cloud taken
   * at one count is still the cloud while the count stays. */
  std::uint64_t
  targetRevision() const
  {
    return target_revision_;
  }
  std::uint64_t
  sourceRevision() const
  {
    return source_revision_;
  }
  /** \brief With \a search_only, prepare() builds only what a search needs: the refinement's
   * distributions, which serve the refinement and the verdict, are left out (distributions()
   * must not be called then). */
  void
  setSearchOnly(bool search_only)
  {
    target_dirty_ = target_dirty_ || search_only != search_only_;
    search_only_ = search_only;
  }
  /** \brief The clouds as set, before any preparation. */
  const PointView&
  targetInput() const
  {
    return target_input_;
  }
  const PointView&
  sourceInput() const
  {
    return source_input_;
  }

  /** \brief Brings everything stale up to date; false (with \a error) when the clouds or
   * parameters cannot be used. The work runs as independent tasks over the threads, each
   * writing only its own outputs, so the result does not depend on the thread count. */
  bool
  prepare(std::string& error);

  /** \brief Pyramid levels (0 = finest) and their voxel sizes. */
  int
  levels() const
  {
    return static_cast<int>(levels_.size());
  }
  double
  levelResolution(int level) const;

  /** \brief First pyramid level the MI search runs on: with a refinement the search skips
   * the finest level, since the refinement from the next level's optimum converges finer
   * than the quantised finest-level MI, for a fraction of the evaluations. */
  int
  firstSearchedLevel() const;

  /** \brief Joint histogram at a source-to-target pose in the input frames, on \a level,
   * computed by evaluator \a slot (0 or 1; the two may run concurrently); no overlap for
   * a pose that does not map to a finite local one. */
  void
  jointHistogram(const Eigen::Matrix4d& pose, JointHistogram& histogram, int level, int slot);

  /** \brief Mutual information of jointHistogram(); 0 without overlap. */
  double
  mutualInformation(const Eigen::Matrix4d& pose,
                    JointHistogram& histogram,
                    int level = 0,
                    int slot = 0);

  /** \brief jointHistogram() of each of \a poses into \a histograms, resized to match:
   * one batch for the level's backend. */
  void
  jointHistograms(const std::vector<Eigen::Matrix4d>& poses,
                  std::vector<JointHistogram>& histograms,
                  int level,
                  int slot);

  /** \brief True when the backends of the levels score a batch of poses in about the time
   * of one (ScoringBackend::prefersBatches()). */
  bool
  prefersBatches();

  /** \brief The pose between the local frames, and back. */
  LocalPose
  toLocal(const Eigen::Matrix4d& pose) const;
  Eigen::Matrix4d
  fromLocal(const LocalPose& local) const;

  const LocalCloud&
  target() const
  {
    return target_;
  }
  const LocalCloud&
  source() const
  {
    return source_;
  }
  /** \brief The refinement's target and the source samples it moves (with a refinement). */
  const TargetDistributions&
  distributions() const
  {
    return *distributions_;
  }
  const SourceSamples&
  refinementSamples() const
  {
    return *source_levels_.front();
  }
  /** \brief distributions() with its cubes moved half a cube along every axis: built on
   * first use, kept with the target. Where the cells cut the surfaces moves a result by
   * about its error (docs/method.md, "The verdict", covariance). */
  const TargetDistributions&
  shiftedDistributions();
  /** \brief refinementSamples() with its cells moved half a cell along every axis (the
   * samples themselves where they are the points). */
  SourceSamples
  shiftedRefinementSamples() const;
  /** \brief How many times prepare() has built from new clouds: what a result's
   * distributions and samples were, changes with it. */
  std::uint64_t
  preparations() const
  {
    return preparations_;
  }
  /** \brief A refinement stage's target: distributions on cubes 2^stage times the
   * refinement's (stage 0: distributions()); coarser stages are built on first use. */
  const TargetDistributions&
  distributions(int stage);
  /** \brief The source samples a refinement stage moves: pyramid level \a stage's, or the
   * coarsest level's beyond it. */
  const SourceSamples&
  refinementSamples(int stage) const
  {
    return *source_levels_[std::min(static_cast<std::size_t>(stage), source_levels_.size() - 1)];
  }
  /** \brief True when either cloud covers less than kNarrowViewDegrees of azimuth. */
  bool
  narrowView() const;
  /** \brief The clouds' up directions in their local frames (estimateUpDirection() on the
   * refinement's cubes and samples); nothing where a cloud shows none. */
  const std::optional<Eigen::Vector3d>&
  sourceUp() const
  {
    return source_up_;
  }
  const std::optional<Eigen::Vector3d>&
  targetUp() const
  {
    return target_up_;
  }
  /** \brief The target local frame's axes in the target's input frame: input = centroid +
   * axes * local. Level axes (levelAxes(), third along targetUp()) where the parameters
   * level and the target is a 360-degree scan tilted by more than kLevelingDegrees, so that
   * the grids' z, along which the z-variance feature is taken, is up; the identity
   * otherwise. */
  const Eigen::Matrix3d&
  targetAxes() const
  {
    return target_axes_;
  }

  /** \brief Far-outlier warnings of the current clouds. */
  std::vector<std::string>
  warnings() const;

  const BackendFactory&
  backends() const
  {
    return backends_;
  }
  std::vector<StageTiming>
  backendProfile() const;
  void
  resetBackendProfile();

private:
  /** One pyramid level (voxel size levelResolution()): the target grid, the source
   * samples, one backend per slot. */
  struct Level {
    std::shared_ptr<const TargetGrid> grid;
    std::shared_ptr<const SourceSamples> samples;
    std::unique_ptr<backend::ScoringBackend> slots[2];
  };

  /** Resolves requested_ for the current target and marks what the change made stale. */
  void
  resolveParameters();
  /** The local clouds of the new clouds (on the threads), checked: false (with \a error)
   * for a resolution too fine for a cloud, too few usable points or no structure; the
   * far-outlier warnings. */
  bool
  prepareLocalClouds(bool new_target, bool new_source, std::string& error);
  /** Everything built from the new local clouds: the source's samples, the target's grids,
   * distributions and up direction (concurrent tasks), the target leveled where it applies,
   * and the samples handed to the levels' backends. */
  void
  buildFromLocalClouds(bool new_target, bool new_source);
  backend::ScoringBackend&
  backend(int level, int slot);
  void
  buildGrid(int level);
  /** Appends the tasks that build the target's distributions and grids, and with
   * \a estimate_up its up direction from the distributions' cubes. */
  void
  appendTargetTasks(std::vector<std::function<void()>>& tasks, bool estimate_up);
  /** Turns the target local frame level where the parameters ask for it and the target is
   * a tilted 360-degree scan, and rebuilds what was built in the old frame. A target that
   * turned would need more voxels than a grid holds stays as it was. */
  void
  levelTarget();
  /** The source's samples per level and its up direction, on up to \a threads threads. */
  void
  buildSourceSamples(int threads);
  FeatureBinning
  levelBinning(double level_resolution) const;
  /** The refinement's distributions of the target's \a cubes of \a min_points or more;
   * \a on_axes as TargetDistributions takes it. */
  std::unique_ptr<TargetDistributions>
  makeDistributions(const SourceSamples& cubes,
                    int min_points,
                    const TargetDistributions::AxesVisitor& on_axes = {}) const;

  Parameters requested_, parameters_;
  /** deriveResolution() of the target; 0 while not needed or without a target. */
  double derived_resolution_ = 0.0;
  PointView target_input_, source_input_;
  bool has_target_ = false, has_source_ = false;
  std::uint64_t target_revision_ = 0, source_revision_ = 0;
  bool search_only_ = false;
  bool target_dirty_ = true, source_dirty_ = true;
  LocalCloud target_, source_;
  std::string target_warning_, source_warning_;
  std::vector<Level> levels_;
  /** The source's samples per level (finest first), built with the source. */
  std::vector<std::shared_ptr<const SourceSamples>> source_levels_;
  std::unique_ptr<TargetDistributions> distributions_;
  /** Coarser refinement stages' distributions (stage 1 first), built on first use. */
  std::vector<std::unique_ptr<TargetDistributions>> coarser_distributions_;
  /** shiftedDistributions(), built on first use. */
  std::unique_ptr<TargetDistributions> shifted_distributions_;
  std::uint64_t preparations_ = 0;
  std::optional<Eigen::Vector3d> source_up_, target_up_;
  Eigen::Matrix3d target_axes_ = Eigen::Matrix3d::Identity();
  BackendFactory backends_;
};

} // namespace core
} // namespace pcl_mi
