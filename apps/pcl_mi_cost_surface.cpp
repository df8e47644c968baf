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
#include <utility>
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

/** GICP's objective as PCL computes it, over one pair: the mean of d^T (C_t + R C_s R^T)^-1 d
 * over every 10th source point that has a target neighbour within 5 m, with the covariances
 * of gicpCovariances(). */
class GicpObjective {
public:
  GicpObjective(Cloud::ConstPtr source, Cloud::ConstPtr target)
  : source_(std::move(source)), target_(std::move(target))
  {
    pcl::KdTreeFLANN<pcl::PointXYZ> source_tree;
    source_tree.setInputCloud(source_);
    target_tree_.setInputCloud(target_);
    std::vector<int> all(target_->size());
    for (std::size_t i = 0; i < source_->size(); i += 10)
      sampled_.push_back(static_cast<int>(i));
    for (std::size_t i = 0; i < all.size(); ++i)
      all[i] = static_cast<int>(i);
    source_cov_ = gicpCovariances(source_, source_tree, sampled_);
    target_cov_ = gicpCovariances(target_, target_tree_, all);
  }

  /** The objective at \a pose (source to target); NaN where no point has a neighbour. */
  double
  operator()(const Eigen::Matrix4d& pose) const
  {
    constexpr double kMaxDistance = 5.0;
    const Eigen::Matrix3d r = pose.topLeftCorner<3, 3>();
    pcl::Indices nn(1);
    std::vector<float> d2(1);
    double sum = 0.0;
    int matched = 0;
    for (std::size_t s = 0; s < sampled_.size(); ++s) {
      const Eigen::Vector3d p =
          (pose * (*source_)[sampled_[s]].getVector3fMap().cast<double>().homogeneous()).head<3>();
      pcl::PointXYZ q(p.x(), p.y(), p.z());
      if (target_tree_.nearestKSearch(q, 1, nn, d2) < 1 || d2[0] > kMaxDistance * kMaxDistance)
        continue;
      const Eigen::Vector3d d = (*target_)[nn[0]].getVector3fMap().cast<double>() - p;
      const Eigen::Matrix3d m = target_cov_[nn[0]] + r * source_cov_[s] * r.transpose();
      sum += d.dot(m.inverse() * d);
      ++matched;
    }
    return matched ? sum / matched : NAN;
  }

private:
  Cloud::ConstPtr source_, target_;
  pcl::KdTreeFLANN<pcl::PointXYZ> target_tree_;
  std::vector<int> sampled_;
  std::vector<Eigen::Matrix3d> source_cov_, target_cov_;
};

using Registration = pcl::MutualInformationRegistration<pcl::PointXYZ, pcl::PointXYZ, double>;

/** How far and how finely the poses around the reference are sampled. */
struct Sampling {
  double extent = 10.0;     ///< half-width of the (tx, ty) grid, m
  double step = 0.25;       ///< its step, m
  double yaw_extent = 45.0; ///< half-width of the heading sweep, deg
  double yaw_step = 0.5;    ///< its step, deg
};

/** Whole steps of \a step on either side of zero within \a extent; an extent that is a
 * multiple of the step up to rounding keeps its last step. */
int
stepsEachSide(double extent, double step)
{
  return static_cast<int>(std::floor(extent / step + 1e-9));
}

/** Poses around \a reference, moved in the target frame about the reference-placed source
 * centroid, as the optimiser's parameters are. */
class Perturbation {
public:
  Perturbation(const Eigen::Matrix4d& reference, const Cloud& source) : reference_(reference)
  {
    Eigen::Vector4f centroid;
    pcl::compute3DCentroid(source, centroid);
    pivot_ = (reference * centroid.cast<double>()).head<3>();
  }

  /** The reference moved by (\a dx, \a dy) m and turned by \a dyaw_deg about z. */
  Eigen::Matrix4d
  operator()(double dx, double dy, double dyaw_deg) const
  {
    const Eigen::Affine3d d = Eigen::Translation3d(Eigen::Vector3d(dx, dy, 0) + pivot_) *
                              Eigen::AngleAxisd(dyaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()) *
                              Eigen::Translation3d(-pivot_);
    return Eigen::Matrix4d(d.matrix() * reference_);
  }

private:
  Eigen::Matrix4d reference_;
  Eigen::Vector3d pivot_;
};

/** Opens \a path for writing; false (said why) when it cannot be. */
bool
openCsv(const std::string& path, std::ofstream& out)
{
  out.open(path);
  if (!out)
    print_error("pcl_mi_cost_surface: cannot write '%s'\n", path.c_str());
  return static_cast<bool>(out);
}

/** PREFIX_xy.csv: the MI over the (tx, ty) grid at the reference's other parameters. */
bool
writeGrid(const std::string& prefix, Registration& reg, const Perturbation& perturbed,
          const Sampling& sampling)
{
  std::ofstream xy;
  if (!openCsv(prefix + "_xy.csv", xy))
    return false;
  const double step = sampling.step;
  const int n = stepsEachSide(sampling.extent, step);
  xy << "dx_m,dy_m,mi\n";
  for (int i = -n; i <= n; ++i) {
    for (int j = -n; j <= n; ++j)
      xy << i * step << ',' << j * step << ',' << reg.evaluate(perturbed(i * step, j * step, 0))
         << '\n';
    print_info("\rpcl_mi_cost_surface: (tx, ty) grid %3d%%", 100 * (i + n + 1) / (2 * n + 1));
    std::fflush(stdout);
  }
  print_info("\n");
  return true;
}

