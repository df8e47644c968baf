/*
 * pcl_mi: KITTI odometry layout (sequences/SS/velodyne/NNNNNN.bin, calib.txt, poses).
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_mi/types.h>

#include <Eigen/Core>

#include <cstddef>
#include <functional>

#include <string>
#include <vector>

namespace pcl_mi {
namespace kitti {

/** \brief Reads the "Tr:" line of a KITTI calib.txt (velodyne to rectified camera 0) as a
 * 4x4 matrix. Returns an empty string on success, else the reason. */
std::string
loadCalibrationTr(const std::string& calib_path, Eigen::Matrix4d& tr);

/** \brief Reads a KITTI poses file: one line per frame, 12 numbers (top 3x4 of the pose of
 * camera 0 at frame k in camera 0 at frame 0). */
std::string
loadPoses(const std::string& poses_path, std::vector<Eigen::Matrix4d>& poses);

/** \brief Velodyne pose of a frame in the velodyne frame of frame 0:
 * inv(Tr) * P_k * Tr. */
Eigen::Matrix4d
velodynePose(const Eigen::Matrix4d& tr, const Eigen::Matrix4d& camera_pose);

/** \brief Transformation mapping velodyne scan j into the frame of scan i,
 * inv(T_velo_i) * T_velo_j: the expected getFinalTransformation() for source = scan j,
 * target = scan i. */
Eigen::Matrix4d
relativeVelodyneTransform(const Eigen::Matrix4d& tr,
                          const Eigen::Matrix4d& camera_pose_i,
                          const Eigen::Matrix4d& camera_pose_j);

/** \brief Path of a frame's scan: ROOT/sequences/SS/velodyne/NNNNNN.bin. */
std::string
scanPath(const std::string& root, const std::string& sequence, int frame);

/** \brief Reads a KITTI Velodyne scan (float32 x, y, z, reflectance per point) in chunks,
 * with no copy of the file in memory: \a begin(n) once with the point count, then
 * \a point(i, xyzr) for each point. Returns an empty string, or why it cannot. */
std::string
readScan(const std::string& path,
         const std::function<void(std::size_t)>& begin,
         const std::function<void(std::size_t, const float*)>& point);

/** \brief The scan's points (x, y, z) at \a path (see readScan()). */
std::string
loadScan(const std::string& path, PointList& points);

} // namespace kitti
} // namespace pcl_mi
