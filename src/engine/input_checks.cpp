/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/input_checks.h"

#include "features/voxel_grid.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

namespace pcl_mi {
namespace core {

std::string
rigidTransformError(const Eigen::Matrix4d& m, double tolerance)
{
  if (!m.allFinite())
    return "is not finite";
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  const double orthogonality = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  const bool bottom = m(3, 0) == 0.0 && m(3, 1) == 0.0 && m(3, 2) == 0.0 && m(3, 3) == 1.0;
  if (orthogonality <= tolerance && r.determinant() > 0.0 && bottom)
    return {};
  std::ostringstream s;
  s << "is not a rigid transformation (";
  if (!bottom)
    s << "bottom row not 0 0 0 1";
  else if (orthogonality > tolerance)
    s << "its 3x3 block is not a rotation: |R^T R - I| reaches " << orthogonality;
  else
    s << "its 3x3 block is a reflection, determinant " << r.determinant();
  s << ")";
  return s.str();
}

bool
bulkExtent(const PointView& points, bool skip_origin, Eigen::Vector3d& extent)
{
  constexpr std::size_t kSamples = 4096;
  std::vector<float> axis[3];
  const std::size_t stride = std::max<std::size_t>(1, points.size() / kSamples);
  for (std::size_t i = 0; i < points.size(); i += stride)
    if (points[i].allFinite() && !(skip_origin && points[i].isZero()))
      for (int a = 0; a < 3; ++a)
        axis[a].push_back(points[i][a]);
  if (axis[0].empty())
    return false;
  for (int a = 0; a < 3; ++a) {
    std::vector<float>& v = axis[a];
    const auto low = v.begin() + static_cast<std::ptrdiff_t>(0.05 * (v.size() - 1));
    std::nth_element(v.begin(), low, v.end());
    const double lo = *low;
    const auto high = v.begin() + static_cast<std::ptrdiff_t>(0.95 * (v.size() - 1));
    std::nth_element(v.begin(), high, v.end());
    extent[a] = static_cast<double>(*high) - lo;
  }
  return true;
}

std::string
resolutionError(const PointView& points, double resolution, const char* which)
{
  Eigen::Vector3d extent;
  if (!bulkExtent(points, false, extent))
    return {};
  double cells = 1.0;
  for (int a = 0; a < 3; ++a)
    cells *= std::floor(extent[a] / resolution) + 1.0;
  if (cells <= static_cast<double>(kMaxGridCells))
    return {};
  // The coarsest resolution at which the bulk fits: cells ~ prod(extent / r).
  const double fitting = std::cbrt(std::max(extent.prod(), 1e-300) / kMaxGridCells);
  std::ostringstream s;
  s << "resolution " << resolution << " is too fine for the " << which << ": the bulk of its "
    << "points spans " << extent.x() << " x " << extent.y() << " x " << extent.z()
    << ", more than the " << kMaxGridCells << " voxels a grid may hold; use a coarser "
    << "resolution (about " << fitting << " or more) or crop the clouds";
  return s.str();
}

std::string
structureError(const LocalCloud& cloud, double resolution, const char* which)
{
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(cloud.covariance, Eigen::EigenvaluesOnly);
  const Eigen::Vector3d spread = solver.eigenvalues().cwiseMax(0.0).cwiseSqrt(); // ascending
  const double needed = kMinimumSpreadVoxels * resolution;
  if (spread[1] >= needed)
    return {};
  std::ostringstream s;
  s << "the " << which << " carries no structure at resolution " << resolution << ": ";
  if (spread[2] == 0.0)
    s << "its " << cloud.points.size() << " usable points all lie at one position";
  else if (spread[2] >= needed && spread[1] <= 1e-6 * spread[2])
    s << "its points lie on a line";
  else
    s << "its points spread " << spread[2] << ", " << spread[1] << " and " << spread[0]
      << " (standard deviations along their principal axes), and at least two must reach half "
         "a voxel ("
      << needed << "); use a finer resolution";
  return s.str();
}

} // namespace core
} // namespace pcl_mi
