/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "compare/pairs.h"

#include <Eigen/Geometry>

#include <cmath>
#include <fstream>
#include <sstream>

namespace pcl_mi {
namespace compare {

bool
readPairList(const std::string& path, std::vector<Pair>& rows, std::string& error)
{
  std::ifstream in(path);
  if (!in) {
    error = "cannot open '" + path + "'";
    return false;
  }
  const auto slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "" : path.substr(0, slash + 1);
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream words(line);
    std::string source, target;
    if (!(words >> source) || source[0] == '#')
      continue;
    std::vector<double> v;
    double x;
    words >> target;
    while (words >> x)
      v.push_back(x);
    if (target.empty() || !words.eof() || (v.size() != 12 && v.size() != 16)) {
      error = "'" + path + "' line " + std::to_string(number) +
              ": expected SOURCE TARGET and 12 or 16 numbers";
      return false;
    }
    Pair p;
    p.sequence = "list";
    p.source_frame = p.target_frame = number;
    p.source_path = source[0] == '/' ? source : dir + source;
    p.target_path = target[0] == '/' ? target : dir + target;
    p.reference.setIdentity();
    for (std::size_t i = 0; i < v.size(); ++i)
      p.reference(static_cast<int>(i / 4), static_cast<int>(i % 4)) = v[i];
    rows.push_back(p);
  }
  if (rows.empty()) {
    error = "'" + path + "' lists no pairs";
    return false;
  }
  return true;
}

std::string
baseName(const std::string& path)
{
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

double
yawDegrees(const Eigen::Matrix4d& t)
{
  return std::atan2(t(1, 0), t(0, 0)) * 180.0 / M_PI;
}

} // namespace compare
} // namespace pcl_mi
