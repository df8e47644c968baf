/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_mi/io.h>

#include <pcl/PCLPointCloud2.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <vector>

namespace pcl_mi {
namespace io {

namespace {

std::string
lowerExtension(const std::string& path)
{
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos)
    return {};
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  return ext;
}

bool
hasXyz(const pcl::PCLPointCloud2& blob)
{
  int found = 0;
  for (const auto& f : blob.fields)
    if (f.name == "x" || f.name == "y" || f.name == "z")
      ++found;
  return found == 3;
}

/** Checks that a file starts like a PCD file: optional comments, then the header keys up
 * to DATA. PCL 1.13's PCD reader crashes on some files that are not PCD at all, so they are
 * refused before it sees them. */
std::string
checkPcdHeader(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  std::string line;
  bool fields = false, points = false;
  for (int n = 0; n < 64 && std::getline(in, line); ++n) {
    if (line.empty() || line[0] == '#')
      continue;
    std::istringstream words(line);
    std::string key;
    words >> key;
    if (key == "FIELDS")
      fields = true;
    else if (key == "POINTS")
      points = true;
    else if (key == "DATA")
      return fields && points ? std::string()
                              : "'" + path + "' has a PCD header without FIELDS or POINTS";
    else if (key != "VERSION" && key != "SIZE" && key != "TYPE" && key != "COUNT" &&
             key != "WIDTH" && key != "HEIGHT" && key != "VIEWPOINT")
      return "'" + path + "' is not a PCD file (unexpected header line '" +
             line.substr(0, 40) + "')";
  }
  return "'" + path + "' is not a PCD file (no DATA line)";
}

std::string
checkPlyHeader(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::getline(in, line);
  if (!line.empty() && line.back() == '\r')
    line.pop_back();
  return line == "ply" ? std::string() : "'" + path + "' is not a PLY file";
}

} // namespace

std::string
loadKittiBin(const std::string& path, pcl::PointCloud<pcl::PointXYZI>& cloud)
{
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in)
    return "cannot open '" + path + "'";
  const std::streamoff size = in.tellg();
  constexpr std::streamoff kPointBytes = 4 * sizeof(float);
  if (size <= 0 || size % kPointBytes != 0) {
    std::ostringstream s;
    s << "'" << path << "' is not a KITTI .bin scan: " << size
      << " bytes is not a positive multiple of 16 (float32 x, y, z, reflectance)";
    return s.str();
  }
  std::vector<float> data(static_cast<std::size_t>(size / sizeof(float)));
  in.seekg(0);
  if (!in.read(reinterpret_cast<char*>(data.data()), size))
    return "cannot read '" + path + "'";
  const std::size_t n = data.size() / 4;
  cloud.clear();
  cloud.resize(n);
  bool dense = true;
  for (std::size_t i = 0; i < n; ++i) {
    auto& p = cloud[i];
    p.x = data[4 * i];
    p.y = data[4 * i + 1];
    p.z = data[4 * i + 2];
    p.intensity = data[4 * i + 3];
    dense = dense && std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
  }
  cloud.width = static_cast<std::uint32_t>(n);
  cloud.height = 1;
  cloud.is_dense = dense;
  return {};
}

std::string
loadCloud(const std::string& path, pcl::PointCloud<pcl::PointXYZI>& cloud)
{
  const std::string ext = lowerExtension(path);
  if (ext == "bin")
    return loadKittiBin(path, cloud);
  if (ext != "pcd" && ext != "ply")
    return "'" + path + "': unknown format (expected .pcd, .ply or KITTI .bin)";
  if (!std::ifstream(path))
    return "cannot open '" + path + "'";
  const std::string header_error = ext == "pcd" ? checkPcdHeader(path) : checkPlyHeader(path);
  if (!header_error.empty())
    return header_error;

  pcl::PCLPointCloud2 blob;
  int status = -1;
  // PCL's readers report their own details on the console; ours is the one-line summary.
  const auto verbosity = pcl::console::getVerbosityLevel();
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  if (ext == "pcd")
    status = pcl::io::loadPCDFile(path, blob);
  else
    status = pcl::io::loadPLYFile(path, blob);
  pcl::console::setVerbosityLevel(verbosity);
  if (status < 0)
    return "cannot parse '" + path + "' as " + ext;
  if (!hasXyz(blob))
    return "'" + path + "' has no x, y, z fields";
  pcl::fromPCLPointCloud2(blob, cloud);
  if (cloud.empty())
    return "'" + path + "' has no points";
  return {};
}

std::string
loadTransform(const std::string& path, Eigen::Matrix4d& transform)
{
  std::ifstream in(path);
  if (!in)
    return "cannot open '" + path + "'";
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::replace(text.begin(), text.end(), ',', ' ');
  std::istringstream s(text);
  std::vector<double> v;
  double x;
  while (s >> x)
    v.push_back(x);
  if (!s.eof())
    return "'" + path + "' holds something other than numbers";
  if (v.size() != 12 && v.size() != 16)
    return "'" + path + "' must hold 12 or 16 numbers, found " + std::to_string(v.size());
  transform.setIdentity();
  for (std::size_t i = 0; i < v.size(); ++i)
    transform(static_cast<int>(i / 4), static_cast<int>(i % 4)) = v[i];
  if (!transform.allFinite())
    return "'" + path + "' holds non-finite numbers";
  return {};
}

PoseError
poseError(const Eigen::Matrix4d& estimate, const Eigen::Matrix4d& reference)
{
  const Eigen::Matrix4d delta = reference.inverse() * estimate;
  PoseError e;
  e.translation = delta.topRightCorner<3, 1>().norm();
  const double c = std::min(1.0, std::max(-1.0, (delta.topLeftCorner<3, 3>().trace() - 1.0) / 2.0));
  e.rotation_deg = std::acos(c) * 180.0 / M_PI;
  return e;
}

} // namespace io
} // namespace pcl_mi
