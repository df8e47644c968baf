/*
 * pcl_mi: 3D scan alignment by maximising the mutual information of voxel features.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_mi/parameters.h>
#include <pcl_mi/types.h>

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

namespace pcl_mi {

/** \brief True when this build has the OpenCL backend and an OpenCL device (with double
 * support) is available; otherwise false and, in \a reason, why. */
bool
openClAvailable(std::string* reason = nullptr);

/** \brief Why \a result (of an align() that did not fail) is not converged: the reliability
 * test's reason, how the iteration cap \a max_iterations ended the search, named as the
 * caller sets it (\a cap_name, e.g. "setMaximumIterations(2000)"), or both, the test's
 * first; then, where the alignment of the clouds swapped was asked and did not confirm it,
 * why not (Verification::reverse_reason). Empty when it converged. */
std::string
notConvergedCause(const AlignmentResult& result, int max_iterations, const std::string& cap_name);


/** \brief Non-templated engine behind pcl::MutualInformationRegistration.
 *
 * Owns the point data (in a local frame centred on each cloud, so world offsets such as UTM
 * coordinates cost no precision), the target's voxel features and the scoring backends,
 * and runs the coarse-to-fine search and the refinement. It knows nothing of PCL point types. Not thread-safe: use one
 * instance per thread.
 */
class RegistrationCore {
public:
  RegistrationCore();
  ~RegistrationCore();
  RegistrationCore(RegistrationCore&&) noexcept;
  RegistrationCore&
  operator=(RegistrationCore&&) noexcept;
  RegistrationCore(const RegistrationCore&) = delete;
  RegistrationCore&
  operator=(const RegistrationCore&) = delete;

  /** \brief Replaces all parameters. Returns an empty string on success; otherwise the
   * reason, and the previous parameters are kept. */
  std::string
  setParameters(const Parameters& parameters);

  /** \brief The parameters as set: a resolution of 0 and translation steps in voxels
   * (negative) where the defaults follow the target. */
  const Parameters&
  parameters() const;

  /** \brief The parameters in use with the current target, derived values resolved
   * (Parameters::grid.resolution says how); a derived resolution is 0 until a target is
   * set. */
  const Parameters&
  effectiveParameters() const;

  /** \brief Sets the target points (non-finite points and points at exactly (0, 0, 0) are
   * skipped). Features are computed lazily, once per target and resolution/feature
   * change. */
  void
  setTarget(PointList points);

  /** \brief Sets the source points (skipped as for the target). */
  void
  setSource(PointList points);

  /** \brief Sets the target points without copying them: they are read through \a points
   * whenever the target is prepared (at the first align() or evaluate() after this call or
   * after a change of parameters) and, for a derived resolution, at once. Their memory must
   * stay valid until the next setTarget() or setTargetView() (the view's owner, when set,
   * keeps it); changes made to them after the target was prepared are not seen. */
  void
  setTargetView(PointView points);

  /** \brief Sets the source points without copying them, as setTargetView(). */
  void
  setSourceView(PointView points);

  /** A temporary list would be gone before it is read: setTarget() and setSource() keep one. */
  void
  setTargetView(PointList&&) = delete;
  void
  setSourceView(PointList&&) = delete;

  /** \brief Maximises the mutual information starting from \a guess (source to target),
   * with at most \a max_iterations Nelder-Mead iterations over every start and level. */
  AlignmentResult
  align(const Eigen::Matrix4d& guess, int max_iterations = kDefaultMaxIterations);

  /** \brief The factor, 1 or more, by which the last align()'s verification.covariance is
   * too small where its result depends on where the cells that summarise the clouds cut
   * their surfaces: the result is refined again on cells moved by half a cell, and the move
   * is weighed against both covariances (docs/method.md, "The verdict", covariance). Computed
   * on the first call after an align() (about a refinement and a preparation of the target's
   * cubes), or by align() for a result that passed its own tests on sparse evidence (step
   * 7), then kept. 1 where that covariance is zero, and where new clouds have been prepared
   * since (by evaluate()) or the grid, sampling, refinement or pinned parameters changed,
   * which leaves nothing to refine it on as it was found. */
  double
  covarianceScale() const;

  /** \brief Mutual information (nats) at \a pose (source to target), for cost surfaces and
   * tests. Returns a negative value and sets \a error if the inputs are unusable; returns 0
   * where the clouds do not overlap at \a pose. */
  double
  evaluate(const Eigen::Matrix4d& pose, std::string* error = nullptr);

  /** \brief Joint histogram at \a pose; false (and \a error) if the inputs are unusable. */
  bool
  jointHistogram(const Eigen::Matrix4d& pose,
                 JointHistogram& histogram,
                 std::string* error = nullptr);

  /** \brief Time per backend stage, summed over every evaluation since the target was set
   * or resetBackendProfile() (for OpenCL: kernel times from device events, plus host-side
   * allocation, copies and the program build). */
  std::vector<StageTiming>
  backendProfile() const;
  void
  resetBackendProfile();

  /** \brief The backend in use ("cpu" or "opencl (device name)"), known after the first
   * evaluate()/align() with the current target and parameters. */
  const std::string&
  backendName() const;

  /** \brief Non-empty when Backend::Auto fell back to the CPU: why. */
  const std::string&
  backendWarning() const;

  /** \brief Number of points dropped from the last target/source: non-finite, exactly at
   * (0, 0, 0) (the no-return marker of many drivers) or far outliers (isolated from the rest
   * of the cloud by a large empty gap). */
  std::size_t
  droppedTargetPoints() const;
  std::size_t
  droppedSourcePoints() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace pcl_mi
