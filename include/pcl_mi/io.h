/*
 * pcl_mi: reading scans and poses for the apps and tests.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <string>

namespace pcl_mi {
namespace io {

/** \brief Loads a scan by extension: .pcd, .ply, or KITTI Velodyne .bin (little-endian
 * float32 x, y, z, reflectance per point). Returns an empty string on success, else a
 * one-line reason (missing file, wrong size, no x/y/z fields, no points...). */
std::string
loadCloud(const std::string& path, pcl::PointCloud<pcl::PointXYZI>& cloud);

/** \brief Reads a KITTI Velodyne .bin scan. Same contract as loadCloud(). */
std::string
loadKittiBin(const std::string& path, pcl::PointCloud<pcl::PointXYZI>& cloud);

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
