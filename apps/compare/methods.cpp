/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "compare/methods.h"

#include "mi_options.h"

#include <pcl_mi/io.h>
#include <pcl_mi/mutual_information_registration.h>

#include <pcl/filters/approximate_voxel_grid.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/registration/gicp.h>
#include <pcl/registration/ndt.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>

namespace pcl_mi {
namespace compare {

namespace {

/** gicp-coarse: voxel leaf (m) of both clouds and the correspondence distance (m). */
constexpr float kCoarseGicpLeaf = 0.25f;
constexpr double kCoarseGicpCorrespondence = 5.0;
/** gicp-fine: voxel leaf (m), correspondence distance (m) and iteration cap; its tolerances
 * are tight enough that only the cap or a zero step stops it. */
constexpr float kFineGicpLeaf = 0.2f;
constexpr double kFineGicpCorrespondence = 1.0;
constexpr int kFineGicpIterations = 200;
constexpr double kFineGicpTolerance = 1e-12;

/** Voxel leaf (m) a method filters both clouds with before registering, 0 for none. */
float
methodLeaf(const std::string& name)
{
  return name == "gicp-coarse" ? kCoarseGicpLeaf : name == "gicp-fine" ? kFineGicpLeaf : 0.0f;
}

/** Keeps one point (the centroid) per \a leaf cube. */
Cloud::Ptr
downsampled(const Cloud::Ptr& cloud, float leaf)
{
  Cloud::Ptr out(new Cloud);
  pcl::VoxelGrid<pcl::PointXYZ> filter;
  filter.setLeafSize(leaf, leaf, leaf);
  filter.setInputCloud(cloud);
  filter.filter(*out);
  return out;
}

} // namespace

/** Settings that use no knowledge of the true pose; docs/apps.md gives each one's settings and why. */
std::unique_ptr<pcl::Registration<pcl::PointXYZ, pcl::PointXYZ>>
makeMethod(const std::string& name, const MiArguments& mi_arguments)
{
  if (name.rfind("mi-", 0) == 0) { // mi-varz, mi-n, and the paper's search: mi-varz-paper
    auto mi = std::make_unique<pcl::MutualInformationRegistration<pcl::PointXYZ>>();
    const bool paper = name.size() > 6 && name.substr(name.size() - 6) == "-paper";
    const std::string feature = paper ? name.substr(3, name.size() - 9) : name.substr(3);
    if (feature != "varz" && feature != "n")
      return nullptr;
    pcl_mi::Parameters p = paper ? pcl_mi::Parameters::paper() : pcl_mi::Parameters();
    p.grid.feature = feature == "n" ? pcl_mi::Feature::PointCount : pcl_mi::Feature::VarianceZ;
    int max_iterations = mi->getMaximumIterations();
    if (!pcl_mi::apps::applyMiOptions(mi_arguments.argc, mi_arguments.argv, p, max_iterations)
             .empty())
      return nullptr;
    mi->setMaximumIterations(max_iterations);
    if (!mi->setParameters(p))
      return nullptr;
    return mi;
  }
  if (name == "gicp")
    return std::make_unique<pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ>>();
  if (name == "gicp-coarse") {
    // The configuration the small_gicp anchor is quoted with, in PCL's implementation: both
    // clouds on a 0.25 m voxel grid (see runMethod), 20 neighbours per covariance, a
    // generous 5 m correspondence distance (small_gicp defaults to 1 m).
    auto gicp =
        std::make_unique<pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ>>();
    gicp->setCorrespondenceRandomness(20);
    gicp->setMaxCorrespondenceDistance(kCoarseGicpCorrespondence);
    return gicp;
  }
  if (name == "gicp-fine") {
    // GICP run to its own optimum on near-full-resolution clouds: an accuracy reference for
    // a known basin (e.g. chained after MI, "mi-varz+gicp-fine"), far too slow otherwise.
    auto gicp =
        std::make_unique<pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ>>();
    gicp->setMaxCorrespondenceDistance(kFineGicpCorrespondence);
    gicp->setMaximumIterations(kFineGicpIterations);
    gicp->setTransformationEpsilon(kFineGicpTolerance);
    gicp->setEuclideanFitnessEpsilon(kFineGicpTolerance);
    gicp->setRotationEpsilon(kFineGicpTolerance);
    return gicp;
  }
  if (name == "ndt") {
    auto ndt = std::make_unique<pcl::NormalDistributionsTransform<pcl::PointXYZ, pcl::PointXYZ>>();
    ndt->setResolution(1.0f);
    ndt->setStepSize(0.1);
    // PCL 1.13 stops when the squared translation step <= epsilon: the tutorial's 0.01
    // would stop after one 0.1 m step.
    ndt->setTransformationEpsilon(1e-8);
    ndt->setMaximumIterations(35);
    return ndt;
  }
  return nullptr;
}

/** True for a method name or a chain of them ("A+B": B started from A's result). */
bool
knownMethod(const std::string& name, const MiArguments& mi)
{
  const auto plus = name.rfind('+');
  if (plus == std::string::npos)
    return makeMethod(name, mi) != nullptr;
  return knownMethod(name.substr(0, plus), mi) && makeMethod(name.substr(plus + 1), mi) != nullptr;
}

Row
runMethod(const std::string& chain,
          const Cloud::Ptr& source,
          const Cloud::Ptr& target,
          const Pair& pair,
          const MiArguments& mi,
          ReusedTargets* reused)
{
  // A chain "A+B" runs B from A's result; its time is the sum, its evaluations A's.
  const auto plus = chain.rfind('+');
  const std::string name = plus == std::string::npos ? chain : chain.substr(plus + 1);
  Pair start_pair = pair;
  Row previous;
  if (plus != std::string::npos) {
    previous = runMethod(chain.substr(0, plus), source, target, pair, mi);
    start_pair.guess = previous.estimate;
  }
  ReusedTargets::Entry* kept =
      reused && plus == std::string::npos && name.rfind("mi-", 0) == 0
          ? &reused->by_method[name]
          : nullptr;
  std::unique_ptr<pcl::Registration<pcl::PointXYZ, pcl::PointXYZ>> fresh;
  if (kept && !kept->registration)
    kept->registration = makeMethod(name, mi);
  else if (!kept)
    fresh = makeMethod(name, mi);
  pcl::Registration<pcl::PointXYZ, pcl::PointXYZ>* reg =
      kept ? kept->registration.get() : fresh.get();
  const auto start = std::chrono::steady_clock::now();
  Cloud::Ptr input = source, reference_cloud = target;
  if (methodLeaf(name) > 0.0f) {
    input = downsampled(source, methodLeaf(name));
    reference_cloud = downsampled(target, methodLeaf(name));
  }
  if (name == "ndt") { // the NDT tutorial registers a 0.2 m voxel-filtered source
    input.reset(new Cloud);
    pcl::ApproximateVoxelGrid<pcl::PointXYZ> filter;
    filter.setLeafSize(0.2f, 0.2f, 0.2f);
    filter.setInputCloud(source);
    filter.filter(*input);
  }
  reg->setInputSource(input);
  const bool new_target = !kept || kept->target != reference_cloud.get();
  if (new_target)
    reg->setInputTarget(reference_cloud);
  if (kept)
    kept->target = reference_cloud.get();
  Cloud aligned;
  reg->align(aligned, start_pair.guess.cast<float>());
  Row o;
  o.method = chain;
  o.seconds = previous.seconds +
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  o.estimate = reg->getFinalTransformation().cast<double>();
  o.reference = pair.reference;
  const auto e = pcl_mi::io::poseError(o.estimate, pair.reference);
  o.translation_error = e.translation;
  o.travel_error = travelFrameError(o.estimate, pair.reference);
  o.rotation_error = e.rotation_deg;
  o.converged = reg->hasConverged();
  if (kept)
    o.target_reuse = new_target ? Row::TargetReuse::kPrepared : Row::TargetReuse::kKept;
  o.evaluations = previous.evaluations;
  if (auto* mi = dynamic_cast<pcl::MutualInformationRegistration<pcl::PointXYZ>*>(reg)) {
    o.evaluations = mi->getNumberOfEvaluations();
    o.stages = mi->getLastResult().stages;
    const pcl_mi::Verification& v = mi->getVerification();
    o.confidence = v.confidence;
    // After the time is taken: the first getCovariance() refines the result once more.
    const Eigen::Matrix<double, 6, 6> covariance = mi->getCovariance();
    for (int i = 0; i < 6; ++i)
      o.sigma[i] = std::sqrt(covariance(i, i)) * (i < 3 ? 1.0 : 180.0 / M_PI);
    const int weaker = v.free_direction_contrast[1] < v.free_direction_contrast[0] ? 1 : 0;
    const double evidence[10] = {mi->getLastResult().search_converged ? 1.0 : 0.0,
                                 static_cast<double>(v.inliers),
                                 v.inlier_fraction,
                                 v.peak_contrast,
                                 v.weakest_contrast,
                                 v.normalized_mi,
                                 std::min(v.free_direction_contrast[0],
                                          v.free_direction_contrast[1]),
                                 v.lead,
                                 std::fmin(v.free_turn_mi_loss[0], v.free_turn_mi_loss[1]),
                                 v.observability_directions.col(weaker).tail<3>().norm()};
    std::copy(std::begin(evidence), std::end(evidence), std::begin(o.evidence));
    o.restart_turn_deg = v.restart_turn_deg;
    o.restart_shift = v.restart_shift;
    o.reverse_shift = v.reverse_shift;
    o.reverse_turn_deg = v.reverse_turn_deg;
    if (!o.converged) {
      o.refusal = apps::notConvergedKind(mi->getLastResult());
      o.reason = mi->getLastError();
    }
  }
  return o;
}

} // namespace compare
} // namespace pcl_mi
