/*
 * pcl_mi_align's viewer (-view, -screenshot), a module the app loads only when asked: PCL's
 * visualization module and VTK would otherwise load, and take their time and memory, at
 * every start of the app.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "align_view.h"

#include <pcl/visualization/pcl_visualizer.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>
#include <vector>

extern "C" bool
pcl_mi_show_before_after(const pcl_mi::apps::ViewCloud::ConstPtr& target,
                         const pcl_mi::apps::ViewCloud::ConstPtr& before,
                         const pcl_mi::apps::ViewCloud::ConstPtr& after,
                         const std::string& screenshot)
{
  using Handler = pcl::visualization::PointCloudColorHandlerCustom<pcl::PointXYZI>;
  pcl::visualization::PCLVisualizer viewer("pcl_mi_align: before (guess) | after");
  viewer.setSize(1600, 800);
  int left = 0, right = 0;
  viewer.createViewPort(0.0, 0.0, 0.5, 1.0, left);
  viewer.createViewPort(0.5, 0.0, 1.0, 1.0, right);
  for (const auto& [viewport, source, label] :
       {std::make_tuple(left, before, "before (initial guess)"),
        std::make_tuple(right, after, "after (pcl_mi)")}) {
    const std::string id = std::to_string(viewport);
    viewer.setBackgroundColor(1.0, 1.0, 1.0, viewport);
    viewer.addPointCloud<pcl::PointXYZI>(target, Handler(target, 120, 120, 120),
                                         "target" + id, viewport);
    viewer.addPointCloud<pcl::PointXYZI>(source, Handler(source, 230, 40, 40), "source" + id,
                                         viewport);
    viewer.addText(std::string(label) + "   grey: target, red: source", 10, 10, 18, 0, 0, 0,
                   "label" + id, viewport);
  }
  // Framed to the target seen from above: its 2-98 % extent in x and y (stray far returns
  // would shrink the scene to a dot), centred, at the height that fits it in a viewport.
  std::vector<float> xs, ys;
  for (const auto& p : *target)
    if (std::isfinite(p.x) && std::isfinite(p.y)) {
      xs.push_back(p.x);
      ys.push_back(p.y);
    }
  float centre[2] = {0.0f, 0.0f}, half = 50.0f;
  if (!xs.empty()) {
    half = 0.0f;
    std::vector<float>* axes[2] = {&xs, &ys};
    for (int a = 0; a < 2; ++a) {
      std::vector<float>& v = *axes[a];
      std::sort(v.begin(), v.end());
      const float lo = v[v.size() / 50], hi = v[v.size() - 1 - v.size() / 50];
      centre[a] = 0.5f * (lo + hi);
      half = std::max(half, 0.5f * (hi - lo));
    }
  }
  // VTK's default view angle is 30 degrees; 10 % margin.
  const double height = 1.1 * half / std::tan(15.0 * M_PI / 180.0) + 1.0;
  viewer.setCameraPosition(centre[0], centre[1], height, centre[0], centre[1], 0, 0, 1, 0);
  if (!screenshot.empty()) {
    viewer.spinOnce(100);
    viewer.saveScreenshot(screenshot);
  }
  else {
    viewer.spin();
  }
  return true;
}
