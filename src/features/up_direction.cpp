/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "features/up_direction.h"

#include "util/parallel.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <vector>

namespace pcl_mi {
namespace core {

namespace {

/** A cell is planar when its least variance is under this share of the middle one. */
constexpr double kPlanarRatio = 0.05;
/** Cone about the frame's +z within which up is looked for (degrees). */
constexpr double kConeDegrees = 75.0;
/** Half-width of a family of parallel planes (degrees). */
constexpr double kFamilyDegrees = 10.0;
/** Fewest planar cells within the cone, and in the family, for an answer. */
constexpr std::size_t kMinimumNormals = 20;
/** Most cells looked at, spread evenly over the cloud: a few thousand normals find the
 * family as well as all of them, at a bounded cost. */
constexpr std::size_t kMaxCells = 8192;
/** Fewest cells looked at per thread: fewer are not worth a thread's start. */
constexpr std::size_t kMinimumShare = 1024;
/** Bins per unit of the normals' (x, y) in the histogram that finds the family. */
constexpr double kBinsPerUnit = 50.0;

double
degrees(double d)
{
  return d * M_PI / 180.0;
}

/** The stride between the cells looked at. */
std::size_t
strideOf(const SourceSamples& cells)
{
  return cells.samples.size() / kMaxCells + 1;
}

/** The unit normal, towards +z, of a cell with principal \a axes where it is planar and the
 * normal lies within the cone. */
std::optional<Eigen::Vector3d>
planarNormal(const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>& axes)
{
  const Eigen::Vector3d& spread = axes.eigenvalues(); // ascending
  if (!(spread[1] > 0.0) || spread[0] >= kPlanarRatio * spread[1])
    return std::nullopt;
  Eigen::Vector3d n = axes.eigenvectors().col(0).normalized();
  if (!n.allFinite())
    return std::nullopt;
  if (n.z() < 0.0)
    n = -n;
  static const double cone = std::cos(degrees(kConeDegrees));
  if (n.z() < cone)
    return std::nullopt;
  return n;
}

/** Appends the unit normals of the planar cells among cells.samples[k * stride] for k in
 * [\a first, \a last), towards +z, within the cone, in the cells' order. */
void
appendPlanarNormals(const SourceSamples& cells,
                    std::size_t stride,
                    std::size_t first,
                    std::size_t last,
                    std::vector<Eigen::Vector3d>& normals)
{
  for (std::size_t k = first; k < last; ++k) {
    const SourceSample& s = cells.samples[k * stride];
    if (s.count < kUpMinimumCellPoints)
      continue;
    const float* c = s.covariance;
    Eigen::Matrix3d covariance;
    covariance << c[0], c[1], c[2], c[1], c[3], c[4], c[2], c[4], c[5];
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
    solver.computeDirect(covariance);
    if (const std::optional<Eigen::Vector3d> n = planarNormal(solver))
      normals.push_back(*n);
  }
}

/** Unit normals of the planar cells looked at, towards +z, within the cone, in the cells'
 * order; on up to \a threads threads, each taking an even share of the cells. */
std::vector<Eigen::Vector3d>
planarNormals(const SourceSamples& cells, int threads)
{
  const std::size_t stride = strideOf(cells);
  const std::size_t looked = (cells.samples.size() + stride - 1) / stride;
  const std::size_t most = static_cast<std::size_t>(std::max(threads, 1));
  const int shares = static_cast<int>(std::clamp<std::size_t>(looked / kMinimumShare, 1, most));
  std::vector<std::vector<Eigen::Vector3d>> found(static_cast<std::size_t>(shares));
  parallelFor(shares, shares, [&](int share) {
    // The thread's own vector: neighbouring vectors' ends share a cache line.
    std::vector<Eigen::Vector3d> normals;
    appendPlanarNormals(cells, stride, looked * static_cast<std::size_t>(share) / shares,
                        looked * static_cast<std::size_t>(share + 1) / shares, normals);
    found[static_cast<std::size_t>(share)] = std::move(normals);
  });
  std::vector<Eigen::Vector3d> normals = std::move(found.front());
  for (std::size_t i = 1; i < found.size(); ++i)
    normals.insert(normals.end(), found[i].begin(), found[i].end());
  return normals;
}

/** The mean normal of the densest square window of the normals' (x, y) histogram. */
Eigen::Vector3d
densestDirection(const std::vector<Eigen::Vector3d>& normals)
{
  const double reach = std::sin(degrees(kConeDegrees));
  const int bins = static_cast<int>(std::ceil(2.0 * reach * kBinsPerUnit));
  const int half = static_cast<int>(std::ceil(std::sin(degrees(kFamilyDegrees)) * kBinsPerUnit));
  auto bin = [&](double v) {
    return std::clamp(static_cast<int>((v + reach) * kBinsPerUnit), 0, bins - 1);
  };
  // Summed-area table: sums[(i + 1) * (bins + 1) + j + 1] = count of bins <= (i, j).
  std::vector<int> sums(static_cast<std::size_t>((bins + 1) * (bins + 1)), 0);
  auto at = [&](int i, int j) -> int& {
    return sums[static_cast<std::size_t>((i + 1) * (bins + 1) + (j + 1))];
  };
  for (const Eigen::Vector3d& n : normals)
    ++at(bin(n.x()), bin(n.y()));
  for (int i = 0; i < bins; ++i)
    for (int j = 0; j < bins; ++j)
      at(i, j) += at(i - 1, j) + at(i, j - 1) - at(i - 1, j - 1);
  int best = -1, best_i = 0, best_j = 0;
  for (int i = 0; i < bins; ++i)
    for (int j = 0; j < bins; ++j) {
      const int i0 = std::max(i - half, 0) - 1, i1 = std::min(i + half, bins - 1);
      const int j0 = std::max(j - half, 0) - 1, j1 = std::min(j + half, bins - 1);
      const int count = at(i1, j1) - at(i0, j1) - at(i1, j0) + at(i0, j0);
      if (count > best) {
        best = count;
        best_i = i;
        best_j = j;
      }
    }
  // The mean of the window's normals: a tight family fills many windows equally, and their
  // centres lie up to a window's half-width from it.
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& n : normals)
    if (std::abs(bin(n.x()) - best_i) <= half && std::abs(bin(n.y()) - best_j) <= half)
      sum += n;
  return sum.normalized();
}

/** The up direction from the planar cells' \a normals (estimateUpDirection()). */
std::optional<Eigen::Vector3d>
upFromNormals(const std::vector<Eigen::Vector3d>& normals)
{
  if (normals.size() < kMinimumNormals)
    return std::nullopt;
  Eigen::Vector3d up = densestDirection(normals);
  // The family's principal direction, from a few rounds of its members.
  const double family = std::cos(degrees(kFamilyDegrees));
  for (int round = 0; round < 3; ++round) {
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    std::size_t members = 0;
    for (const Eigen::Vector3d& n : normals)
      if (std::abs(n.dot(up)) >= family) {
        scatter += n * n.transpose();
        ++members;
      }
    if (members < kMinimumNormals)
      return std::nullopt;
    // The iterative solver: the closed form loses its way on a scatter of one direction.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
    up = solver.eigenvectors().col(2).normalized();
    if (up.z() < 0.0)
      up = -up;
  }
  return up;
}

} // namespace

std::optional<Eigen::Vector3d>
estimateUpDirection(const SourceSamples& cells, int threads)
{
  return upFromNormals(planarNormals(cells, threads));
}

UpDirectionFromAxes::UpDirectionFromAxes(const SourceSamples& cells)
: cells_(cells), stride_(strideOf(cells))
{}

bool
UpDirectionFromAxes::wanted(std::size_t i) const
{
  return i % stride_ == 0 && cells_.samples[i].count >= kUpMinimumCellPoints;
}

void
UpDirectionFromAxes::look(std::size_t i, const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>& axes)
{
  if (!wanted(i))
    return;
  if (const std::optional<Eigen::Vector3d> n = planarNormal(axes))
    normals_.push_back(*n);
}

std::optional<Eigen::Vector3d>
UpDirectionFromAxes::estimate() const
{
  return upFromNormals(normals_);
}

} // namespace core
} // namespace pcl_mi
