/*
 * pcl_mi: 3D scan alignment by maximising the mutual information of voxel features.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_mi/registration_core.h>

#include <pcl/registration/registration.h>

#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace pcl {

/** \brief Registration by maximising the mutual information (MI) of voxel features.
 *
 * Implements Mehta, McBride and Pandey, "Robust and Fast 3D Scan Alignment using Mutual
 * Information": both clouds are put on one voxel grid (resolution R_v), every voxel gets a
 * feature (variance of z, or point count) or the "no feature" value when empty, and the MI
 * between the target's and the transformed source's features over the intersection of
 * their bounding boxes is maximised over [tx, ty, tz, roll, pitch, yaw] with Nelder-Mead,
 * starting from an anisotropic simplex around the guess.
 *
 * A drop-in replacement for pcl::GeneralizedIterativeClosestPoint or
 * pcl::NormalDistributionsTransform:
 * \code
 * pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
 * reg.setInputSource(source);
 * reg.setInputTarget(target);
 * pcl::PointCloud<pcl::PointXYZ> aligned;
 * reg.align(aligned, guess);
 * if (reg.hasConverged()) use(reg.getFinalTransformation());
 * \endcode
 *
 * hasConverged() is true only when the simplex shrank below the tolerances
 * (setTranslationTolerance(), setRotationTolerance()) and the result passed the
 * reliability test: enough source samples on the target's surfaces, no direction the
 * surfaces leave free, and getConfidence() >= 0.95 (docs/method.md, "The verdict").
 * Hitting the iteration cap (setMaximumIterations()), a failed test or any failure leaves
 * it false, with the reason in getLastError(). Failures are reported with PCL_ERROR; no
 * exception leaves align().
 *
 * Non-finite points, points at exactly (0, 0, 0) (many drivers' "no return") and far
 * outliers are skipped (docs/hardening.md).
 *
 * The clouds are read in place when an alignment needs them, not copied. A target changed
 * in place after an alignment prepared it is not seen until setInputTarget() hands it again;
 * one that grew or moved in memory is read again by itself.
 *
 * \note Not thread-safe; use one object per thread.
 */
