/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/derived_defaults.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace pcl_mi {
namespace core {

double
deriveResolution(const PointList& points)
{
  // The percentiles come from an even sample: a scan's extent needs no more points.
  constexpr std::size_t kSamples = 4096;
  const std::size_t stride = std::max<std::size_t>(1, points.size() / kSamples);
  std::vector<float> axis[3];
  for (std::size_t i = 0; i < points.size(); i += stride) {
    const Eigen::Vector3f& p = points[i];
    if (p.allFinite() && !p.isZero())
      for (int a = 0; a < 3; ++a)
        axis[a].push_back(p[a]);
  }
  if (axis[0].empty())
    return 0.0;
  double extent[3];
  for (int a = 0; a < 3; ++a) {
    std::vector<float>& v = axis[a];
    const auto at = [&v](double q) {
      const auto it = v.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
      std::nth_element(v.begin(), it, v.end());
      return static_cast<double>(*it);
    };
    const double lo = at(0.05);
    extent[a] = at(0.95) - lo;
  }
  std::sort(extent, extent + 3);
  // Points on a line have one extent only; the structure check refuses them later.
  const double scale = extent[1] > 0.0 ? std::sqrt(extent[1] * extent[2]) : extent[2];
  if (!(scale > 0.0))
    return 0.0;
  const double resolution = std::exp2(std::round(std::log2(scale / kExtentVoxels)));
  return resolution;
}

Parameters
resolveParameters(const Parameters& requested, double derived_resolution)
{
  Parameters p = requested;
  if (p.grid.resolution == 0.0)
    p.grid.resolution = derived_resolution;
  if (p.grid.resolution == 0.0)
    return p; // steps in voxels wait for a resolution
  for (int i = 0; i < 3; ++i)
    if (p.search.simplex_steps[i] < 0.0)
      p.search.simplex_steps[i] *= -p.grid.resolution;
  return p;
}

} // namespace core
} // namespace pcl_mi
