/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "features/mutual_information.h"

#include <algorithm>
#include <cmath>

namespace pcl_mi {
namespace core {

double
entropy(const std::vector<std::uint64_t>& counts)
{
  // H = -sum p log p with p = c / N, rewritten as log N - (1/N) sum c log c so that only
  // the integer counts enter the sum.
  std::uint64_t total = 0;
  double sum_c_log_c = 0.0;
  for (const std::uint64_t c : counts) {
    if (c == 0)
      continue;
    total += c;
    const double cd = static_cast<double>(c);
    sum_c_log_c += cd * std::log(cd);
  }
  if (total == 0)
    return 0.0;
  const double n = static_cast<double>(total);
  return std::log(n) - sum_c_log_c / n;
}

Entropies
entropies(const JointHistogram& histogram)
{
  const int b = histogram.num_bins;
  std::vector<std::uint64_t> target(b, 0), source(b, 0);
  std::vector<std::uint64_t> joint(histogram.counts.begin(), histogram.counts.end());
  for (int x = 0; x < b; ++x)
    for (int y = 0; y < b; ++y) {
      const std::uint64_t c = histogram.at(x, y);
      target[x] += c;
      source[y] += c;
    }
  Entropies e;
  e.target = entropy(target);
  e.source = entropy(source);
  e.joint = entropy(joint);
  return e;
}

double
mutualInformation(const JointHistogram& histogram)
{
  if (histogram.num_bins <= 0 || histogram.counts.empty())
    return 0.0;
  // Rounding can make MI of independent variables a hair negative; MI >= 0 by definition.
  return std::max(0.0, entropies(histogram).mutualInformation());
}

double
normalizedMutualInformation(const JointHistogram& histogram)
{
  if (histogram.num_bins <= 0 || histogram.counts.empty())
    return 0.0;
  const Entropies e = entropies(histogram);
  // Rounding can put H(X) + H(Y) a hair below H(X,Y); their ratio is >= 1 by definition.
  return e.joint > 0.0 ? std::max(1.0, (e.target + e.source) / e.joint) : 0.0;
}

} // namespace core
} // namespace pcl_mi
