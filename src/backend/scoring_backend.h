/*
 * pcl_mi: the one interface every compute backend implements: "score this pose".
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "features/source_samples.h"
#include "features/voxel_grid.h"

#include <pcl_mi/types.h>

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

namespace pcl_mi {
namespace backend {

/** \brief Computes the joint feature histogram of the target grid and the transformed
 * source over their overlap. Everything else (MI, search) is backend-independent. */
class ScoringBackend {
public:
  virtual ~ScoringBackend() = default;

  /** \brief Backend name for messages and profiling ("cpu", ...). */
  virtual const char*
  name() const = 0;

  /** \brief The target grid the next histograms are computed against. */
  virtual void
  setTarget(std::shared_ptr<const core::TargetGrid> target) = 0;

  /** \brief The source, as weighted samples in the source's local frame. */
  virtual void
  setSource(std::shared_ptr<const core::SourceSamples> source) = 0;

  /** \brief Joint histogram over the overlap of the target grid's bounding box and the
   * source transformed by (rotation, translation) into the target's local frame. An empty
   * overlap gives overlap_voxels == 0. */
  virtual void
  jointHistogram(const Eigen::Matrix3f& rotation,
                 const Eigen::Vector3f& translation,
                 JointHistogram& histogram) = 0;

  /** \brief jointHistogram() of each of \a rotations[i], \a translations[i] into
   * \a histograms[i] (resized to match). A backend that prefersBatches() computes them in
   * one round trip; by default, one call each. */
  virtual void
  jointHistograms(const std::vector<Eigen::Matrix3f>& rotations,
                  const std::vector<Eigen::Vector3f>& translations,
                  std::vector<JointHistogram>& histograms)
  {
    histograms.resize(rotations.size());
    for (std::size_t i = 0; i < rotations.size(); ++i)
      jointHistogram(rotations[i], translations[i], histograms[i]);
  }

  /** \brief True when a batch of poses costs about as much as one (a device round trip
   * dominates): the search then evaluates speculatively in batches. */
  virtual bool
  prefersBatches() const
  {
    return false;
  }

  /** \brief Adds this backend's stage timings since the last reset to \a stages (stages of
   * the same name are summed). */
  virtual void
  appendProfile(std::vector<StageTiming>& stages) const = 0;

  /** \brief Forgets the stage timings. */
  virtual void
  resetProfile() = 0;
};

/** \brief The entry of \a stages called \a name, appended with no calls if absent: the
 * backends sum their timings per stage name. */
inline StageTiming&
stageNamed(std::vector<StageTiming>& stages, const std::string& name)
{
  for (StageTiming& s : stages)
    if (s.name == name)
      return s;
  stages.push_back({name, 0, 0.0});
  return stages.back();
}

/** \brief The reference CPU backend. */
std::unique_ptr<ScoringBackend>
makeCpuBackend();

} // namespace backend
} // namespace pcl_mi
