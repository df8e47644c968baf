/*
 * pcl_mi: entropies and mutual information from integer histograms.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_mi/types.h>

#include <cstdint>
#include <vector>

namespace pcl_mi {
namespace core {

/** \brief Shannon entropy (nats) of the distribution given by integer \a counts. 0 for an
 * empty histogram. */
double
entropy(const std::vector<std::uint64_t>& counts);

/** \brief Entropies of a joint histogram: H(X) (target), H(Y) (source), H(X,Y). */
struct Entropies {
  double target = 0.0;
  double source = 0.0;
  double joint = 0.0;

  /** MI = H(X) + H(Y) - H(X,Y) (the paper's equation). */
  double
  mutualInformation() const
  {
    return target + source - joint;
  }
};

/** \brief Marginal and joint entropies of \a histogram. */
Entropies
entropies(const JointHistogram& histogram);

/** \brief Mutual information (nats) of \a histogram; 0 when it is empty. */
double
mutualInformation(const JointHistogram& histogram);

/** \brief Studholme's normalised mutual information (H(X) + H(Y)) / H(X,Y) of
 * \a histogram: 1 for independent features, 2 for features that fix each other, and
 * unchanged when the overlap grows by voxels distributed as the rest. 0 when the histogram
 * is empty or holds a single joint value. */
double
normalizedMutualInformation(const JointHistogram& histogram);

} // namespace core
} // namespace pcl_mi