template <typename PointSource, typename PointTarget = PointSource, typename Scalar = float>
class MutualInformationRegistration
: public Registration<PointSource, PointTarget, Scalar> {
public:
  using Base = Registration<PointSource, PointTarget, Scalar>;
  using typename Base::Matrix4;
  using typename Base::PointCloudSource;
  using PointCloudSourceConstPtr = typename PointCloudSource::ConstPtr;
  using typename Base::PointCloudTarget;
  using PointCloudTargetConstPtr = typename PointCloudTarget::ConstPtr;

  using Ptr = shared_ptr<MutualInformationRegistration<PointSource, PointTarget, Scalar>>;
  using ConstPtr =
      shared_ptr<const MutualInformationRegistration<PointSource, PointTarget, Scalar>>;
  using Vector6d = Eigen::Matrix<double, 6, 1>;

  /** \brief The defaults of pcl_mi::Parameters: voxels and translation steps derived from
   * the target's extent, VarianceZ, rotation steps [0.1, 0.1, 0.8 rad]. */
  MutualInformationRegistration();
  ~MutualInformationRegistration() override;

  /** \brief Aligns the source onto the target, starting from the identity. */
  void
  align(PointCloudSource& output)
  {
    align(output, Matrix4::Identity());
  }

  /** \brief Aligns the source onto the target, starting from \a guess (source to target).
   *
   * Every call starts from a clean result: where it cannot run (no source or target, an
   * index out of range of the source) hasConverged() is false, getFinalTransformation() is
   * \a guess and getLastError() says why, unlike pcl::Registration::align(), which returns
   * early and leaves the previous result in place. (Called through a pcl::Registration
   * reference, the base class's align() runs, with its behaviour.) */
  void
  align(PointCloudSource& output, const Matrix4& guess);

  /** \brief Mean squared distance from the source under getFinalTransformation() to the
   * nearest target point, over the pairs closer than \a max_range, as PCL's. Non-finite
   * points and points beyond 1e15 in any coordinate are left out of the search (FLANN
   * aborts on them); without a source or target, or with no pair in range, returns
   * std::numeric_limits<double>::max() (with PCL_ERROR for missing clouds). */
  double
  getFitnessScore(double max_range = std::numeric_limits<double>::max());
  using Base::getFitnessScore;

  using Base::getClassName;

  /** \name Inherited setters that MI registration does not use
   * It has no correspondences and no per-iteration transformation change to threshold. Each
   * stores its value like PCL's (the getters return it) and warns once per object, naming
   * what to use instead (README, "Migrating from GICP/NDT"). */
  ///@{
  /** \brief Not used: the scale is setResolution()'s. */
  void
  setMaxCorrespondenceDistance(double distance_threshold);
  /** \brief Not used: see setTranslationTolerance() and setRotationTolerance(). */
  void
  setTransformationEpsilon(double epsilon);
  /** \brief Not used: see setTranslationTolerance() and setRotationTolerance(). */
  void
  setEuclideanFitnessEpsilon(double epsilon);
  /** \brief Not used: there are no correspondences to reject. */
  void
  setRANSACOutlierRejectionThreshold(double inlier_threshold);
  /** \brief Not used: there are no correspondences to reject. */
  void
  setRANSACIterations(int ransac_iterations);
  ///@}

  /** \brief Source cloud (transformed onto the target). Honours setIndices(). */
  void
  setInputSource(const PointCloudSourceConstPtr& cloud) override;

  /** \brief Target cloud. Its voxel features are computed once, at the next align() or
   * evaluate(), and reused until the target or a grid parameter changes. */
  void
  setInputTarget(const PointCloudTargetConstPtr& cloud) override;

  /** \brief Voxel edge length R_v (> 0), or 0 (the default) to derive it from the target's
   * extent (pcl_mi::GridParameters::resolution). */
  void
  setResolution(double resolution)
  {
    setField("setResolution", &Params::grid, &Grid::resolution, resolution);
  }
  /** \brief The resolution in use: the one set, or the one derived from the target (0
   * until a target is set). */
  double
  getResolution() const
  {
    return core_.effectiveParameters().grid.resolution;
  }

  /** \brief Voxel feature (default pcl_mi::Feature::VarianceZ). */
  void
  setFeature(pcl_mi::Feature feature)
  {
    setField("setFeature", &Params::grid, &Grid::feature, feature);
  }
  pcl_mi::Feature
  getFeature() const
  {
    return core_.parameters().grid.feature;
  }

  /** \brief Histogram binning of \a feature: \a num_bins (1..255) equal bins over
   * [0, max_value), or, with \a range_quantile in (0, 1], over [0, that quantile of the
   * target's occupied voxels' values) per grid; see pcl_mi::FeatureBinning. A call without
   * \a range_quantile fixes the range. Defaults: VarianceZ 16 bins up to 1/12
   * (var(z) / R_v^2); PointCount 16 bins up to the upper quartile of the target's counts. */
  void
  setFeatureBinning(pcl_mi::Feature feature,
                    int num_bins,
                    double max_value,
                    double range_quantile = 0.0);
  pcl_mi::FeatureBinning
  getFeatureBinning(pcl_mi::Feature feature) const
  {
    return feature == pcl_mi::Feature::VarianceZ ? core_.parameters().grid.variance_z_binning
                                                 : core_.parameters().grid.point_count_binning;
  }

  /** \brief Initial simplex step per parameter [tx, ty, tz, roll, pitch, yaw (rad)];
   * translations in the clouds' units, or negative in voxels (default [-16, -16, -4, 0.1, 0.1,
   * 0.8]: 16, 16 and 4 voxels). A zero step keeps that parameter at the guess. */
  void
  setSimplexSteps(const Vector6d& steps)
  {
    setField("setSimplexSteps", &Params::search, &Search::simplex_steps, steps);
  }
  /** \brief The steps in use, translations in the clouds' units (steps in voxels wait for
   * the resolution: they stay negative until a target is set). */
  Vector6d
  getSimplexSteps() const
  {
    return core_.effectiveParameters().search.simplex_steps;
  }

  /** \brief Also search from the mirrored simplex (all steps negated), keeping the better
   * result (default true; the paper's search is false). */
  void
  setSymmetricStart(bool symmetric)
  {
    setField("setSymmetricStart", &Params::search, &Search::symmetric_start, symmetric);
  }
  bool
  getSymmetricStart() const
  {
    return core_.parameters().search.symmetric_start;
  }

  /** \brief Restarts around the best vertex on the finest searched level (default 0: the
   * refinement sharpens the optimum instead; without a refinement 2 lift the search out of
   * the grid's small local optima). */
  void
  setNumberOfRestarts(int restarts)
  {
    setField("setNumberOfRestarts", &Params::search, &Search::restarts, restarts);
  }
  int
  getNumberOfRestarts() const
  {
    return core_.parameters().search.restarts;
  }

  /** \brief Headings (yaw) the coarsest level starts from, spread evenly over 360 degrees
   * from the guess's (default 1). 4-8 where the heading of the guess may be off by more
   * than about 60 degrees (pcl_mi::SearchParameters::heading_starts). */
  void
  setNumberOfHeadingStarts(int headings)
  {
    setField("setNumberOfHeadingStarts", &Params::search, &Search::heading_starts, headings);
  }
  int
  getNumberOfHeadingStarts() const
  {
    return core_.parameters().search.heading_starts;
  }

  /** \brief Further starts of the coarsest level around the guess, half the x/y steps away
   * (default 0; narrow fields of view get setNarrowViewPositionStarts()'s without asking)
   * (pcl_mi::SearchParameters::position_starts). */
  void
  setNumberOfPositionStarts(int positions)
  {
    setField("setNumberOfPositionStarts", &Params::search, &Search::position_starts, positions);
  }
  int
  getNumberOfPositionStarts() const
  {
    return core_.parameters().search.position_starts;
  }

  /** \brief Position starts used instead of setNumberOfPositionStarts()'s, when more,
   * where either cloud covers less than 180 degrees of azimuth about its own origin: a
   * narrow field of view (default 8; 0 = never; pcl_mi::SearchParameters::
   * narrow_view_position_starts). getLastResult().position_starts says what was used. */
  void
  setNarrowViewPositionStarts(int positions)
  {
    setField("setNarrowViewPositionStarts", &Params::search,
             &Search::narrow_view_position_starts, positions);
  }
  int
  getNarrowViewPositionStarts() const
  {
    return core_.parameters().search.narrow_view_position_starts;
  }

  /** \brief Roll and pitch simplex steps (rad) used instead, when larger, where either cloud
   * has a narrow field of view; the search then also turns the source about its sensor
   * (default 0.35; 0 = never; pcl_mi::SearchParameters::narrow_view_tilt_step).
   * getLastResult().turned_about_sensor says what was used. */
  void
  setNarrowViewTiltStep(double step)
  {
    setField("setNarrowViewTiltStep", &Params::search, &Search::narrow_view_tilt_step, step);
  }
  double
  getNarrowViewTiltStep() const
  {
    return core_.parameters().search.narrow_view_tilt_step;
  }

  /** \brief Where either cloud has a narrow field of view, two more starts of the coarsest
   * level, turned from the guess by plus and minus this yaw (default 0.5 rad; 0 = none;
   * pcl_mi::SearchParameters::narrow_view_yaw_start). */
  void
  setNarrowViewYawStart(double yaw)
  {
    setField("setNarrowViewYawStart", &Params::search, &Search::narrow_view_yaw_start, yaw);
  }
  double
  getNarrowViewYawStart() const
  {
    return core_.parameters().search.narrow_view_yaw_start;
  }

  /** \brief Where either cloud has a narrow field of view, this many more starts of the
   * coarsest level at the turns about the sensor that score best on a grid of yaw, pitch
   * and, unless both clouds show the same up direction, roll (default 2; 0 = none;
   * pcl_mi::SearchParameters::narrow_view_scanned_starts). */
  void
  setNarrowViewScannedStarts(int starts)
  {
    setField("setNarrowViewScannedStarts", &Params::search, &Search::narrow_view_scanned_starts,
             starts);
  }
  int
  getNarrowViewScannedStarts() const
  {
    return core_.parameters().search.narrow_view_scanned_starts;
  }

  /** \brief Headings of the second, wider search that a 360-degree pair whose result the
   * verification does not trust gets (default 4; 0 = none;
   * pcl_mi::SearchParameters::second_search_headings). getLastResult().second_search says
   * whether it ran. */
  void
  setSecondSearchHeadings(int headings)
  {
    setField("setSecondSearchHeadings", &Params::search, &Search::second_search_headings,
             headings);
  }
  int
  getSecondSearchHeadings() const
  {
    return core_.parameters().search.second_search_headings;
  }

  /** \brief Where the verification does not trust the result, also search the target onto
   * the source, on what is left of the iteration cap, and keep one of that search's optima,
   * inverted, where it lies on surface the clouds share and the finest grid prefers it
   * (default true; pcl_mi::SearchParameters::reverse_search). getLastResult().reverse_search
   * and reverse_kept say whether it ran and whether one was kept. */
  void
  setReverseSearch(bool reverse)
  {
    setField("setReverseSearch", &Params::search, &Search::reverse_search, reverse);
  }
  bool
  getReverseSearch() const
  {
    return core_.parameters().search.reverse_search;
  }

  /** \brief Search a 360-degree pair along the target's up direction (from its horizontal
   * surfaces), starting from the guess turned so that the two clouds' ups agree where they
   * disagree by more than 5 degrees (a sensor carried tilted), and from the guess itself
   * where they agree on an up more than 5 degrees from z (a sensor mounted tilted) (default
   * true; pcl_mi::SearchParameters::leveling). getLastResult().leveled says whether it did. */
  void
  setLeveling(bool leveling)
  {
    setField("setLeveling", &Params::search, &Search::leveling, leveling);
  }
  bool
  getLeveling() const
  {
    return core_.parameters().search.leveling;
  }

  /** \brief Search the coarsest pyramid level on normalised MI, which the overlap a far
   * search moves through does not bias (default true;
   * pcl_mi::SearchParameters::coarse_normalized_mi). */
  void
  setCoarseNormalizedMI(bool normalized)
  {
    setField("setCoarseNormalizedMI", &Params::search, &Search::coarse_normalized_mi,
             normalized);
  }
  bool
  getCoarseNormalizedMI() const
  {
    return core_.parameters().search.coarse_normalized_mi;
  }

  /** \brief Convergence: every simplex vertex within \a tolerance (the clouds' units) of
   * the best one in each translation parameter; 0 (default) = 0.005 * resolution. */
  void
  setTranslationTolerance(double tolerance)
  {
    setField("setTranslationTolerance", &Params::search, &Search::translation_tolerance, tolerance);
  }
  /** \brief The translation tolerance in use (0.005 voxels unless set). */
  double
  getTranslationTolerance() const
  {
    return core_.effectiveParameters().effectiveTranslationTolerance();
  }

  /** \brief Convergence: every simplex vertex within \a tolerance radians of the best one in
   * each rotation parameter (default 0.0005 rad). */
  void
  setRotationTolerance(double tolerance)
  {
    setField("setRotationTolerance", &Params::search, &Search::rotation_tolerance, tolerance);
  }
  double
  getRotationTolerance() const
  {
    return core_.parameters().search.rotation_tolerance;
  }

  /** \brief Where the cost evaluations run: Backend::Cpu (default), Backend::OpenCL (an
   * error at align() if no OpenCL device is usable) or Backend::Auto (OpenCL on a GPU or
   * accelerator when every point enters each evaluation, where it is faster; otherwise the
   * CPU; the CPU with a PCL_WARN if no OpenCL device is usable). All give the same result. */
  void
  setBackend(pcl_mi::Backend backend)
  {
    setField("setBackend", &Params::backend, &Devices::type, backend);
  }
  pcl_mi::Backend
  getBackend() const
  {
    return core_.parameters().backend.type;
  }

  /** \brief Time every OpenCL command with device events for getBackendProfile()
   * (pcl_mi::BackendParameters::profile_device; default false: it slows evaluations down). */
  void
  setDeviceProfiling(bool enabled)
  {
    setField("setDeviceProfiling", &Params::backend, &Devices::profile_device, enabled);
  }
  bool
  getDeviceProfiling() const
  {
    return core_.parameters().backend.profile_device;
  }

  /** \brief How the search hands poses to the OpenCL backend: Batching::Auto (default:
   * in batches on a GPU, one at a time on a CPU device), On or Off. The result is the same
   * in every mode (pcl_mi::BackendParameters::batching). */
  void
  setBatching(pcl_mi::Batching batching)
  {
    setField("setBatching", &Params::backend, &Devices::batching, batching);
  }
  pcl_mi::Batching
  getBatching() const
  {
    return core_.parameters().backend.batching;
  }

  /** \brief Per-stage time of the backend since the target was set (see
   * pcl_mi::RegistrationCore::backendProfile()). OpenCL kernel times need
   * setDeviceProfiling(true) first. */
  std::vector<pcl_mi::StageTiming>
  getBackendProfile() const
  {
    return core_.backendProfile();
  }

  /** \brief Refinement after the MI search (pcl_mi::RefinementParameters::method). */
  void
  setRefinement(pcl_mi::Refinement refinement)
  {
    setField("setRefinement", &Params::refinement, &Refine::method, refinement);
  }
  pcl_mi::Refinement
  getRefinement() const
  {
    return core_.parameters().refinement.method;
  }

  /** \brief Cube edge of the refinement's target distributions (the clouds' units);
   * 0 (default) = 0.7 * resolution. */
  void
  setRefinementResolution(double resolution)
  {
    setField("setRefinementResolution", &Params::refinement, &Refine::resolution, resolution);
  }
  /** \brief The refinement cube edge in use (0.7 voxels unless set). */
  double
  getRefinementResolution() const
  {
    return core_.effectiveParameters().effectiveRefinementResolution();
  }

  /** \brief Where either cloud has a narrow field of view, this many coarser refinement
   * stages before the finest, on cubes 2, 4, ... times larger (default 2; 0 = none;
   * pcl_mi::RefinementParameters::narrow_view_stages). */
  void
  setNarrowViewRefinementStages(int stages)
  {
    setField("setNarrowViewRefinementStages", &Params::refinement, &Refine::narrow_view_stages,
             stages);
  }
  int
  getNarrowViewRefinementStages() const
  {
    return core_.parameters().refinement.narrow_view_stages;
  }

  /** \brief Replaces all parameters at once; refused (PCL_ERROR, old values kept) if any is
   * invalid. The iteration cap stays setMaximumIterations()'s. */
  bool
  setParameters(const pcl_mi::Parameters& parameters)
  {
    return applyParameters(parameters, "setParameters");
  }
  /** \brief All parameters as set (the iteration cap is getMaximumIterations()'s). */
  const pcl_mi::Parameters&
  getParameters() const
  {
    return core_.parameters();
  }
  /** \brief All parameters in use with the current target: derived values resolved. */
  const pcl_mi::Parameters&
  getEffectiveParameters() const
  {
    return core_.effectiveParameters();
  }

  /** \brief Nelder-Mead iterations of the last align() (as NDT's getFinalNumIteration()). */
  int
  getFinalNumIteration() const
  {
    return nr_iterations_;
  }

  /** \brief Mutual information (nats) at the final transformation of the last align(). */
  double
  getFinalMutualInformation() const
  {
    return result_.mutual_information;
  }

  /** \brief Cost evaluations (MI computations) of the last align(). */
  int
  getNumberOfEvaluations() const
  { return result_.evaluations; }

  /** \brief Gauss-Newton iterations of the last refinement (0: off or discarded). */
  int
  getNumberOfRefinementIterations() const
  {
    return result_.refinement_iterations;
  }

  /** \brief Everything the last align() reported: pose, counts, error, stage timings. */
  const pcl_mi::AlignmentResult&
  getLastResult() const
  {
    return result_;
  }

  /** \brief Probability (0 to 1) that the last result is within 0.5 m and 2 degrees of the
   * true pose, from the evidence at the result, calibrated on real scans of several sensors
   * (docs/method.md, "The verdict"); 0 after a failure. hasConverged() requires at least
   * 0.95. A result the verdict refuses for another reason (a free direction, a capped
   * search) keeps it, unless restarts of the refinement around it end apart
   * (Verification::restart_turn_deg): then it is the share of such results that were
   * right. A result that passed its own tests on sparse evidence (under 60 inliers) takes
   * it times the chance that getCovariance() gives it to lie within the bound; where that
   * holds it back, the clouds swapped are asked, and it is the share of the results they
   * confirmed, or did not, that were right (Verification::reverse_confirmed). Read it
   * together with hasConverged(). */
  double
  getConfidence() const
  {
    return result_.verification.confidence;
  }

  /** \brief Covariance of the last result's error as a left increment [tx, ty, tz, roll,
   * pitch, yaw] (m, rad) in the target frame, rotations about its origin: the true pose is
   * about exp(increment) * getFinalTransformation(). Zero when the result is degenerate.
   * It is getVerification().covariance times core().covarianceScale(), which the first
   * call after an align() computes (a refinement on cells moved by half a cell), or align()
   * itself for a result that passed its own tests on sparse evidence. */
  Eigen::Matrix<double, 6, 6>
  getCovariance() const
  {
    const Eigen::Matrix<double, 6, 6>& covariance = result_.verification.covariance;
    return covariance.isZero() ? covariance : core_.covarianceScale() * covariance;
  }

  /** \brief The evidence behind the verdict: inliers, contrast, observability per direction
   * (getLastResult().verification). */
  const pcl_mi::Verification&
  getVerification() const
  {
    return result_.verification;
  }

  /** \brief Why the last align() failed (the pose stays the guess) or did not converge
   * (the search hit the iteration cap, or the result failed the reliability test; the pose
   * is the best found). getLastResult().error: failures. */
  const std::string&
  getLastError() const
  {
    return last_error_;
  }

  /** \brief Mutual information (nats) at \a pose (source to target), e.g. for cost
   * surfaces: 0 without overlap, negative (with PCL_ERROR) for unusable inputs. The source
   * is converted once per cloud and indices object: call setInputSource() after an edit. */
  double
  evaluate(const Matrix4& pose);

  /** \brief The engine, read-only: backend name and warning, dropped points. */
  const pcl_mi::RegistrationCore&
  core() const
  {
    return core_;
  }

protected:
  using Base::converged_;
  using Base::final_transformation_;
  using Base::indices_;
  using Base::input_;
  using Base::max_iterations_;
  using Base::nr_iterations_;
  using Base::previous_transformation_;
  using Base::reg_name_;
  using Base::source_cloud_updated_;
  using Base::target_cloud_updated_;
  using Base::target_;
  using Base::transformation_;
  using Base::tree_;

  void
  computeTransformation(PointCloudSource& output, const Matrix4& guess) override;

private:
  /** PCL_WARN, once per object and \a setter, that \a setter has no effect here. */
  void
  warnUnused(const char* setter, const char* instead);

  /** Applies \a parameters, or reports \a setter's refusal and keeps the old ones. */
  bool
  applyParameters(const pcl_mi::Parameters& parameters, const char* setter);

  using Params = pcl_mi::Parameters;
  using Grid = pcl_mi::GridParameters;
  using Search = pcl_mi::SearchParameters;
  using Refine = pcl_mi::RefinementParameters;
  using Devices = pcl_mi::BackendParameters;
  /** Sets one field of one parameter group through applyParameters(). */
  template <typename Group, typename Field, typename Value>
  void
  setField(const char* setter, Group Params::*group, Field Group::*field, const Value& value)
  {
    pcl_mi::Parameters p = core_.parameters();
    (p.*group).*field = value;
    applyParameters(p, setter);
  }

  /** Hands the source points selected by indices_ (all when unset) to the core. Done at
   * every align() because PCL lets indices change between calls without notice. Returns
   * why not when an index is out of range of the source (nothing is handed over then). */
  std::string
  updateSource();

  /** The first index of indices_ out of range of the source, as an error; empty when all
   * fit (or there is no source or no indices). */
  std::string
  indexError() const;

  /** Why align() cannot run with the inputs as they are (no target, no source, an index
   * out of range); empty when it can. */
  std::string
  inputError() const;

  /** Hands target_ to the core where it is not the cloud last handed over (setInputTarget()
   * hands it at once; a cloud grown or reallocated in place since is handed again). */
  void
  updateTarget();

  /** Identity of a cloud last handed to the core: the cloud, its points' memory and count,
   * and the indices taken (with their count). The core reads a cloud in place, so a cloud
   * whose memory moved or whose size changed is handed over again before the core can read
   * it. */
  struct HandedCloud {
    const void* cloud = nullptr;
    const void* points = nullptr;
    std::size_t points_size = 0;
    const void* indices = nullptr;
    std::size_t size = 0;
    bool
    operator==(const HandedCloud& o) const
    {
      return cloud == o.cloud && points == o.points && points_size == o.points_size &&
             indices == o.indices && size == o.size && cloud;
    }
  };
  /** The identity of \a cloud with \a indices (null for all points). */
  template <typename Cloud>
  static HandedCloud
  identityOf(const Cloud* cloud, const pcl::Indices* indices)
  {
    if (!cloud)
      return {};
    return {cloud, cloud->points.data(), cloud->size(), indices, indices ? indices->size() : 0};
  }

  pcl_mi::RegistrationCore core_;
  pcl_mi::AlignmentResult result_;
  std::string last_error_; // see getLastError()
  std::string warned_; // the backend warning already printed
  std::vector<std::string> warned_setters_; // inherited setters already warned about
  HandedCloud handed_source_;
  HandedCloud handed_target_;
};

} // namespace pcl

#include <pcl_mi/impl/mutual_information_registration.hpp>

#ifndef PCL_MI_NO_PRECOMPILE
#include <pcl_mi/build_config.h>
// The precompiled instantiations serve only code with the library's Eigen alignment; with
// other flags (e.g. -march=native) the layout differs and the templates compile here.
#if EIGEN_MAX_STATIC_ALIGN_BYTES == PCL_MI_EIGEN_MAX_STATIC_ALIGN_BYTES
#include <pcl/point_types.h>
extern template class pcl::MutualInformationRegistration<pcl::PointXYZ>;
extern template class pcl::MutualInformationRegistration<pcl::PointXYZI>;
#endif
#endif
