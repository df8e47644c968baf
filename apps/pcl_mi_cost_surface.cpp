/*
 * pcl_mi_cost_surface: the MI cost around a reference pose, for plots like the paper's
 * cost-function figures: MI over a (tx, ty) grid with the other parameters at the
 * reference, and MI versus heading next to GICP's objective versus heading.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "app_util.h"
#include "mi_options.h"

#include <pcl_mi/io.h>
#include <pcl_mi/mutual_information_registration.h>

#include <pcl/console/parse.h>
#include <pcl/console/print.h>
#include <pcl/kdtree/kdtree_flann.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

using pcl::console::print_error;
using pcl::console::print_info;
using Cloud = pcl::PointCloud<pcl::PointXYZ>;

namespace {

/** Plane-regularised covariances as in GICP (Segal et al.; PCL's defaults): the covariance
 * of the k nearest neighbours with its eigenvalues replaced by (1, 1, epsilon). */
std::vector<Eigen::Matrix3d>
gicpCovariances(const Cloud::ConstPtr& cloud, const pcl::KdTreeFLANN<pcl::PointXYZ>& tree,
                const std::vector<int>& which)
{
  constexpr int k = 20;
  constexpr double epsilon = 1e-3;
  std::vector<Eigen::Matrix3d> out;
  pcl::Indices nn(k);
  std::vector<float> d(k);
  for (const int i : which) {
    tree.nearestKSearch((*cloud)[i], k, nn, d);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto j : nn)
      mean += (*cloud)[j].getVector3fMap().cast<double>();
    mean /= k;
    Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
    for (const auto j : nn) {
      const Eigen::Vector3d v = (*cloud)[j].getVector3fMap().cast<double>() - mean;
      c += v * v.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(c / k);
    const Eigen::Vector3d values(epsilon, 1.0, 1.0); // ascending, smallest = normal
    out.push_back(es.eigenvectors() * values.asDiagonal() * es.eigenvectors().transpose());
  }
  return out;
}

/** GICP's objective at \a pose: mean over matched sampled source points of
 * d^T (C_t + R C_s R^T)^-1 d, nearest neighbours within \a max_distance. */
double
gicpCost(const Eigen::Matrix4d& pose, const Cloud::ConstPtr& source,
         const std::vector<int>& sampled, const std::vector<Eigen::Matrix3d>& source_cov,
         const Cloud::ConstPtr& target, const pcl::KdTreeFLANN<pcl::PointXYZ>& target_tree,
         const std::vector<Eigen::Matrix3d>& target_cov, double max_distance)
{
  const Eigen::Matrix3d r = pose.topLeftCorner<3, 3>();
  pcl::Indices nn(1);
  std::vector<float> d2(1);
  double sum = 0.0;
  int matched = 0;
  for (std::size_t s = 0; s < sampled.size(); ++s) {
    const Eigen::Vector3d p =
        (pose * (*source)[sampled[s]].getVector3fMap().cast<double>().homogeneous()).head<3>();
    pcl::PointXYZ q(p.x(), p.y(), p.z());
    if (target_tree.nearestKSearch(q, 1, nn, d2) < 1 || d2[0] > max_distance * max_distance)
      continue;
    const Eigen::Vector3d d = (*target)[nn[0]].getVector3fMap().cast<double>() - p;
    const Eigen::Matrix3d m = target_cov[nn[0]] + r * source_cov[s] * r.transpose();
    sum += d.dot(m.inverse() * d);
    ++matched;
  }
  return matched ? sum / matched : NAN;
}

