/*
 * pcl_mi: the search's cost on a prepared problem: minus the MI of the pose a search
 * vector stands for.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "engine/prepared_problem.h"
#include "engine/search_space.h"
#include "features/mutual_information.h"
#include "search/coarse_to_fine.h"

#include <Eigen/Core>

#include <vector>

namespace pcl_mi {
namespace core {

/** \brief The search's cost: minus the MI of the pose a search vector stands for, or minus
 * its normalised MI on \a normalized_level (-1: none). */
class MutualInformationCosts final : public LevelCosts {
public:
  MutualInformationCosts(PreparedProblem& problem,
                         const SearchSpace& space,
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
      LevelCosts::costs(level, slot, xs, values);
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
    return level == normalized_level_ ? normalizedMutualInformation(histogram)
                                      : mutualInformation(histogram);
  }

  PreparedProblem& problem_;
  const SearchSpace& space_;
  int normalized_level_;
  bool prefers_batches_;
  // One per slot: the two may run concurrently.
  JointHistogram histograms_[2];
  std::vector<JointHistogram> batch_histograms_[2];
};

} // namespace core
} // namespace pcl_mi
