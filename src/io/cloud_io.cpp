/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_mi/io.h>
#include <pcl_mi/kitti.h>

#include "io/file_checks.h"
#include "io/readers.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <new>
#include <stdexcept>
#include <utility>
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

/** Writes the header PCL writes for a binary PCD of one-count, 4-byte \a fields of \a types
 * ("x y z rgb", "F F F U"), so that PCL and pcl_viewer read the file as their own. */
void
writePcdHeader(std::ostream& out,
               const char* fields,
               const char* types,
               std::size_t width,
               std::size_t height,
               std::size_t points,
               const std::string& viewpoint)
{
  out << "# .PCD v0.7 - Point Cloud Data file format\n"
      << "VERSION 0.7\nFIELDS " << fields << "\nSIZE 4 4 4 4\nTYPE " << types
      << "\nCOUNT 1 1 1 1\nWIDTH " << width << "\nHEIGHT " << height << "\nVIEWPOINT "
      << viewpoint << "\nPOINTS " << points << "\nDATA binary\n";
}

/** Appends \a cloud to \a out as the packed records \a record(point) gives, a chunk at a
 * time: unlike saving a converted copy of the cloud, this holds none, which matters at
 * millions of points. */
template <typename Record, typename MakeRecord>
void
writeRecords(std::ostream& out,
             const pcl::PointCloud<pcl::PointXYZI>& cloud,
             const MakeRecord& record)
{
  static_assert(sizeof(Record) == 16, "PCD records of four 4-byte fields are 16 packed bytes");
  constexpr std::size_t kChunkPoints = 1 << 16;
  std::vector<Record> chunk;
  chunk.reserve(std::min(cloud.size(), kChunkPoints));
  for (std::size_t begin = 0; begin < cloud.size() && out; begin += kChunkPoints) {
    const std::size_t end = std::min(cloud.size(), begin + kChunkPoints);
    chunk.clear();
    for (std::size_t i = begin; i < end; ++i)
      chunk.push_back(record(cloud[i]));
    out.write(reinterpret_cast<const char*>(chunk.data()),
              static_cast<std::streamsize>(chunk.size() * sizeof(Record)));
  }
}

} // namespace

std::string
readKittiBin(const std::string& path, ScanPoints& points)
{
  bool dense = true;
  const std::string error = kitti::readScan(
      path, [&](std::size_t n) { points.xyzi.assign(4 * n, 0.0f); },
      [&](std::size_t i, const float* xyzr) {
        std::copy(xyzr, xyzr + 4, &points.xyzi[4 * i]);
        dense = dense && std::isfinite(xyzr[0]) && std::isfinite(xyzr[1]) &&
                std::isfinite(xyzr[2]);
      });
  if (!error.empty())
    return error;
  points.width = static_cast<std::uint32_t>(points.size());
  points.height = 1;
  points.is_dense = dense;
  return {};
}

std::string
readScan(const std::string& path, ScanPoints& points)
{
  const std::string ext = lowerExtension(path);
  if (ext != "bin" && ext != "pcd" && ext != "ply")
    return "'" + path + "': unknown format (expected .pcd, .ply or KITTI .bin)";
  std::string error;
  try {
    error = ext == "bin" ? readKittiBin(path, points)
            : ext == "pcd" ? detail::readPcd(path, points)
                           : detail::readPly(path, points);
  }
  catch (const std::bad_alloc&) {
    error = "not enough memory to load '" + path + "'";
  }
  catch (const std::length_error&) {
    error = "not enough memory to load '" + path + "'";
  }
  if (!error.empty()) {
    points = ScanPoints();
    return error;
  }
  if (points.size() == 0)
    return "'" + path + "' has no points";
  return {};
}

std::string
loadTransform(const std::string& path, Eigen::Matrix4d& transform)
{
  std::uint64_t bytes = 0;
  const std::string not_regular = detail::checkRegularFile(path, &bytes);
  if (!not_regular.empty())
    return not_regular;
  // A transform is 16 numbers: a file of megabytes is something else.
  if (bytes > (1u << 20))
    return "'" + path + "' is too large to be a transform";
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

std::string
saveTransform(const std::string& path, const Eigen::Matrix4d& transform)
{
  std::ofstream out(path, std::ios::trunc);
  if (!out)
    return "cannot write '" + path + "'";
  char line[128];
  for (int r = 0; r < 4; ++r) {
    // 17 significant digits: the text reads back as the same doubles.
    std::snprintf(line, sizeof line, "%.17g %.17g %.17g %.17g\n", transform(r, 0),
                  transform(r, 1), transform(r, 2), transform(r, 3));
    out << line;
  }
  out.flush();
  if (!out)
    return "cannot write '" + path + "'";
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

std::string
savePcd(const std::string& path, const pcl::PointCloud<pcl::PointXYZI>& cloud)
{
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out)
    return "cannot write '" + path + "'";
  const Eigen::Vector4f& o = cloud.sensor_origin_;
  const Eigen::Quaternionf& q = cloud.sensor_orientation_;
  std::ostringstream viewpoint;
  viewpoint << o.x() << " " << o.y() << " " << o.z() << " " << q.w() << " " << q.x() << " "
            << q.y() << " " << q.z();
  writePcdHeader(out, "x y z intensity", "F F F F", cloud.width, cloud.height, cloud.size(),
                 viewpoint.str());
  // Four packed floats a point (a PointXYZI in memory is 32 bytes, with padding).
  struct Record {
    float x, y, z, intensity;
  };
  writeRecords<Record>(out, cloud, [](const pcl::PointXYZI& p) {
    return Record{p.x, p.y, p.z, p.intensity};
  });
  out.close();
  if (!out)
    return "cannot write '" + path + "' (disk full?)";
  return {};
}

std::string
saveMergedPcd(const std::string& path,
              const pcl::PointCloud<pcl::PointXYZI>& target,
              const pcl::PointCloud<pcl::PointXYZI>& aligned)
{
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out)
    return "cannot open '" + path + "' for writing";
  const std::size_t total = target.size() + aligned.size();
  writePcdHeader(out, "x y z rgb", "F F F U", total, 1, total, "0 0 0 1 0 0 0");
  struct Record {
    float x, y, z;
    std::uint32_t rgba;
  };
  // The target grey (170, 170, 170), the aligned source red (230, 40, 40), both opaque.
  for (const auto& [cloud, rgba] :
       {std::make_pair(&target, 0xFFAAAAAAu), std::make_pair(&aligned, 0xFFE62828u)})
    writeRecords<Record>(out, *cloud, [rgba = rgba](const pcl::PointXYZI& p) {
      return Record{p.x, p.y, p.z, rgba};
    });
  out.close();
  if (!out)
    return "cannot write '" + path + "' (disk full?)";
  return {};
}

} // namespace io
} // namespace pcl_mi