int
run(int argc, char** argv)
{
  if (argc < 4 || pcl::console::find_switch(argc, argv, "-h")) {
    print_info(
        "Samples the MI cost around a reference pose, for cost-surface plots.\n"
        "Usage: %s SOURCE TARGET REFERENCE [options]\n"
        "  SOURCE, TARGET        .pcd, .ply or KITTI .bin; REFERENCE: 4x4 or 3x4 text\n"
        "  -o PREFIX             output prefix (default cost_surface): writes\n"
        "                        PREFIX_xy.csv (dx, dy, mi) and PREFIX_yaw.csv\n"
        "                        (dyaw_deg, mi, gicp)\n"
        "  -extent M             half-width of the (tx, ty) grid in m (default 10)\n"
        "  -step M               grid step in m (default 0.25)\n"
        "  -yaw_extent DEG       half-width of the heading sweep (default 45)\n"
        "  -yaw_step DEG         heading step (default 0.5)\n"
        "  -toward FILE          also sample the line from REFERENCE to the pose in FILE\n"
        "                        (4x4 or 3x4 text, e.g. pcl_mi_align -transform): writes\n"
        "                        PREFIX_line.csv (s, offset_m, mi, gicp) for s from -0.5\n"
        "                        (beyond REFERENCE) to 1.5 (beyond FILE's pose)\n"
        "Plot with: pcl_mi_plot_cost_surface.py PREFIX\n"
        "\n%s",
        argv[0], pcl_mi::apps::miOptionsHelp(pcl_mi::apps::MiOptionSet::All).c_str());
    return pcl::console::find_switch(argc, argv, "-h") ? 0 : 2;
  }
  using pcl_mi::apps::OptionValue;
  const std::string bad_option = pcl_mi::apps::checkOptions(
      argc, argv, 3,
      pcl_mi::apps::join({{"-o", OptionValue::Text},
                          {"-extent", OptionValue::Number},
                          {"-step", OptionValue::Number},
                          {"-yaw_extent", OptionValue::Number},
                          {"-yaw_step", OptionValue::Number},
                          {"-toward", OptionValue::Text}},
                         pcl_mi::apps::miOptionTable(pcl_mi::apps::MiOptionSet::All)));
  if (!bad_option.empty()) {
    print_error("pcl_mi_cost_surface: %s\n", bad_option.c_str());
    return 2;
  }
  pcl::PointCloud<pcl::PointXYZI> xyzi;
  auto source = pcl::make_shared<Cloud>(), target = pcl::make_shared<Cloud>();
  for (auto [path, cloud] : {std::make_pair(argv[1], source), std::make_pair(argv[2], target)}) {
    const std::string error = pcl_mi::io::loadCloud(path, xyzi);
    if (!error.empty()) {
      print_error("pcl_mi_cost_surface: %s\n", error.c_str());
      return 1;
    }
    pcl::copyPointCloud(xyzi, *cloud);
  }
  Eigen::Matrix4d reference;
  std::string error = pcl_mi::io::loadTransform(argv[3], reference);
  if (!error.empty()) {
    print_error("pcl_mi_cost_surface: %s\n", error.c_str());
    return 1;
  }
  std::string prefix = "cost_surface", toward_path;
  pcl::console::parse_argument(argc, argv, "-toward", toward_path);
  Eigen::Matrix4d toward = reference;
  if (!toward_path.empty()) {
    error = pcl_mi::io::loadTransform(toward_path, toward);
    if (!error.empty()) {
      print_error("pcl_mi_cost_surface: %s\n", error.c_str());
      return 1;
    }
  }
  double extent = 10.0, step = 0.25, yaw_extent = 45.0, yaw_step = 0.5;
  pcl::console::parse_argument(argc, argv, "-o", prefix);
  pcl::console::parse_argument(argc, argv, "-extent", extent);
  pcl::console::parse_argument(argc, argv, "-step", step);
  pcl::console::parse_argument(argc, argv, "-yaw_extent", yaw_extent);
  pcl::console::parse_argument(argc, argv, "-yaw_step", yaw_step);
  if (!(step > 0) || !(yaw_step > 0) || !(extent >= 0) || !(yaw_extent >= 0) ||
      extent / step > 1000 || yaw_extent / yaw_step > 10000) {
    print_error("pcl_mi_cost_surface: bad grid (see -h)\n");
    return 1;
  }

  pcl::MutualInformationRegistration<pcl::PointXYZ, pcl::PointXYZ, double> reg;
  pcl_mi::Parameters parameters = reg.getParameters();
  int max_iterations = reg.getMaximumIterations();
  error = pcl_mi::apps::applyMiOptions(argc, argv, parameters, max_iterations);
  if (!error.empty()) {
    print_error("pcl_mi_cost_surface: %s\n", error.c_str());
    return 1;
  }
  reg.setParameters(parameters);
  reg.setInputSource(source);
  reg.setInputTarget(target);
  if (reg.evaluate(reference) < 0.0)
    return 1; // evaluate() reported why

  // Perturbations are applied in the target frame about the reference-placed source centroid,
  // as the optimiser's parameters are.
  Eigen::Vector4f centroid;
  pcl::compute3DCentroid(*source, centroid);
  const Eigen::Vector3d pivot = (reference * centroid.cast<double>()).head<3>();
  auto perturbed = [&](double dx, double dy, double dyaw_deg) {
    const Eigen::Affine3d d = Eigen::Translation3d(Eigen::Vector3d(dx, dy, 0) + pivot) *
                              Eigen::AngleAxisd(dyaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()) *
                              Eigen::Translation3d(-pivot);
    return Eigen::Matrix4d(d.matrix() * reference);
  };

  const int n = static_cast<int>(std::floor(extent / step + 1e-9));
  std::ofstream xy(prefix + "_xy.csv");
  if (!xy) {
    print_error("pcl_mi_cost_surface: cannot write '%s_xy.csv'\n", prefix.c_str());
    return 1;
  }
  xy << "dx_m,dy_m,mi\n";
  for (int i = -n; i <= n; ++i) {
    for (int j = -n; j <= n; ++j)
      xy << i * step << ',' << j * step << ',' << reg.evaluate(perturbed(i * step, j * step, 0))
         << '\n';
    print_info("\rpcl_mi_cost_surface: (tx, ty) grid %3d%%", 100 * (i + n + 1) / (2 * n + 1));
    std::fflush(stdout);
  }
  print_info("\n");

  pcl::KdTreeFLANN<pcl::PointXYZ> source_tree, target_tree;
  source_tree.setInputCloud(source);
  target_tree.setInputCloud(target);
  std::vector<int> sampled, all(target->size());
  for (std::size_t i = 0; i < source->size(); i += 10)
    sampled.push_back(static_cast<int>(i));
  for (std::size_t i = 0; i < all.size(); ++i)
    all[i] = static_cast<int>(i);
  const auto source_cov = gicpCovariances(source, source_tree, sampled);
  const auto target_cov = gicpCovariances(target, target_tree, all);

  const int m = static_cast<int>(std::floor(yaw_extent / yaw_step + 1e-9));
  std::ofstream yaw(prefix + "_yaw.csv");
  yaw << "dyaw_deg,mi,gicp\n";
  for (int k = -m; k <= m; ++k) {
    const Eigen::Matrix4d pose = perturbed(0, 0, k * yaw_step);
    yaw << k * yaw_step << ',' << reg.evaluate(pose) << ','
        << gicpCost(pose, source, sampled, source_cov, target, target_tree, target_cov, 5.0)
        << '\n';
    if ((k + m) % 10 == 0 || k == m)
      print_info("\rpcl_mi_cost_surface: heading sweep %3d%%", 100 * (k + m + 1) / (2 * m + 1));
  }
  print_info("\n");

  if (!toward_path.empty()) {
    // Rotation angle and translation both scale with s, so s = 0 is the reference, s = 1 the
    // other pose, and the step between them is the same at every s.
    const Eigen::Matrix4d delta = reference.inverse() * toward;
    const Eigen::AngleAxisd rotation(Eigen::Matrix3d(delta.topLeftCorner<3, 3>()));
    const double distance = delta.topRightCorner<3, 1>().norm();
    std::ofstream line(prefix + "_line.csv");
    if (!line) {
      print_error("pcl_mi_cost_surface: cannot write '%s_line.csv'\n", prefix.c_str());
      return 1;
    }
    line << "s,offset_m,mi,gicp\n";
    constexpr int kLineSteps = 40; // s = -0.5 .. 1.5 in steps of 0.05
    for (int k = 0; k <= kLineSteps; ++k) {
      const double t = -0.5 + 2.0 * k / kLineSteps;
      Eigen::Matrix4d step = Eigen::Matrix4d::Identity();
      step.topLeftCorner<3, 3>() = Eigen::AngleAxisd(t * rotation.angle(), rotation.axis()).matrix();
      step.topRightCorner<3, 1>() = t * delta.topRightCorner<3, 1>();
      const Eigen::Matrix4d pose = reference * step;
      line << t << ',' << t * distance << ',' << reg.evaluate(pose) << ','
           << gicpCost(pose, source, sampled, source_cov, target, target_tree, target_cov, 5.0)
           << '\n';
    }
    print_info("Wrote %s_line.csv\n", prefix.c_str());
  }
  print_info("Wrote %s_xy.csv and %s_yaw.csv (plot: pcl_mi_plot_cost_surface.py %s)\n",
             prefix.c_str(), prefix.c_str(), prefix.c_str());
  return 0;
}

} // namespace

int
main(int argc, char** argv)
{
  return pcl_mi::apps::guardedMain("pcl_mi_cost_surface", [&] { return run(argc, argv); });
}
