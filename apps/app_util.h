/*
 * pcl_mi apps: small helpers the command-line apps share (header-only, no PCL, so the
 * engine-only pcl_mi_backend_bench can use them too).
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <new>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace pcl_mi {
namespace apps {

/** Splits \a s at \a sep, dropping empty items ("a,,b" -> {"a", "b"}). */
inline std::vector<std::string>
split(const std::string& s, char sep)
{
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, sep))
    if (!item.empty())
      out.push_back(item);
  return out;
}

/** Median of \a v; NaN when empty. */
inline double
median(std::vector<double> v)
{
  if (v.empty())
    return NAN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/** [tx, ty, tz, roll, pitch, yaw] with the angles in degrees, as the apps take it on the
 * command line, into \a out with the angles in radians; false unless there are 6 values. */
inline bool
poseVectorFromDegrees(const std::vector<double>& values, Eigen::Matrix<double, 6, 1>& out)
{
  if (values.size() != 6)
    return false;
  for (int i = 0; i < 6; ++i)
    out[i] = i < 3 ? values[i] : values[i] * M_PI / 180.0;
  return true;
}

/** Reference poses of KITTI sequence \a sequence under \a root. \a kind "semantic":
 * sequences/SS/poses.txt (SemanticKITTI's LiDAR-SLAM poses); "gt": poses/SS.txt (KITTI's
 * GPS/INS ground truth, the odometry benchmark's own layout); "auto": the SemanticKITTI file
 * where it exists, else the ground truth. Empty for any other kind. */
inline std::string
kittiPosesPath(const std::string& root, const std::string& sequence, const std::string& kind)
{
  const std::string semantic = root + "/sequences/" + sequence + "/poses.txt";
  const std::string gt = root + "/poses/" + sequence + ".txt";
  if (kind == "semantic")
    return semantic;
  if (kind == "gt")
    return gt;
  if (kind == "auto")
    return std::ifstream(semantic).good() ? semantic : gt;
  return "";
}

/** The one exception boundary of an app: runs \a body and returns its exit code; whatever
 * escapes it (out of memory, PCL's IOException on an unwritable file, ...) becomes one line
 * on stderr and exit code 1, instead of "terminate called" and SIGABRT. */
template <typename Body>
int
guardedMain(const char* app, Body&& body)
{
  try {
    return body();
  }
  catch (const std::bad_alloc&) {
    std::fprintf(stderr, "%s: out of memory\n", app);
  }
  catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", app, e.what());
  }
  catch (...) {
    std::fprintf(stderr, "%s: unknown error\n", app);
  }
  return 1;
}

} // namespace apps
} // namespace pcl_mi
