/*
 * pcl_mi: template bodies of pcl::MutualInformationRegistration. They only adapt PCL
 * clouds to the non-templated core, where all the work happens.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl/common/transforms.h>
#include <pcl/console/print.h>
#include <pcl/search/kdtree.h>

#include <cmath>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>

namespace pcl_mi {
namespace detail {

/** \brief The points of \a cloud (those of \a indices, in their order, when not null) as
 * the core reads them: in place, kept alive by \a cloud, where every point is taken and
 * the point type holds x, y and z as three consecutive floats (as every PCL type does);
 * otherwise a copy. */
template <typename PointT>
PointView
pointsOf(const std::shared_ptr<const pcl::PointCloud<PointT>>& cloud, const pcl::Indices* indices)
{
  if (!cloud || cloud->empty())
    return {};
  using Coordinate = std::decay_t<decltype(std::declval<const PointT&>().x)>;
  if constexpr (std::is_same<Coordinate, float>::value) {
    const PointT& first = cloud->front();
    const auto* x = reinterpret_cast<const unsigned char*>(&first.x);
    if (!indices && reinterpret_cast<const unsigned char*>(&first.y) == x + sizeof(float) &&
        reinterpret_cast<const unsigned char*>(&first.z) == x + 2 * sizeof(float))
      return PointView(&first.x, sizeof(PointT), cloud->size(), cloud);
  }
  PointList points;
  const std::size_t n = indices ? indices->size() : cloud->size();
  points.reserve(n);
  for (std::size_t k = 0; k < n; ++k) {
    const PointT& p = (*cloud)[indices ? static_cast<std::size_t>((*indices)[k]) : k];
    points.emplace_back(p.x, p.y, p.z);
  }
  return ownedView(std::move(points));
}

/** \brief Largest coordinate magnitude a k-d tree query or point may have: FLANN's
 * squared distances overflow beyond it and its assertions abort the process. */
constexpr float kMaxSearchCoordinate = 1e15f;

template <typename PointT>
bool
isSearchable(const PointT& p)
{
  return std::abs(p.x) <= kMaxSearchCoordinate && std::abs(p.y) <= kMaxSearchCoordinate &&
         std::abs(p.z) <= kMaxSearchCoordinate; // false for NaN too
}

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
    if (!canSearch(point, k_indices, k_sqr_distances))
      return 0;
    return Base::nearestKSearch(point, k, k_indices, k_sqr_distances);
  }

  int
  radiusSearch(const PointT& point,
               double radius,
               pcl::Indices& k_indices,
               std::vector<float>& k_sqr_distances,
               unsigned int max_nn = 0) const override
  {
    if (!canSearch(point, k_indices, k_sqr_distances))
      return 0;
    return Base::radiusSearch(point, radius, k_indices, k_sqr_distances, max_nn);
  }

private:
  /** Builds the tree on first use; false (with empty results) when \a point cannot be
   * searched or the tree holds no point. */
  bool
  canSearch(const PointT& point, pcl::Indices& k_indices, std::vector<float>& k_sqr_distances) const
  {
    build();
    if (searchable_ > 0 && isSearchable(point))
      return true;
    k_indices.clear();
    k_sqr_distances.clear();
    return false;
  }

  /** Builds the tree over the searchable points (of indices_, when given). */
  void
  build() const
  {
    if (built_ || !this->input_)
      return;
    built_ = true;
    auto searchable = pcl::make_shared<pcl::Indices>();
    const std::size_t n = this->indices_ ? this->indices_->size() : this->input_->size();
    for (std::size_t k = 0; k < n; ++k) {
      const auto i = this->indices_ ? (*this->indices_)[k] : static_cast<pcl::index_t>(k);
      if (i >= 0 && static_cast<std::size_t>(i) < this->input_->size() &&
          isSearchable((*this->input_)[static_cast<std::size_t>(i)]))
        searchable->push_back(i);
    }
    searchable_ = searchable->size();
    if (searchable_ > 0)
      const_cast<LazyKdTree*>(this)->Base::setInputCloud(this->input_, searchable);
  }

  mutable bool built_ = false;
  mutable std::size_t searchable_ = 0;
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
  max_iterations_ = pcl_mi::kDefaultMaxIterations;
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
  handed_source_ = HandedCloud{};
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
  handed_target_ = HandedCloud{};
  updateTarget();
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::updateTarget()
{
  const HandedCloud current = identityOf(target_.get(), nullptr);
  if (current == handed_target_)
    return;
  core_.setTargetView(pcl_mi::detail::pointsOf(target_, nullptr));
  handed_target_ = current;
}

