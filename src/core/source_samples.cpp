/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "core/source_samples.h"

#include <algorithm>
#include <cmath>

namespace pcl_mi {
namespace core {

SourceSamples
makeSourceSamples(const PointList& points, double cell_size)
{
  SourceSamples out;
  out.cell_size = cell_size;
  out.point_count = points.size();
  if (points.empty())
    return out;
  if (!(cell_size > 0.0)) {
    out.samples.resize(points.size());
    for (std::size_t i = 0; i < points.size(); ++i)
      out.samples[i].position = points[i];
    return out;
  }

  // Sort points by a packed cell key (21 bits per axis, z slowest), then summarise runs.
  Eigen::Vector3f min = points.front();
  for (const auto& p : points)
    min = min.cwiseMin(p);
  const double inv = 1.0 / cell_size;
  constexpr std::uint64_t kMask = (std::uint64_t{1} << 21) - 1;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d c = ((points[i] - min).cast<double>() * inv).array().floor();
    const std::uint64_t kx = std::min<std::uint64_t>(static_cast<std::uint64_t>(c.x()), kMask);
    const std::uint64_t ky = std::min<std::uint64_t>(static_cast<std::uint64_t>(c.y()), kMask);
    const std::uint64_t kz = std::min<std::uint64_t>(static_cast<std::uint64_t>(c.z()), kMask);
    keyed[i] = {(kz << 42) | (ky << 21) | kx, static_cast<std::uint32_t>(i)};
  }
  std::sort(keyed.begin(), keyed.end());

  for (std::size_t begin = 0; begin < keyed.size();) {
    std::size_t end = begin + 1;
    while (end < keyed.size() && keyed[end].first == keyed[begin].first)
      ++end;
    // Mean and covariance relative to the first point, in double, for accuracy.
    const Eigen::Vector3d anchor = points[keyed[begin].second].cast<double>();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d sum_outer = Eigen::Matrix3d::Zero();
    for (std::size_t k = begin; k < end; ++k) {
      const Eigen::Vector3d d = points[keyed[k].second].cast<double>() - anchor;
      sum += d;
      sum_outer += d * d.transpose();
    }
    const double n = static_cast<double>(end - begin);
    const Eigen::Vector3d mean = sum / n;
    const Eigen::Matrix3d cov = sum_outer / n - mean * mean.transpose();
    SourceSample s;
    s.position = (anchor + mean).cast<float>();
    s.count = static_cast<std::uint32_t>(end - begin);
    const double c[6] = {cov(0, 0), cov(0, 1), cov(0, 2), cov(1, 1), cov(1, 2), cov(2, 2)};
    for (int i = 0; i < 6; ++i)
      s.covariance[i] = static_cast<float>(c[i]);
    out.has_covariance = out.has_covariance || s.count > 1;
    out.samples.push_back(s);
    begin = end;
  }
  return out;
}

std::vector<SourceSamples>
makeSourceSamplePyramid(const PointList& points, double cell_size, int coarser)
{
  std::vector<SourceSamples> pyramid;
  pyramid.push_back(makeSourceSamples(points, cell_size));
  if (points.empty() || !(cell_size > 0.0))
    return pyramid;
  Eigen::Vector3f min = points.front();
  for (const auto& p : points)
    min = min.cwiseMin(p);
  for (int k = 1; k <= coarser; ++k) {
    const SourceSamples& fine = pyramid.back();
    SourceSamples out;
    out.cell_size = fine.cell_size * 2.0;
    out.point_count = fine.point_count;
    // The same keys as makeSourceSamples at the coarser size, for the finer centroids.
    const double inv = 1.0 / out.cell_size;
    constexpr std::uint64_t kMask = (std::uint64_t{1} << 21) - 1;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(fine.samples.size());
    for (std::size_t i = 0; i < fine.samples.size(); ++i) {
      const Eigen::Vector3d c =
          ((fine.samples[i].position - min).cast<double>() * inv).array().floor().max(0.0);
      const std::uint64_t kx = std::min<std::uint64_t>(static_cast<std::uint64_t>(c.x()), kMask);
      const std::uint64_t ky = std::min<std::uint64_t>(static_cast<std::uint64_t>(c.y()), kMask);
      const std::uint64_t kz = std::min<std::uint64_t>(static_cast<std::uint64_t>(c.z()), kMask);
      keyed[i] = {(kz << 42) | (ky << 21) | kx, static_cast<std::uint32_t>(i)};
    }
    std::sort(keyed.begin(), keyed.end());
    for (std::size_t begin = 0; begin < keyed.size();) {
      std::size_t end = begin + 1;
      while (end < keyed.size() && keyed[end].first == keyed[begin].first)
        ++end;
      // Merge by the parallel-axis rule, relative to the first centroid, in double.
      const Eigen::Vector3d anchor = fine.samples[keyed[begin].second].position.cast<double>();
      double n = 0.0;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      Eigen::Matrix3d sum_outer = Eigen::Matrix3d::Zero();
      for (std::size_t k2 = begin; k2 < end; ++k2) {
        const SourceSample& f = fine.samples[keyed[k2].second];
        const double m = f.count;
        const Eigen::Vector3d d = f.position.cast<double>() - anchor;
        const float* c = f.covariance;
        Eigen::Matrix3d cov;
        cov << c[0], c[1], c[2], c[1], c[3], c[4], c[2], c[4], c[5];
        n += m;
        sum += m * d;
        sum_outer += m * (cov + d * d.transpose());
      }
      const Eigen::Vector3d mean = sum / n;
      const Eigen::Matrix3d cov = sum_outer / n - mean * mean.transpose();
      SourceSample s;
      s.position = (anchor + mean).cast<float>();
      s.count = static_cast<std::uint32_t>(n);
      const double c[6] = {cov(0, 0), cov(0, 1), cov(0, 2), cov(1, 1), cov(1, 2), cov(2, 2)};
      for (int i = 0; i < 6; ++i)
        s.covariance[i] = static_cast<float>(c[i]);
      out.has_covariance = out.has_covariance || s.count > 1;
      out.samples.push_back(s);
      begin = end;
    }
    pyramid.push_back(std::move(out));
  }
  return pyramid;
}

} // namespace core
} // namespace pcl_mi
