/*
 * pcl_mi: reading scans and poses for the apps and tests.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace pcl_mi {
namespace io {

/** \brief A scan as the readers hand it over: x, y, z, intensity per point in plain
 * floats. No Eigen-aligned allocation crosses the library boundary, so code compiled with
 * other alignment flags than the library (e.g. -march=native) can use the readers: the
 * inline loadCloud() builds the pcl::PointCloud in the caller's own code. */
struct ScanPoints {
  std::vector<float> xyzi;            ///< 4 floats per point
  std::uint32_t width = 0, height = 0; ///< organisation, as the file gives it
  bool is_dense = false;               ///< every point finite

  std::size_t
  size() const
  {
    return xyzi.size() / 4;
  }
};

/** \brief Reads a scan by extension: .pcd, .ply, or KITTI Velodyne .bin (little-endian
 * float32 x, y, z, reflectance per point). Returns an empty string on success, else a
 * one-line reason (missing file, wrong size, no x/y/z fields, no points...). */
std::string
readScan(const std::string& path, ScanPoints& points);

/** \brief Reads a KITTI Velodyne .bin scan. Same contract as readScan(). */
std::string
readKittiBin(const std::string& path, ScanPoints& points);

/** \brief \a points as a cloud. */
inline void
toCloud(const ScanPoints& points, pcl::PointCloud<pcl::PointXYZI>& cloud)
{
  cloud.clear();
  cloud.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    pcl::PointXYZI& p = cloud[i];
    p.x = points.xyzi[4 * i];
    p.y = points.xyzi[4 * i + 1];
    p.z = points.xyzi[4 * i + 2];
    p.intensity = points.xyzi[4 * i + 3];
  }
  cloud.width = points.width;
  cloud.height = points.height;
  cloud.is_dense = points.is_dense;
}

/** \brief \a read (readScan or readKittiBin) of \a path into \a cloud; on failure
 * \a cloud is empty and the reason returned. */
inline std::string
loadInto(std::string (*read)(const std::string&, ScanPoints&),
         const std::string& path,
         pcl::PointCloud<pcl::PointXYZI>& cloud)
{
  ScanPoints points;
  const std::string error = read(path, points);
  cloud.clear();
  if (error.empty())
    toCloud(points, cloud);
  return error;
}

/** \brief Loads a scan (see readScan()) into \a cloud. */
inline std::string
loadCloud(const std::string& path, pcl::PointCloud<pcl::PointXYZI>& cloud)
{
  return loadInto(readScan, path, cloud);
}

/** \brief Loads a KITTI Velodyne .bin scan (see readKittiBin()). */
inline std::string
loadKittiBin(const std::string& path, pcl::PointCloud<pcl::PointXYZI>& cloud)
{
  return loadInto(readKittiBin, path, cloud);
}

/** \brief Reads a rigid transformation from text: 16 numbers (4x4, row-major) or 12
 * (the top 3x4 rows, KITTI style), separated by white space or commas. */
std::string
loadTransform(const std::string& path, Eigen::Matrix4d& transform);

/** \brief Writes \a transform as four rows of four numbers, readable by loadTransform()
 * (and so by pcl_mi_align's -guess_file and -reference). Returns an empty string on
 * success, else a one-line reason. */
std::string
saveTransform(const std::string& path, const Eigen::Matrix4d& transform);

/** \brief Translation error (m) and rotation error (deg) of \a estimate against
 * \a reference: the translation and angle of inv(reference) * estimate. */
struct PoseError {
  double translation = 0.0;
  double rotation_deg = 0.0;
};
PoseError
poseError(const Eigen::Matrix4d& estimate, const Eigen::Matrix4d& reference);

/** \brief Writes \a cloud as a binary .pcd (fields x y z intensity, its width and height
 * kept), as pcl::io::savePCDFileBinary() does but without PCL's io module. Returns an empty
 * string on success, else a one-line reason. */
std::string
savePcd(const std::string& path, const pcl::PointCloud<pcl::PointXYZI>& cloud);

/** \brief Writes \a target (grey) followed by \a aligned (red) as one binary XYZRGB .pcd
 * for pcl_viewer, in chunks: unlike building a merged pcl::PointCloud and saving it, this
 * holds no copy of the two clouds, which matters at millions of points. Returns an empty
 * string on success, else a one-line reason. */
std::string
saveMergedPcd(const std::string& path,
              const pcl::PointCloud<pcl::PointXYZI>& target,
              const pcl::PointCloud<pcl::PointXYZI>& aligned);

} // namespace io
} // namespace pcl_mi
