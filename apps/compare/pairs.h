/*
 * pcl_mi_compare: the scan pairs it aligns, from KITTI or from a list file.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

namespace pcl_mi {
namespace compare {

struct Pair {
  std::string sequence;            // KITTI sequence, or "list" for -list rows
  int source_frame, target_frame;  // KITTI frames, or the list row number for both
  std::string source_path, target_path;
  Eigen::Matrix4d reference; // source to target
  Eigen::Matrix4d guess;
  bool backward = false; // source = the earlier scan (a list row: its target)
};

/** Reads -list rows "SOURCE TARGET" + 12 or 16 numbers (the reference source-to-target
 * transform, row-major), white space or commas, '#' comments; relative paths are relative to
 * the list file. Each row yields (source, target, reference) as the forward pair. */
bool
readPairList(const std::string& path, std::vector<Pair>& rows, std::string& error);

/** The file name of \a path, without its directories. */
std::string
baseName(const std::string& path);

/** Yaw (deg) of a transformation. */
double
yawDegrees(const Eigen::Matrix4d& t);

} // namespace compare
} // namespace pcl_mi
