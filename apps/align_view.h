/*
 * pcl_mi_align: the entry point of its viewer module (apps/align_view.cpp).
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <string>

namespace pcl_mi {
namespace apps {

using ViewCloud = pcl::PointCloud<pcl::PointXYZI>;

/** The viewer's entry point, by the name pcl_mi_align looks it up (kShowBeforeAfterSymbol):
 * shows (or, with \a screenshot, saves) target + source under the guess (\a before) on the
 * left and target + aligned source (\a after) on the right, seen from above. */
using ShowBeforeAfter = bool (*)(const ViewCloud::ConstPtr& target,
                                 const ViewCloud::ConstPtr& before,
                                 const ViewCloud::ConstPtr& after,
                                 const std::string& screenshot);

constexpr const char* kShowBeforeAfterSymbol = "pcl_mi_show_before_after";

} // namespace apps
} // namespace pcl_mi
