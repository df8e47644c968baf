/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_mi/kitti.h>

#include "io/file_checks.h"

#include <Eigen/Geometry>

#include <cstdio>
#include <fstream>
#include <sstream>

namespace pcl_mi {
namespace kitti {

namespace {

bool
parseTwelve(const std::string& text, Eigen::Matrix4d& m)
{
  std::istringstream s(text);
  m.setIdentity();
  for (int i = 0; i < 12; ++i)
    if (!(s >> m(i / 4, i % 4)))
      return false;
  double extra;
  return !(s >> extra) && m.allFinite();
}

} // namespace

std::string
loadCalibrationTr(const std::string& calib_path, Eigen::Matrix4d& tr)
{
  const std::string not_regular = io::detail::checkRegularFile(calib_path);
  if (!not_regular.empty())
    return not_regular;
  std::ifstream in(calib_path);
  if (!in)
    return "cannot open '" + calib_path + "'";
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("Tr:", 0) != 0)
      continue;
    if (!parseTwelve(line.substr(3), tr))
      return "'" + calib_path + "': the Tr line does not hold 12 numbers";
    return {};
  }
  return "'" + calib_path + "' has no 'Tr:' line";
}

std::string
loadPoses(const std::string& poses_path, std::vector<Eigen::Matrix4d>& poses)
{
  const std::string not_regular = io::detail::checkRegularFile(poses_path);
  if (!not_regular.empty())
    return not_regular;
  std::ifstream in(poses_path);
  if (!in)
    return "cannot open '" + poses_path + "'";
  poses.clear();
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.find_first_not_of(" \t\r") == std::string::npos)
      continue;
    Eigen::Matrix4d p;
    if (!parseTwelve(line, p))
      return "'" + poses_path + "' line " + std::to_string(number) +
             ": expected 12 numbers";
    poses.push_back(p);
  }
  if (poses.empty())
    return "'" + poses_path + "' holds no poses";
  return {};
}

Eigen::Matrix4d
velodynePose(const Eigen::Matrix4d& tr, const Eigen::Matrix4d& camera_pose)
{
  return tr.inverse() * camera_pose * tr;
}

Eigen::Matrix4d
relativeVelodyneTransform(const Eigen::Matrix4d& tr,
                          const Eigen::Matrix4d& camera_pose_i,
                          const Eigen::Matrix4d& camera_pose_j)
{
  return velodynePose(tr, camera_pose_i).inverse() * velodynePose(tr, camera_pose_j);
}

std::string
scanPath(const std::string& root, const std::string& sequence, int frame)
{
  char name[32];
  std::snprintf(name, sizeof(name), "%06d.bin", frame);
  return root + "/sequences/" + sequence + "/velodyne/" + name;
}

} // namespace kitti
} // namespace pcl_mi