template <typename PointSource, typename PointTarget, typename Scalar>
std::string
MutualInformationRegistration<PointSource, PointTarget, Scalar>::updateSource()
{
  handed_source_ = HandedCloud{};
  // The base class's own (fake) indices take every point, in order.
  const pcl::Indices* indices = this->fake_indices_ ? nullptr : indices_.get();
  if (input_ && indices) {
    const std::string bad_index = indexError();
    if (!bad_index.empty())
      return bad_index;
  }
  core_.setSourceView(pcl_mi::detail::pointsOf(input_, indices));
  handed_source_ = identityOf(input_.get(), indices_.get());
  return {};
}

template <typename PointSource, typename PointTarget, typename Scalar>
std::string
MutualInformationRegistration<PointSource, PointTarget, Scalar>::indexError() const
{
  if (input_ && indices_)
    for (const auto i : *indices_)
      if (i < 0 || static_cast<std::size_t>(i) >= input_->size())
        return "index " + std::to_string(i) + " is out of range of the source's " +
               std::to_string(input_->size()) + " points (setIndices)";
  return {};
}

template <typename PointSource, typename PointTarget, typename Scalar>
std::string
MutualInformationRegistration<PointSource, PointTarget, Scalar>::inputError() const
{
  if (!target_)
    return "no target cloud was given (setInputTarget)";
  if (!input_)
    return "no source cloud was given (setInputSource)";
  // The base class's align() copies the source through the indices before anything else;
  // its own (fake) indices always fit the source.
  return this->fake_indices_ ? std::string() : indexError();
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::align(
    PointCloudSource& output, const Matrix4& guess)
{
  converged_ = false;
  nr_iterations_ = 0;
  result_ = pcl_mi::AlignmentResult();
  last_error_.clear();
  result_.transformation = guess.template cast<double>();
  final_transformation_ = transformation_ = previous_transformation_ = guess;
  const std::string refused = inputError();
  if (refused.empty()) {
    Base::align(output, guess);
    return;
  }
  result_.error = last_error_ = refused;
  PCL_ERROR("[pcl::%s::align] %s.\n", getClassName().c_str(), refused.c_str());
  output.clear();
}

template <typename PointSource, typename PointTarget, typename Scalar>
double
MutualInformationRegistration<PointSource, PointTarget, Scalar>::getFitnessScore(
    double max_range)
{
  if (!input_ || !target_ || input_->empty() || target_->empty()) {
    PCL_ERROR("[pcl::%s::getFitnessScore] needs a source and a target cloud.\n",
              getClassName().c_str());
    return std::numeric_limits<double>::max();
  }
  // The search tree is the base class's (built lazily); before the first align() it has
  // not been handed the target yet.
  if (tree_->getInputCloud() != target_)
    tree_->setInputCloud(target_);
  pcl::Indices nearest(1);
  std::vector<float> squared(1);
  double sum = 0.0;
  std::size_t pairs = 0;
  const Eigen::Transform<Scalar, 3, Eigen::Affine> pose(final_transformation_);
  for (const auto& p : *input_) {
    PointSource moved = p;
    moved.getVector3fMap() =
        (pose * p.getVector3fMap().template cast<Scalar>()).template cast<float>();
    if (!pcl_mi::detail::isSearchable(moved))
      continue;
    PointTarget query;
    query.x = moved.x;
    query.y = moved.y;
    query.z = moved.z;
    if (tree_->nearestKSearch(query, 1, nearest, squared) == 1 && squared[0] <= max_range) {
      sum += squared[0];
      ++pairs;
    }
  }
  return pairs > 0 ? sum / static_cast<double>(pairs) : std::numeric_limits<double>::max();
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::warnUnused(const char* setter,
                                                                           const char* instead)
{
  for (const std::string& done : warned_setters_)
    if (done == setter)
      return;
  warned_setters_.emplace_back(setter);
  PCL_WARN("[pcl::%s::%s] has no effect on MI registration; %s.\n", getClassName().c_str(),
           setter, instead);
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setMaxCorrespondenceDistance(
    double distance_threshold)
{
  Base::setMaxCorrespondenceDistance(distance_threshold);
  warnUnused("setMaxCorrespondenceDistance",
             "it has no correspondences: the scale is setResolution() (voxel size)");
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setTransformationEpsilon(
    double epsilon)
{
  Base::setTransformationEpsilon(epsilon);
  warnUnused("setTransformationEpsilon",
             "convergence is setTranslationTolerance() and setRotationTolerance()");
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setEuclideanFitnessEpsilon(
    double epsilon)
{
  Base::setEuclideanFitnessEpsilon(epsilon);
  warnUnused("setEuclideanFitnessEpsilon",
             "convergence is setTranslationTolerance() and setRotationTolerance()");
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::
    setRANSACOutlierRejectionThreshold(double inlier_threshold)
{
  Base::setRANSACOutlierRejectionThreshold(inlier_threshold);
  warnUnused("setRANSACOutlierRejectionThreshold", "it has no correspondences to reject");
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setRANSACIterations(
    int ransac_iterations)
{
  Base::setRANSACIterations(ransac_iterations);
  warnUnused("setRANSACIterations", "it has no correspondences to reject");
}

template <typename PointSource, typename PointTarget, typename Scalar>
bool
MutualInformationRegistration<PointSource, PointTarget, Scalar>::applyParameters(
    const pcl_mi::Parameters& parameters, const char* setter)
{
  // A derived resolution reads the target: one that grew or moved in memory since it was
  // set is handed over again first, so the view never points into freed storage. Without a
  // target there is nothing to read, and the resolution stays unknown.
  if (target_)
    updateTarget();
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
MutualInformationRegistration<PointSource, PointTarget, Scalar>::setFeatureBinning(
    pcl_mi::Feature feature, int num_bins, double max_value, double range_quantile)
{
  const pcl_mi::FeatureBinning binning{num_bins, max_value, range_quantile};
  setField("setFeatureBinning", &Params::grid,
           feature == pcl_mi::Feature::VarianceZ ? &Grid::variance_z_binning
                                                 : &Grid::point_count_binning,
           binning);
}

template <typename PointSource, typename PointTarget, typename Scalar>
double
MutualInformationRegistration<PointSource, PointTarget, Scalar>::evaluate(
    const Matrix4& pose)
{
  // Cost surfaces call this thousands of times: hand the source over only when it changed.
  updateTarget();
  std::string error;
  if (!(identityOf(input_.get(), indices_.get()) == handed_source_))
    error = updateSource();
  if (!error.empty()) {
    PCL_ERROR("[pcl::%s::evaluate] %s.\n", getClassName().c_str(), error.c_str());
    return -1.0;
  }
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

  // setMaximumIterations() is the base class's and cannot refuse a value: checked here.
  const std::string bad_cap = pcl_mi::maxIterationsError(max_iterations_);
  updateTarget();
  const std::string source_error = bad_cap.empty() ? updateSource() : std::string();
  if (!bad_cap.empty()) {
    result_.error = "invalid parameters: " + bad_cap + " (setMaximumIterations)";
  }
  else if (!source_error.empty()) {
    result_.error = source_error;
  }
  else {
    try {
      result_ = core_.align(guess.template cast<double>(), max_iterations_);
    }
    catch (const std::exception& e) {
      // Only resource exhaustion can throw here (std::bad_alloc); it must not escape.
      result_ = pcl_mi::AlignmentResult();
      result_.error = std::string("internal error: ") + e.what();
    }
  }
  for (const std::string& warning : result_.warnings)
    PCL_WARN("[pcl::%s::computeTransformation] %s.\n", getClassName().c_str(), warning.c_str());

  if (!core_.backendWarning().empty() && core_.backendWarning() != warned_) {
    warned_ = core_.backendWarning();
    PCL_WARN("[pcl::%s::computeTransformation] %s.\n", getClassName().c_str(), warned_.c_str());
  }
  if (!result_.error.empty()) {
    PCL_ERROR("[pcl::%s::computeTransformation] %s.\n",
              getClassName().c_str(),
              result_.error.c_str());
    final_transformation_ = guess;
    last_error_ = result_.error;
  }
  else {
    final_transformation_ = result_.transformation.template cast<Scalar>();
    converged_ = result_.converged;
    nr_iterations_ = result_.iterations;
    last_error_.clear();
    if (!converged_)
      last_error_ = "not converged: " +
                    pcl_mi::notConvergedCause(result_, max_iterations_,
                                              "setMaximumIterations(" +
                                                  std::to_string(max_iterations_) + ")") +
                    "; the final transformation is the best one found";
  }
  transformation_ = final_transformation_;
  previous_transformation_ = final_transformation_;
  // Like every PCL registration: output is the source under the final transformation.
  pcl::transformPointCloud(output, output, final_transformation_);
}

} // namespace pcl
