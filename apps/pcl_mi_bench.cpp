/*
 * pcl_mi_bench: times and scores MI registration against PCL's GICP and NDT on real KITTI
 * pairs with reference poses, all through one pcl::Registration& code path, in one run.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_mi/io.h>
#include <pcl_mi/kitti.h>
#include <pcl_mi/mutual_information_registration.h>

#include <pcl/console/parse.h>
#include <pcl/console/print.h>
#include <pcl/filters/approximate_voxel_grid.h>
#include <pcl/registration/gicp.h>
#include <pcl/registration/ndt.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

using pcl::console::print_error;
using pcl::console::print_info;
using Cloud = pcl::PointCloud<pcl::PointXYZ>;

namespace {

struct Pair {
  std::string sequence;
  int source_frame, target_frame;
  Eigen::Matrix4d reference; // source to target
  Eigen::Matrix4d guess;
};

struct Outcome {
  double translation_error, rotation_error, seconds;
  bool converged;
  int evaluations;
};

std::vector<std::string>
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

double
yawDegrees(const Eigen::Matrix4d& t)
{
  return std::atan2(t(1, 0), t(0, 0)) * 180.0 / M_PI;
}

/** Overrides of the MI defaults from the command line (negative: keep the default). */
struct MiOverrides {
  int subdivision = -1, levels = -1, restarts = -1;
} mi_overrides;

/** Settings that use no knowledge of the true pose; see the README's comparison notes. */
std::unique_ptr<pcl::Registration<pcl::PointXYZ, pcl::PointXYZ>>
makeMethod(const std::string& name)
{
  if (name.rfind("mi-", 0) == 0) { // mi-varz, mi-n, and the paper's search: mi-varz-paper
    auto mi = std::make_unique<pcl::MutualInformationRegistration<pcl::PointXYZ>>();
    const bool paper = name.size() > 6 && name.substr(name.size() - 6) == "-paper";
    const std::string feature = paper ? name.substr(3, name.size() - 9) : name.substr(3);
    if (feature != "varz" && feature != "n")
      return nullptr;
    pcl_mi::Parameters p = paper ? pcl_mi::Parameters::paper() : pcl_mi::Parameters();
    p.feature = feature == "n" ? pcl_mi::Feature::PointCount : pcl_mi::Feature::VarianceZ;
    if (mi_overrides.subdivision >= 0)
      p.source_subdivision = mi_overrides.subdivision;
    if (mi_overrides.levels >= 0)
      p.pyramid_levels = mi_overrides.levels;
    if (mi_overrides.restarts >= 0)
      p.restarts = mi_overrides.restarts;
    if (!mi->setParameters(p))
      return nullptr;
    return mi;
  }
  if (name == "gicp")
    return std::make_unique<pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ>>();
  if (name == "ndt") {
    auto ndt = std::make_unique<pcl::NormalDistributionsTransform<pcl::PointXYZ, pcl::PointXYZ>>();
    ndt->setResolution(1.0f);
    ndt->setStepSize(0.1);
    // PCL 1.13 stops when the squared translation step <= epsilon: the tutorial's 0.01
    // would stop after one 0.1 m step.
    ndt->setTransformationEpsilon(1e-8);
    ndt->setMaximumIterations(35);
    return ndt;
  }
  return nullptr;
}

Outcome
runMethod(const std::string& name,
          const Cloud::Ptr& source,
          const Cloud::Ptr& target,
          const Pair& pair)
{
  auto reg = makeMethod(name);
  const auto start = std::chrono::steady_clock::now();
  Cloud::Ptr input = source;
  if (name == "ndt") { // the NDT tutorial registers a 0.2 m voxel-filtered source
    input.reset(new Cloud);
    pcl::ApproximateVoxelGrid<pcl::PointXYZ> filter;
    filter.setLeafSize(0.2f, 0.2f, 0.2f);
    filter.setInputCloud(source);
    filter.filter(*input);
  }
  reg->setInputSource(input);
  reg->setInputTarget(target);
  Cloud aligned;
  reg->align(aligned, pair.guess.cast<float>());
  Outcome o;
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const auto e = pcl_mi::io::poseError(reg->getFinalTransformation().cast<double>(),
                                       pair.reference);
  o.translation_error = e.translation;
  o.rotation_error = e.rotation_deg;
  o.converged = reg->hasConverged();
  o.evaluations = 0;
  if (auto* mi = dynamic_cast<pcl::MutualInformationRegistration<pcl::PointXYZ>*>(reg.get()))
    o.evaluations = mi->getNumberOfEvaluations();
  return o;
}

double
median(std::vector<double> v)
{
  if (v.empty())
    return NAN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double
mean(const std::vector<double>& v)
{
  double s = 0;
  for (double x : v)
    s += x;
  return v.empty() ? NAN : s / v.size();
}

} // namespace