/** PREFIX_yaw.csv: the MI and GICP's objective over the heading sweep. */
bool
writeHeadingSweep(const std::string& prefix, Registration& reg, const Perturbation& perturbed,
                  const GicpObjective& gicp, const Sampling& sampling)
{
  std::ofstream yaw;
  if (!openCsv(prefix + "_yaw.csv", yaw))
    return false;
  const double step = sampling.yaw_step;
  const int m = stepsEachSide(sampling.yaw_extent, step);
  yaw << "dyaw_deg,mi,gicp\n";
  for (int k = -m; k <= m; ++k) {
    const Eigen::Matrix4d pose = perturbed(0, 0, k * step);
    yaw << k * step << ',' << reg.evaluate(pose) << ',' << gicp(pose) << '\n';
    if ((k + m) % 10 == 0 || k == m)
      print_info("\rpcl_mi_cost_surface: heading sweep %3d%%", 100 * (k + m + 1) / (2 * m + 1));
  }
  print_info("\n");
  return true;
}

/** PREFIX_line.csv: the MI and GICP's objective on the line from \a reference (s = 0) to
 * \a toward (s = 1), from s = -0.5 to 1.5. Rotation angle and translation both scale with
 * s, so the step between poses is the same at every s. */
bool
writeLine(const std::string& prefix, Registration& reg, const Eigen::Matrix4d& reference,
          const Eigen::Matrix4d& toward, const GicpObjective& gicp)
{
  const Eigen::Matrix4d delta = reference.inverse() * toward;
  const Eigen::AngleAxisd rotation(Eigen::Matrix3d(delta.topLeftCorner<3, 3>()));
  const double distance = delta.topRightCorner<3, 1>().norm();
  std::ofstream line;
  if (!openCsv(prefix + "_line.csv", line))
    return false;
  line << "s,offset_m,mi,gicp\n";
  constexpr int kLineSteps = 40; // s = -0.5 .. 1.5 in steps of 0.05
  for (int k = 0; k <= kLineSteps; ++k) {
    const double t = -0.5 + 2.0 * k / kLineSteps;
    Eigen::Matrix4d step = Eigen::Matrix4d::Identity();
    step.topLeftCorner<3, 3>() = Eigen::AngleAxisd(t * rotation.angle(), rotation.axis()).matrix();
    step.topRightCorner<3, 1>() = t * delta.topRightCorner<3, 1>();
    const Eigen::Matrix4d pose = reference * step;
    line << t << ',' << t * distance << ',' << reg.evaluate(pose) << ',' << gicp(pose) << '\n';
  }
  print_info("Wrote %s_line.csv\n", prefix.c_str());
  return true;
}

/** Help, or a command line this app refuses: the exit code (help 0, refused 2); -1 to go
 * on. */
int
checkCommandLine(int argc, char** argv)
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
  return -1;
}

/** Reads the transform in \a path into \a transform; false (said why) when it cannot. */
bool
readTransform(const std::string& path, Eigen::Matrix4d& transform)
{
  const std::string error = pcl_mi::io::loadTransform(path, transform);
  if (!error.empty())
    print_error("pcl_mi_cost_surface: %s\n", error.c_str());
  return error.empty();
}

/** The grid and sweep of the command line; false (said why) when they are malformed or
 * would take too many evaluations. */
bool
readSampling(int argc, char** argv, Sampling& sampling)
{
  pcl::console::parse_argument(argc, argv, "-extent", sampling.extent);
  pcl::console::parse_argument(argc, argv, "-step", sampling.step);
  pcl::console::parse_argument(argc, argv, "-yaw_extent", sampling.yaw_extent);
  pcl::console::parse_argument(argc, argv, "-yaw_step", sampling.yaw_step);
  const Sampling& s = sampling;
  if (!(s.step > 0) || !(s.yaw_step > 0) || !(s.extent >= 0) || !(s.yaw_extent >= 0) ||
      s.extent / s.step > 1000 || s.yaw_extent / s.yaw_step > 10000) {
    print_error("pcl_mi_cost_surface: bad grid (see -h)\n");
    return false;
  }
  return true;
}

int
run(int argc, char** argv)
{
  const int refused = checkCommandLine(argc, argv);
  if (refused >= 0)
    return refused;
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
  if (!readTransform(argv[3], reference))
    return 1;
  std::string prefix = "cost_surface", toward_path;
  pcl::console::parse_argument(argc, argv, "-toward", toward_path);
  Eigen::Matrix4d toward = reference;
  if (!toward_path.empty() && !readTransform(toward_path, toward))
    return 1;
  pcl::console::parse_argument(argc, argv, "-o", prefix);
  Sampling sampling;
  if (!readSampling(argc, argv, sampling))
    return 1;

  Registration reg;
  pcl_mi::Parameters parameters = reg.getParameters();
  int max_iterations = reg.getMaximumIterations();
  const std::string invalid = pcl_mi::apps::applyMiOptions(argc, argv, parameters, max_iterations);
  if (!invalid.empty()) {
    print_error("pcl_mi_cost_surface: %s\n", invalid.c_str());
    return 1;
  }
  reg.setParameters(parameters);
  reg.setInputSource(source);
  reg.setInputTarget(target);
  if (reg.evaluate(reference) < 0.0)
    return 1; // evaluate() reported why

  const Perturbation perturbed(reference, *source);
  if (!writeGrid(prefix, reg, perturbed, sampling))
    return 1;
  const GicpObjective gicp(source, target);
  if (!writeHeadingSweep(prefix, reg, perturbed, gicp, sampling))
    return 1;
  if (!toward_path.empty() && !writeLine(prefix, reg, reference, toward, gicp))
    return 1;
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
