/*
 * pcl_mi: template bodies of pcl::MutualInformationRegistration. They only adapt PCL
 * clouds to the non-templated core, where all the work happens.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl/common/transforms.h>
#include <pcl/console/print.h>
#include <pcl/search/kdtree.h>

namespace pcl_mi {
namespace detail {

/** \brief A k-d tree that is built on its first query instead of in setInputCloud().
 *
 * pcl::Registration::align() hands every new target to its search tree, but the MI
 * registration never searches it: only getFitnessScore() does. Building a FLANN tree over
 * a 120k-point scan costs about as much as a whole alignment, so it is deferred until
 * someone asks. Not safe for concurrent first queries (neither is the base class). */
template <typename PointT>
class LazyKdTree : public pcl::search::KdTree<PointT> {
public:
  using Base = pcl::search::KdTree<PointT>;
  using typename Base::IndicesConstPtr;
  using typename Base::PointCloudConstPtr;
  using Base::nearestKSearch;
  using Base::radiusSearch;

  void
  setInputCloud(const PointCloudConstPtr& cloud,
                const IndicesConstPtr& indices = IndicesConstPtr()) override
  {
    this->input_ = cloud;
    this->indices_ = indices;
    built_ = false;
  }

  int
  nearestKSearch(const PointT& point,
                 int k,
                 pcl::Indices& k_indices,
                 std::vector<float>& k_sqr_distances) const override
  {
    build();
    return Base::nearestKSearch(point, k, k_indices, k_sqr_distances);
  }

  int
  radiusSearch(const PointT& point,
               double radius,
               pcl::Indices& k_indices,
               std::vector<float>& k_sqr_distances,
               unsigned int max_nn = 0) const override
  {
    build();
    return Base::radiusSearch(point, radius, k_indices, k_sqr_distances, max_nn);
  }

private:
  void
  build() const
  {
    if (built_ || !this->input_)
      return;
    const_cast<LazyKdTree*>(this)->Base::setInputCloud(this->input_, this->indices_);
    built_ = true;
  }

  mutable bool built_ = false;
};

} // namespace detail
} // namespace pcl_mi

