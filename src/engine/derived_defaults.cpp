/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/derived_defaults.h"

#include "engine/input_checks.h"

#include <algorithm>
#include <cmath>

namespace pcl_mi {
namespace core {

double
deriveResolution(const PointView& points)
{
  Eigen::Vector3d extent;
  if (!bulkExtent(points, true, extent))
    return 0.0;
  std::sort(extent.data(), extent.data() + 3);
  // Points on a line have one extent only; the structure check refuses them later.
  const double scale = extent[1] > 0.0 ? std::sqrt(extent[1] * extent[2]) : extent[2];
  if (!(scale > 0.0))
    return 0.0;
  return std::exp2(std::round(std::log2(scale / kExtentVoxels)));
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