int
main(int argc, char** argv)
{
  if (pcl::console::find_switch(argc, argv, "-h") || argc < 2) {
    print_info(
        "Benchmarks MI registration against PCL GICP and NDT on KITTI pairs.\n"
        "Usage: %s -kitti DIR [options]\n"
        "  -kitti DIR            KITTI odometry root (holds sequences/SS/...)\n"
        "  -sequences 00,02      sequences (default: 00,01,02,05,08)\n"
        "  -frames N             frames 0..N-1 of each sequence (default 10)\n"
        "  -poses semantic|gt    sequences/SS/poses.txt or poses/SS.txt (default semantic)\n"
        "  -distance MIN,MAX     pair translation range in m (default 1,10)\n"
        "  -max_yaw DEG          largest |yaw| of a pair (default 20)\n"
        "  -pairs SS:i:j,...     only these pairs (sequence SS, frames i < j)\n"
        "  -stride K             every K-th pair only (default 1)\n"
        "  -directions both|forward|backward   (default both)\n"
        "  -perturb T,YAW        guess = reference perturbed by T m (random horizontal\n"
        "                        direction) and +-YAW deg (default: identity guess)\n"
        "  -seed S               random seed for -perturb (default 1)\n"
        "  -methods LIST         from mi-varz,mi-n,mi-varz-paper,mi-n-paper,gicp,ndt\n"
        "                        (default mi-varz,gicp,ndt)\n"
        "  -success T,R          success bound in m and deg (default 0.5,2)\n"
        "  -csv FILE             one row per pair and method\n"
        "  -subdivision N, -levels N, -restarts N   override MI parameters\n",
        argv[0]);
    return argc < 2 ? 1 : 0;
  }
  std::string root, sequences_arg = "00,01,02,05,08", poses_kind = "semantic";
  std::string methods_arg = "mi-varz,gicp,ndt", directions = "both", csv_path, pairs_arg;
  int frames = 10, stride = 1, seed = 1;
  double max_yaw = 20.0;
  std::vector<double> distance{1.0, 10.0}, perturb, success{0.5, 2.0};
  pcl::console::parse_argument(argc, argv, "-kitti", root);
  pcl::console::parse_argument(argc, argv, "-sequences", sequences_arg);
  pcl::console::parse_argument(argc, argv, "-poses", poses_kind);
  pcl::console::parse_argument(argc, argv, "-methods", methods_arg);
  pcl::console::parse_argument(argc, argv, "-directions", directions);
  pcl::console::parse_argument(argc, argv, "-csv", csv_path);
  pcl::console::parse_argument(argc, argv, "-pairs", pairs_arg);
  pcl::console::parse_argument(argc, argv, "-frames", frames);
  pcl::console::parse_argument(argc, argv, "-stride", stride);
  pcl::console::parse_argument(argc, argv, "-seed", seed);
  pcl::console::parse_argument(argc, argv, "-max_yaw", max_yaw);
  pcl::console::parse_argument(argc, argv, "-subdivision", mi_overrides.subdivision);
  pcl::console::parse_argument(argc, argv, "-levels", mi_overrides.levels);
  pcl::console::parse_argument(argc, argv, "-restarts", mi_overrides.restarts);
  pcl::console::parse_x_arguments(argc, argv, "-distance", distance);
  pcl::console::parse_x_arguments(argc, argv, "-perturb", perturb);
  pcl::console::parse_x_arguments(argc, argv, "-success", success);
  const auto methods = split(methods_arg, ',');
  for (const auto& m : methods)
    if (!makeMethod(m)) {
      print_error("pcl_mi_bench: unknown method '%s'\n", m.c_str());
      return 1;
    }
  if (root.empty() || distance.size() != 2 || success.size() != 2 ||
      (!perturb.empty() && perturb.size() != 2) || stride < 1) {
    print_error("pcl_mi_bench: bad arguments (see -h)\n");
    return 1;
  }
  std::map<std::tuple<std::string, int, int>, bool> wanted_pairs;
  for (const auto& p : split(pairs_arg, ',')) {
    const auto sij = split(p, ':');
    if (sij.size() != 3) {
      print_error("pcl_mi_bench: -pairs takes SS:i:j items\n");
      return 1;
    }
    wanted_pairs[{sij[0], std::stoi(sij[1]), std::stoi(sij[2])}] = true;
  }

  std::mt19937 rng(seed);
  std::vector<Pair> pairs;
  std::map<std::string, Cloud::Ptr> clouds;
  int candidate = 0;
  for (const auto& seq : split(sequences_arg, ',')) {
    Eigen::Matrix4d tr;
    std::vector<Eigen::Matrix4d> poses;
    std::string error =
        pcl_mi::kitti::loadCalibrationTr(root + "/sequences/" + seq + "/calib.txt", tr);
    if (error.empty())
      error = pcl_mi::kitti::loadPoses(poses_kind == "gt" ? root + "/poses/" + seq + ".txt"
                                                          : root + "/sequences/" + seq +
                                                                "/poses.txt",
                                       poses);
    if (!error.empty()) {
      print_error("pcl_mi_bench: %s\n", error.c_str());
      return 1;
    }
    const int n = std::min<int>(frames, static_cast<int>(poses.size()));
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) {
        const Eigen::Matrix4d t_ij =
            pcl_mi::kitti::relativeVelodyneTransform(tr, poses[i], poses[j]);
        const double dist = t_ij.topRightCorner<3, 1>().norm();
        if (!wanted_pairs.empty() ? !wanted_pairs.count({seq, i, j})
                                  : (dist < distance[0] || dist >= distance[1] ||
                                     std::abs(yawDegrees(t_ij)) > max_yaw))
          continue;
        if (candidate++ % stride)
          continue;
        for (int dir = 0; dir < 2; ++dir) {
          if ((dir == 0 && directions == "backward") || (dir == 1 && directions == "forward"))
            continue;
          Pair p;
          p.sequence = seq;
          p.target_frame = dir == 0 ? i : j;
          p.source_frame = dir == 0 ? j : i;
          p.reference = dir == 0 ? t_ij : Eigen::Matrix4d(t_ij.inverse());
          p.guess = Eigen::Matrix4d::Identity();
          if (!perturb.empty()) {
            std::uniform_real_distribution<double> angle(-M_PI, M_PI), sign(-1.0, 1.0);
            const double a = angle(rng);
            Eigen::Affine3d d = Eigen::Translation3d(perturb[0] * std::cos(a),
                                                     perturb[0] * std::sin(a), 0.0) *
                                Eigen::AngleAxisd((sign(rng) < 0 ? -1 : 1) * perturb[1] *
                                                      M_PI / 180.0,
                                                  Eigen::Vector3d::UnitZ());
            p.guess = d.matrix() * p.reference;
          }
          pairs.push_back(p);
          for (int f : {i, j}) {
            const std::string key = seq + "/" + std::to_string(f);
            if (clouds.count(key))
              continue;
            pcl::PointCloud<pcl::PointXYZI> xyzi;
            error = pcl_mi::io::loadCloud(pcl_mi::kitti::scanPath(root, seq, f), xyzi);
            if (!error.empty()) {
              print_error("pcl_mi_bench: %s\n", error.c_str());
              return 1;
            }
            auto cloud = pcl::make_shared<Cloud>();
            pcl::copyPointCloud(xyzi, *cloud);
            clouds[key] = cloud;
          }
        }
      }
  }
  print_info("pcl_mi_bench: %zu alignments per method (%s guess), methods %s\n",
             pairs.size(), perturb.empty() ? "identity" : "perturbed", methods_arg.c_str());

  std::ofstream csv;
  if (!csv_path.empty()) {
    csv.open(csv_path);
    csv << "sequence,target,source,distance_m,yaw_deg,method,translation_error_m,"
           "rotation_error_deg,seconds,converged,evaluations\n";
  }
  std::map<std::string, std::vector<Outcome>> results;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const Pair& p = pairs[k];
    const auto& src = clouds[p.sequence + "/" + std::to_string(p.source_frame)];
    const auto& tgt = clouds[p.sequence + "/" + std::to_string(p.target_frame)];
    const double dist = p.reference.topRightCorner<3, 1>().norm();
    std::printf("[%3zu/%zu] %s %d->%d %5.2f m:", k + 1, pairs.size(), p.sequence.c_str(),
                p.source_frame, p.target_frame, dist);
    for (const auto& m : methods) {
      const Outcome o = runMethod(m, src, tgt, p);
      results[m].push_back(o);
      std::printf("  %s %.3f m %.2f deg %.3f s", m.c_str(), o.translation_error,
                  o.rotation_error, o.seconds);
      if (csv.is_open())
        csv << p.sequence << ',' << p.target_frame << ',' << p.source_frame << ',' << dist
            << ',' << yawDegrees(p.reference) << ',' << m << ',' << o.translation_error << ','
            << o.rotation_error << ',' << o.seconds << ',' << o.converged << ','
            << o.evaluations << '\n';
    }
    std::printf("\n");
    std::fflush(stdout);
  }

  std::printf("\n%-8s %6s %9s %9s %9s %9s %10s %10s %8s\n", "method", "pairs", "success",
              "mean_t", "mean_r", "max_t", "median_s", "mean_evals", "vs_mi");
  const double reference_time = median([&] {
    std::vector<double> v;
    for (const auto& o : results[methods.front()])
      v.push_back(o.seconds);
    return v;
  }());
  for (const auto& m : methods) {
    std::vector<double> t, r, s, ev;
    int ok = 0;
    for (const auto& o : results[m]) {
      t.push_back(o.translation_error);
      r.push_back(o.rotation_error);
      s.push_back(o.seconds);
      ev.push_back(o.evaluations);
      ok += o.translation_error < success[0] && o.rotation_error < success[1];
    }
    std::printf("%-8s %6zu %8.1f%% %9.3f %9.3f %9.3f %10.3f %10.1f %7.1fx\n", m.c_str(),
                t.size(), 100.0 * ok / std::max<std::size_t>(1, t.size()), mean(t), mean(r),
                t.empty() ? NAN : *std::max_element(t.begin(), t.end()), median(s), mean(ev),
                median(s) / reference_time);
  }
  std::printf("(errors in m and deg; success: < %.2f m and < %.2f deg; vs_mi: median time "
              "relative to %s)\n",
              success[0], success[1], methods.front().c_str());
  return 0;
}