namespace pcl {

template <typename PointSource, typename PointTarget, typename Scalar>
MutualInformationRegistration<PointSource, PointTarget, Scalar>::
    MutualInformationRegistration()
{
  reg_name_ = "MutualInformationRegistration";
  // align() would otherwise build a k-d tree over every new target that MI never uses.
  tree_.reset(new pcl_mi::detail::LazyKdTree<PointTarget>);
  max_iterations_ = core_.parameters().max_iterations;
}

template <typename PointSource, typename PointTarget, typename Scalar>
MutualInformationRegistration<PointSource, PointTarget, Scalar>::
    ~MutualInformationRegistration() = default;

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setInputSource(
    const PointCloudSourceConstPtr& cloud)
{
  // PCL's base class dereferences a null cloud and ignores an empty one, so that align()
  // would silently reuse the previous source. Keep it instead; align() then says why it
  // cannot run.
  if (!cloud || cloud->empty()) {
    PCLBase<PointSource>::setInputCloud(cloud);
    source_cloud_updated_ = true;
  }
  else {
    Base::setInputSource(cloud);
  }
  converged_ = false;
  converted_source_ = ConvertedSource{};
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setInputTarget(
    const PointCloudTargetConstPtr& cloud)
{
  if (!cloud || cloud->empty()) { // see setInputSource()
    target_ = cloud;
    target_cloud_updated_ = true;
  }
  else {
    Base::setInputTarget(cloud);
  }
  converged_ = false;
  pcl_mi::PointList points;
  if (cloud) {
    points.reserve(cloud->size());
    for (const auto& p : *cloud)
      points.emplace_back(p.x, p.y, p.z);
  }
  core_.setTarget(std::move(points));
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::updateSource()
{
  converted_source_ = {input_.get(), indices_.get(), indices_ ? indices_->size() : 0};
  pcl_mi::PointList points;
  if (input_) {
    if (indices_) {
      points.reserve(indices_->size());
      for (const auto i : *indices_) {
        const PointSource& p = (*input_)[i];
        points.emplace_back(p.x, p.y, p.z);
      }
    }
    else {
      points.reserve(input_->size());
      for (const auto& p : *input_)
        points.emplace_back(p.x, p.y, p.z);
    }
  }
  core_.setSource(std::move(points));
}

template <typename PointSource, typename PointTarget, typename Scalar>
bool
MutualInformationRegistration<PointSource, PointTarget, Scalar>::applyParameters(
    const pcl_mi::Parameters& parameters, const char* setter)
{
  const std::string error = core_.setParameters(parameters);
  if (!error.empty()) {
    PCL_ERROR("[pcl::%s::%s] %s; keeping the previous value.\n",
              getClassName().c_str(),
              setter,
              error.c_str());
    return false;
  }
  return true;
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setResolution(
    double resolution)
{
  updateParameters("setResolution", [&](pcl_mi::Parameters& p) { p.resolution = resolution; });
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setFeature(
    pcl_mi::Feature feature)
{
  updateParameters("setFeature", [&](pcl_mi::Parameters& p) { p.feature = feature; });
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setFeatureBinning(
    pcl_mi::Feature feature, int num_bins, double max_value, double range_quantile)
{
  updateParameters("setFeatureBinning", [&](pcl_mi::Parameters& p) {
    pcl_mi::FeatureBinning& b = feature == pcl_mi::Feature::VarianceZ ? p.variance_z_binning
                                                                      : p.point_count_binning;
    b.num_bins = num_bins;
    b.max_value = max_value;
    b.range_quantile = range_quantile;
  });
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setSimplexSteps(
    const Vector6d& steps)
{
  updateParameters("setSimplexSteps", [&](pcl_mi::Parameters& p) { p.simplex_steps = steps; });
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setSymmetricStart(
    bool symmetric)
{
  updateParameters("setSymmetricStart", [&](pcl_mi::Parameters& p) { p.symmetric_start = symmetric; });
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setNumberOfRestarts(
    int restarts)
{
  updateParameters("setNumberOfRestarts", [&](pcl_mi::Parameters& p) { p.restarts = restarts; });
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setNumberOfHeadingStarts(
    int headings)
{
  updateParameters("setNumberOfHeadingStarts",
                   [&](pcl_mi::Parameters& p) { p.heading_starts = headings; });
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setNumberOfPositionStarts(
    int positions)
{
  updateParameters("setNumberOfPositionStarts",
                   [&](pcl_mi::Parameters& p) { p.position_starts = positions; });
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setNarrowViewPositionStarts(
    int positions)
{
  updateParameters("setNarrowViewPositionStarts",
                   [&](pcl_mi::Parameters& p) { p.narrow_view_position_starts = positions; });
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setBackend(
    pcl_mi::Backend backend)
{
  updateParameters("setBackend", [&](pcl_mi::Parameters& p) { p.backend = backend; });
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setDeviceProfiling(
    bool enabled)
{
  updateParameters("setDeviceProfiling",
                   [&](pcl_mi::Parameters& p) { p.profile_device = enabled; });
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setRefinement(
    pcl_mi::Refinement refinement)
{
  updateParameters("setRefinement", [&](pcl_mi::Parameters& p) { p.refinement = refinement; });
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setRefinementResolution(
    double resolution)
{
  updateParameters("setRefinementResolution",
                   [&](pcl_mi::Parameters& p) { p.refinement_resolution = resolution; });
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setTranslationTolerance(
    double tolerance)
{
  updateParameters("setTranslationTolerance",
                   [&](pcl_mi::Parameters& p) { p.translation_tolerance = tolerance; });
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setRotationTolerance(
    double tolerance)
{
  updateParameters("setRotationTolerance", [&](pcl_mi::Parameters& p) { p.rotation_tolerance = tolerance; });
}

template <typename PointSource, typename PointTarget, typename Scalar>
bool
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setParameters(
    const pcl_mi::Parameters& parameters)
{
  if (!applyParameters(parameters, "setParameters"))
    return false;
  max_iterations_ = parameters.max_iterations;
  return true;
}

template <typename PointSource, typename PointTarget, typename Scalar>
pcl_mi::Parameters
MutualInformationRegistration<PointSource, PointTarget, Scalar>::getParameters() const
{
  pcl_mi::Parameters p = core_.parameters();
  // The base class's setMaximumIterations() writes max_iterations_ directly.
  p.max_iterations = max_iterations_;
  return p;
}

template <typename PointSource, typename PointTarget, typename Scalar>
double
MutualInformationRegistration<PointSource, PointTarget, Scalar>::evaluate(
    const Matrix4& pose)
{
  // Cost surfaces call this thousands of times: convert the source only when it changed.
  const ConvertedSource current{input_.get(), indices_.get(), indices_ ? indices_->size() : 0};
  if (!(current == converted_source_))
    updateSource();
  std::string error;
  const double mi = core_.evaluate(pose.template cast<double>(), &error);
  if (!error.empty())
    PCL_ERROR("[pcl::%s::evaluate] %s.\n", getClassName().c_str(), error.c_str());
  return mi;
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::computeTransformation(
    PointCloudSource& output, const Matrix4& guess)
{
  converged_ = false;
  nr_iterations_ = 0;
  result_ = pcl_mi::AlignmentResult();
  final_transformation_ = guess;

  if (!applyParameters(getParameters(), "computeTransformation")) {
    result_.error = "invalid parameters";
  }
  else {
    updateSource();
    try {
      result_ = core_.align(guess.template cast<double>());
    }
    catch (const std::exception& e) {
      // Only resource exhaustion can throw here (std::bad_alloc); it must not escape.
      result_ = pcl_mi::AlignmentResult();
      result_.error = std::string("internal error: ") + e.what();
    }
  }

  if (!core_.backendWarning().empty() && core_.backendWarning() != warned_) {
    warned_ = core_.backendWarning();
    PCL_WARN("[pcl::%s::computeTransformation] %s.\n", getClassName().c_str(), warned_.c_str());
  }
  if (!result_.error.empty()) {
    PCL_ERROR("[pcl::%s::computeTransformation] %s.\n",
              getClassName().c_str(),
              result_.error.c_str());
    final_transformation_ = guess;
  }
  else {
    final_transformation_ = result_.transformation.template cast<Scalar>();
    converged_ = result_.converged;
    nr_iterations_ = result_.iterations;
  }
  transformation_ = final_transformation_;
  previous_transformation_ = final_transformation_;
  // Like every PCL registration: output is the source under the final transformation.
  pcl::transformPointCloud(output, output, final_transformation_);
}

} // namespace pcl
