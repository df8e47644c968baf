/*
 * pcl_mi_compare: the registration methods it compares (MI, PCL GICP, PCL NDT and chains of
 * them), each run through the one pcl::Registration interface.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "compare/pairs.h"
#include "compare/rows.h"

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/registration.h>

#include <map>
#include <memory>
#include <string>

namespace pcl_mi {
namespace compare {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

/** The command line, whose MI options tune every MI method (apps/mi_options.h). */
struct MiArguments {
  int argc;
  char** argv;
};

/** The registration \a name stands for, or null for an unknown name. */
std::unique_ptr<pcl::Registration<pcl::PointXYZ, pcl::PointXYZ>>
makeMethod(const std::string& name, const MiArguments& mi_arguments);

/** True for a method name or a chain of them ("A+B": B started from A's result). */
bool
knownMethod(const std::string& name, const MiArguments& mi);

/** MI registrations kept between pairs (-reuse_target): one per method, with the target
 * it was given, so that a pair with the same target cloud only hands over its source. */
struct ReusedTargets {
  struct Entry {
    std::unique_ptr<pcl::Registration<pcl::PointXYZ, pcl::PointXYZ>> registration;
    const Cloud* target = nullptr;
  };
  std::map<std::string, Entry> by_method;
};

/** Runs the method (or chain) \a chain on \a pair: pose, errors, time, evaluations. With
 * \a reused, an MI method that is not part of a chain keeps its registration there and
 * skips setInputTarget() when the target is the previous one's. */
Row
runMethod(const std::string& chain,
          const Cloud::Ptr& source,
          const Cloud::Ptr& target,
          const Pair& pair,
          const MiArguments& mi,
          ReusedTargets* reused = nullptr);

} // namespace compare
} // namespace pcl_mi
