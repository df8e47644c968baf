/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_mi/kitti.h>

#include "io/file_checks.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <vector>

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
  std::ifstream in;
  const std::string not_opened = io::detail::openRegularFile(calib_path, in);
  if (!not_opened.empty())
    return not_opened;
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
  std::ifstream in;
  const std::string not_opened = io::detail::openRegularFile(poses_path, in);
  if (!not_opened.empty())
    return not_opened;
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

std::string
readScan(const std::string& path,
         const std::function<void(std::size_t)>& begin,
         const std::function<void(std::size_t, const float*)>& point)
{
  std::uint64_t size = 0;
  std::ifstream in;
  const std::string not_opened = io::detail::openRegularFile(path, in, &size);
  if (!not_opened.empty())
    return not_opened;
  constexpr std::uint64_t kPointBytes = 4 * sizeof(float);
  if (size == 0 || size % kPointBytes != 0) {
    std::ostringstream s;
    s << "'" << path << "' is not a KITTI .bin scan: " << size
      << " bytes is not a positive multiple of 16 (float32 x, y, z, reflectance)";
    return s.str();
  }
  const std::uint64_t n = size / kPointBytes;
  begin(static_cast<std::size_t>(n));
  constexpr std::size_t kChunkPoints = 1 << 16;
  std::vector<float> chunk(4 * kChunkPoints);
  for (std::size_t first = 0; first < n; first += kChunkPoints) {
    const std::size_t count = std::min<std::size_t>(kChunkPoints, n - first);
    if (!in.read(reinterpret_cast<char*>(chunk.data()),
                 static_cast<std::streamsize>(count * kPointBytes)))
      return "cannot read '" + path + "'";
    for (std::size_t i = 0; i < count; ++i)
      point(first + i, &chunk[4 * i]);
  }
  return {};
}

std::string
loadScan(const std::string& path, PointList& points)
{
  return readScan(
      path, [&](std::size_t n) { points.assign(n, Eigen::Vector3f::Zero()); },
      [&](std::size_t i, const float* xyzr) { points[i] = Eigen::Vector3f(xyzr[0], xyzr[1], xyzr[2]); });
}

} // namespace kitti
} // namespace pcl_mi
