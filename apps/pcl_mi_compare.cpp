/*
 * pcl_mi_compare: side-by-side MI-VARZ, MI-N, PCL GICP and PCL NDT on real KITTI pairs with
 * reference poses, all through one pcl::Registration& code path, in one run. Prints the
 * paper's tables (mean error per initial-error bin, runtime, success), writes one CSV row per
 * (pair, method), and shards: -shard k/N runs every N-th pair, -merge combines the CSVs.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "app_util.h"
#include "compare/methods.h"
#include "compare/pairs.h"
#include "compare/rows.h"
#include "compare/tables.h"
#include "mi_options.h"

#include <pcl_mi/io.h>
#include <pcl_mi/kitti.h>
#include <pcl_mi/mutual_information_registration.h>

#include <pcl/console/parse.h>
#include <pcl/console/print.h>
#include <pcl/filters/approximate_voxel_grid.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/registration/gicp.h>
#include <pcl/registration/ndt.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

using pcl::console::print_error;
using pcl::console::print_info;
using pcl_mi::apps::split;
using namespace pcl_mi::compare;

namespace {

void
printHelp(const char* program)
{
  print_info(
      "Compares MI registration with PCL GICP and NDT on KITTI pairs with reference poses.\n"
      "Usage: %s -kitti DIR [options]\n"
      "       %s -merge A.csv B.csv ... [-csv ALL.csv] [-methods LIST]\n"
      "  -kitti DIR            KITTI odometry root (holds sequences/SS/...)\n"
      "  -list FILE            instead of KITTI: rows 'SOURCE TARGET' + 12 or 16 numbers\n"
      "                        (reference source-to-target 4x4, row-major); paths relative\n"
      "                        to FILE; every row also runs backwards (swapped, inverse)\n"
      "  -sequences 00,02      sequences (default: every one under DIR/sequences with a\n"
      "                        calib.txt; frames without a scan are left out)\n"
      "  -frames N             frames 0..N-1 of each sequence (default 10)\n"
      "  -poses semantic|gt|auto   reference poses: sequences/SS/poses.txt (SemanticKITTI),\n"
      "                        poses/SS.txt (KITTI GPS/INS), or auto: the first where it\n"
      "                        exists, else the second (default auto)\n"
      "  -distance MIN,MAX     pair translation range in m (default 1,10)\n"
      "  -max_yaw DEG          largest |yaw| of a pair (default 20)\n"
      "  -pairs SS:i:j,...     only these pairs (sequence SS, frames i < j)\n"
      "  -stride K             every K-th pair only (default 1)\n"
      "  -repeat N             run every alignment N times, report the median time\n"
      "  -shuffle S            run the pairs in an order shuffled with seed S (S > 0), so\n"
      "                        that a slow spell of a shared machine spreads over all\n"
      "                        bins instead of the bins it coincides with (default 0: in\n"
      "                        order); the rows are the same\n"
      "  -reuse_target         MI keeps its prepared target while consecutive alignments\n"
      "                        share the target cloud (scan to map: one map, many scans;\n"
      "                        use with -directions forward); other methods are unchanged\n"
      "  -backend cpu|opencl|auto   where MI's cost evaluations run (default cpu)\n"
      "  -directions both|forward|backward   (default both)\n"
      "  -perturb T,YAW        guess = reference perturbed by T m (random horizontal\n"
      "                        direction) and +-YAW deg (default: identity guess, the paper's\n"
      "                        protocol)\n"
      "  -perturb TMIN,TMAX,YAWMAX   the same with T uniform in [TMIN, TMAX] and yaw uniform\n"
      "                        in [-YAWMAX, YAWMAX]\n"
      "  -seed S               random seed for -perturb (default 1)\n"
      "  -methods LIST         from mi-varz,mi-n,mi-varz-paper,mi-n-paper,gicp,ndt,\n"
      "                        gicp-coarse,gicp-fine (default mi-varz,mi-n,gicp,ndt);\n"
      "                        gicp-coarse is PCL GICP on 0.25 m voxel-filtered clouds\n"
      "                        with a 5 m correspondence distance (small_gicp's quoted\n"
      "                        setting);\n"
      "                        gicp-fine is PCL GICP on 0.2 m voxel-filtered clouds, 1 m\n"
      "                        correspondences, up to 200 iterations, tolerances 1e-12;\n"
      "                        A+B runs B from A's result (e.g. mi-varz+gicp-fine)\n"
      "  -success T,R          success bound in m and deg (default 0.5,2)\n"
      "  -csv FILE             one row per (pair, method)\n"
      "  -shard K/N            run only pairs K, K+N, K+2N, ... (K in 1..N), for GNU parallel\n"
      "                        or Slurm arrays; combine the shards' CSVs with -merge\n"
      "\n%s",
      program,
      program,
      pcl_mi::apps::miOptionsHelp(pcl_mi::apps::MiOptionSet::Tuning).c_str());
}

/** pcl_mi_compare's own options, with their defaults. */
struct Options {
  std::string root, sequences = "00,01,02,05,08", poses_kind = "auto";
  std::string methods_arg = "mi-varz,mi-n,gicp,ndt", directions = "both", csv_path, pairs_arg;
  std::string shard_arg, list_path;
  int frames = 10, stride = 1, seed = 1, repeat = 1, shuffle_seed = 0;
  int shard = 1, shards = 1;
  bool reuse_target = false;
  double max_yaw = 20.0;
  std::vector<double> distance{1.0, 10.0}, perturb, success{0.5, 2.0};
  std::vector<std::string> methods;
  std::map<std::tuple<std::string, int, int>, bool> wanted_pairs;
  bool sequences_given = false; ///< else: every sequence the root holds
  bool methods_given = false;   ///< else with -merge: every method in the files
};

/** Reads the options after checkOptions(); false (having said why) on a bad value. */
bool
parseOptions(int argc, char** argv, const MiArguments& mi, Options& o)
{
  pcl::console::parse_argument(argc, argv, "-kitti", o.root);
  pcl::console::parse_argument(argc, argv, "-sequences", o.sequences);
  pcl::console::parse_argument(argc, argv, "-poses", o.poses_kind);
  if (pcl_mi::apps::kittiPosesPath("", "", o.poses_kind).empty()) {
    print_error("pcl_mi_compare: -poses must be semantic, gt or auto, got '%s'\n",
                o.poses_kind.c_str());
    return false;
  }
  pcl::console::parse_argument(argc, argv, "-methods", o.methods_arg);
  pcl::console::parse_argument(argc, argv, "-directions", o.directions);
  pcl::console::parse_argument(argc, argv, "-csv", o.csv_path);
  pcl::console::parse_argument(argc, argv, "-pairs", o.pairs_arg);
  pcl::console::parse_argument(argc, argv, "-shard", o.shard_arg);
  pcl::console::parse_argument(argc, argv, "-frames", o.frames);
  pcl::console::parse_argument(argc, argv, "-stride", o.stride);
  pcl::console::parse_argument(argc, argv, "-seed", o.seed);
  pcl::console::parse_argument(argc, argv, "-repeat", o.repeat);
  pcl::console::parse_argument(argc, argv, "-shuffle", o.shuffle_seed);
  o.reuse_target = pcl::console::find_switch(argc, argv, "-reuse_target");
  pcl::console::parse_argument(argc, argv, "-max_yaw", o.max_yaw);
  {
    pcl_mi::Parameters p;
    int max_iterations = pcl_mi::kDefaultMaxIterations;
    const std::string invalid = pcl_mi::apps::applyMiOptions(argc, argv, p, max_iterations);
    if (!invalid.empty()) {
      print_error("pcl_mi_compare: %s\n", invalid.c_str());
      return false;
    }
  }
  pcl::console::parse_x_arguments(argc, argv, "-distance", o.distance);
  pcl::console::parse_x_arguments(argc, argv, "-perturb", o.perturb);
  pcl::console::parse_x_arguments(argc, argv, "-success", o.success);
  o.methods = split(o.methods_arg, ',');
  for (const auto& m : o.methods)
    if (!knownMethod(m, mi)) {
      print_error("pcl_mi_compare: unknown method '%s'\n", m.c_str());
      return false;
    }
  if (o.distance.size() != 2 || o.success.size() != 2 ||
      !(o.perturb.empty() || o.perturb.size() == 2 || o.perturb.size() == 3) || o.stride < 1 || o.repeat < 1 ||
      o.shuffle_seed < 0) {
    print_error("pcl_mi_compare: bad arguments (see -h)\n");
    return false;
  }

  if (!o.shard_arg.empty() &&
      (std::sscanf(o.shard_arg.c_str(), "%d/%d", &o.shard, &o.shards) != 2 || o.shards < 1 ||
       o.shard < 1 || o.shard > o.shards)) {
    print_error("pcl_mi_compare: -shard takes K/N with 1 <= K <= N, got '%s'\n",
                o.shard_arg.c_str());
    return false;
  }
  for (const auto& p : split(o.pairs_arg, ',')) {
    const auto sij = split(p, ':');
    if (sij.size() != 3) {
      print_error("pcl_mi_compare: -pairs takes SS:i:j items\n");
      return false;
    }
    o.wanted_pairs[{sij[0], std::stoi(sij[1]), std::stoi(sij[2])}] = true;
  }

  pcl::console::parse_argument(argc, argv, "-list", o.list_path);
  o.sequences_given = pcl_mi::apps::optionValue(argc, argv, "-sequences") != nullptr;
  o.methods_given = pcl_mi::apps::optionValue(argc, argv, "-methods") != nullptr;
  return true;
}

/** The sequences under ROOT/sequences that have a calib.txt, in order. */
std::vector<std::string>
sequencesUnder(const std::string& root)
{
  std::vector<std::string> found;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(root + "/sequences", error))
    if (entry.is_directory() && std::filesystem::exists(entry.path() / "calib.txt"))
      found.push_back(entry.path().filename().string());
  std::sort(found.begin(), found.end());
  return found;
}

/** -merge: combines shards' CSVs (the files after -merge) and prints the tables. */
int
merge(int argc, char** argv, int merge_at, const Options& o)
{
  std::vector<Row> rows;
  for (int a = merge_at + 1; a < argc && argv[a][0] != '-'; ++a) {
    std::string error;
    if (!readRows(argv[a], rows, error)) {
      print_error("pcl_mi_compare: %s\n", error.c_str());
      return 1;
    }
  }
  if (rows.empty()) {
    print_error("pcl_mi_compare: -merge found no rows\n");
    return 1;
  }
  if (!o.csv_path.empty()) {
    std::ofstream csv(o.csv_path);
    csv << csvHeader() << '\n';
    for (const auto& r : rows)
      writeRow(csv, r);
  }
  // Every method in the files, in order of appearance, unless -methods picks some.
  std::vector<std::string> present;
  if (o.methods_given) {
    for (const auto& m : o.methods)
      if (std::any_of(rows.begin(), rows.end(), [&](const Row& r) { return r.method == m; }))
        present.push_back(m);
  }
  else {
    for (const Row& r : rows)
      if (std::find(present.begin(), present.end(), r.method) == present.end())
        present.push_back(r.method);
  }
  if (present.empty()) {
    print_error("pcl_mi_compare: the rows hold none of the methods %s\n", o.methods_arg.c_str());
    return 1;
  }
  printTables(rows, present, o.success);
  return 0;
}

/** The candidate pairs in their forward direction (source = the later scan), from KITTI or
 * from a list; false (having said why) when they cannot be read. */
bool
forwardPairs(const Options& o, std::vector<Pair>& forward_pairs)
{
  if (!o.list_path.empty()) {
    std::string error;
    if (!readPairList(o.list_path, forward_pairs, error)) {
      print_error("pcl_mi_compare: %s\n", error.c_str());
      return false;
    }
  }
  else {
    if (o.root.empty()) {
      print_error("pcl_mi_compare: -kitti DIR or -list FILE is required (see -h)\n");
      return false;
    }
    const std::vector<std::string> sequences =
        o.sequences_given ? split(o.sequences, ',') : sequencesUnder(o.root);
    if (sequences.empty()) {
      print_error("pcl_mi_compare: no sequence with a calib.txt under '%s/sequences'\n",
                  o.root.c_str());
      return false;
    }
    for (const auto& seq : sequences) {
      Eigen::Matrix4d tr;
      std::vector<Eigen::Matrix4d> poses;
      std::string error =
          pcl_mi::kitti::loadCalibrationTr(o.root + "/sequences/" + seq + "/calib.txt", tr);
      if (error.empty()) {
        const std::string poses_path = pcl_mi::apps::kittiPosesPath(o.root, seq, o.poses_kind);
        error = pcl_mi::kitti::loadPoses(poses_path, poses);
        if (error.empty())
          print_info("pcl_mi_compare: sequence %s: reference poses from %s\n", seq.c_str(),
                     poses_path.c_str());
      }
      if (!error.empty()) {
        print_error("pcl_mi_compare: %s\n", error.c_str());
        return false;
      }
      const int n = std::min<int>(o.frames, static_cast<int>(poses.size()));
      // Without -pairs, frames without a scan are left out (a sample of a sequence).
      std::vector<bool> has_scan(static_cast<std::size_t>(n), true);
      int scans = n;
      if (o.wanted_pairs.empty())
        for (int k = 0; k < n; ++k)
          if (!std::filesystem::exists(pcl_mi::kitti::scanPath(o.root, seq, k))) {
            has_scan[static_cast<std::size_t>(k)] = false;
            --scans;
          }
      if (scans < n)
        print_info("pcl_mi_compare: sequence %s: %d of frames 0-%d have a scan\n", seq.c_str(),
                   scans, n - 1);
      for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j) {
          if (!has_scan[static_cast<std::size_t>(i)] || !has_scan[static_cast<std::size_t>(j)])
            continue;
          const Eigen::Matrix4d t_ij =
              pcl_mi::kitti::relativeVelodyneTransform(tr, poses[i], poses[j]);
          const double dist = t_ij.topRightCorner<3, 1>().norm();
          if (!o.wanted_pairs.empty() ? !o.wanted_pairs.count({seq, i, j})
                                    : (dist < o.distance[0] || dist >= o.distance[1] ||
                                       std::abs(yawDegrees(t_ij)) > o.max_yaw))
            continue;
          Pair p;
          p.sequence = seq;
          p.target_frame = i;
          p.source_frame = j;
          p.target_path = pcl_mi::kitti::scanPath(o.root, seq, i);
          p.source_path = pcl_mi::kitti::scanPath(o.root, seq, j);
          p.reference = t_ij;
          forward_pairs.push_back(p);
        }
    }
  }

  return true;
}

/** This shard's alignments, both directions and the guesses drawn, with their clouds
 * loaded; false (having said why) when a cloud cannot be read. */
bool
shardPairs(const Options& o,
           const std::vector<Pair>& forward_pairs,
           std::vector<Pair>& pairs,
           std::map<std::string, Cloud::Ptr>& clouds)
{
  // Every shard enumerates the same pairs and draws the same perturbations, then keeps its
  // share, so shards together give exactly the rows of one unsharded run.
  std::mt19937 rng(o.seed);
  int candidate = 0, enumerated = 0;
  for (const Pair& forward : forward_pairs) {
    if (candidate++ % o.stride)
      continue;
    for (int dir = 0; dir < 2; ++dir) {
      if ((dir == 0 && o.directions == "backward") || (dir == 1 && o.directions == "forward"))
        continue;
      Pair p = forward;
      if (dir == 1) { // source = the earlier scan: the motion points backwards
        p.backward = true;
        std::swap(p.source_frame, p.target_frame);
        std::swap(p.source_path, p.target_path);
        p.reference = forward.reference.inverse();
      }
      p.guess = Eigen::Matrix4d::Identity();
      if (!o.perturb.empty()) {
        std::uniform_real_distribution<double> unit(0.0, 1.0);
        const double a = 2.0 * M_PI * unit(rng);
        const double t = o.perturb.size() == 2
                             ? o.perturb[0]
                             : o.perturb[0] + (o.perturb[1] - o.perturb[0]) * unit(rng);
        const double yaw_max = o.perturb.back();
        const double yaw = o.perturb.size() == 2 ? (unit(rng) < 0.5 ? -yaw_max : yaw_max)
                                               : yaw_max * (2.0 * unit(rng) - 1.0);
        Eigen::Affine3d d = Eigen::Translation3d(t * std::cos(a), t * std::sin(a), 0.0) *
                            Eigen::AngleAxisd(yaw * M_PI / 180.0, Eigen::Vector3d::UnitZ());
        p.guess = d.matrix() * p.reference;
      }
      if (enumerated++ % o.shards != o.shard - 1)
        continue;
      pairs.push_back(p);
      for (const std::string& path : {p.source_path, p.target_path}) {
        if (clouds.count(path))
          continue;
        pcl::PointCloud<pcl::PointXYZI> xyzi;
        const std::string error = pcl_mi::io::loadCloud(path, xyzi);
        if (!error.empty()) {
          print_error("pcl_mi_compare: %s\n", error.c_str());
          return false;
        }
        auto cloud = pcl::make_shared<Cloud>();
        pcl::copyPointCloud(xyzi, *cloud);
        clouds[path] = cloud;
      }
    }
  }
  return true;
}

/** Aligns every pair with every method, printing progress and writing CSV rows as they
 * finish (a run stopped early keeps what it did); false (having said why) when the CSV file
 * cannot be written. */
bool
alignAll(const Options& o,
         const MiArguments& mi,
         const std::vector<Pair>& pairs,
         std::map<std::string, Cloud::Ptr>& clouds,
         std::vector<Row>& rows)
{
  std::ofstream csv;
  if (!o.csv_path.empty()) {
    csv.open(o.csv_path);
    if (!csv) {
      print_error("pcl_mi_compare: cannot write '%s'\n", o.csv_path.c_str());
      return false;
    }
    csv << csvHeader() << '\n';
  }
  ReusedTargets reused;
  ReusedTargets* reuse = o.reuse_target ? &reused : nullptr;
  const auto started = std::chrono::steady_clock::now();
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const Pair& p = pairs[k];
    const auto& src = clouds[p.source_path];
    const auto& tgt = clouds[p.target_path];
    const auto truth = pcl_mi::io::poseError(Eigen::Matrix4d::Identity(), p.reference);
    const auto initial = pcl_mi::io::poseError(p.guess, p.reference);
    if (p.sequence == "list") // the row number alone does not say which scans
      std::printf("[%3zu/%zu] %s->%s %5.2f m:", k + 1, pairs.size(),
                  baseName(p.source_path).c_str(), baseName(p.target_path).c_str(),
                  truth.translation);
    else
      std::printf("[%3zu/%zu] %s %d->%d %5.2f m:", k + 1, pairs.size(), p.sequence.c_str(),
                  p.source_frame, p.target_frame, truth.translation);
    for (const auto& m : o.methods) {
      Row row = runMethod(m, src, tgt, p, mi, reuse);
      if (o.repeat > 1) { // report the median run's times; the results are identical every run
        std::vector<Row> runs{row};
        for (int r = 1; r < o.repeat; ++r)
          runs.push_back(runMethod(m, src, tgt, p, mi, reuse));
        std::nth_element(runs.begin(), runs.begin() + o.repeat / 2, runs.end(),
                         [](const Row& a, const Row& b) { return a.seconds < b.seconds; });
        const Row& middle = runs[static_cast<std::size_t>(o.repeat / 2)];
        row.seconds = middle.seconds;
        row.stages = middle.stages;
        row.target_reuse = middle.target_reuse;
      }
      row.sequence = p.sequence;
      row.target = p.target_frame;
      row.source = p.source_frame;
      row.direction = p.backward ? "backward" : "forward";
      row.true_translation = truth.translation;
      row.true_rotation = truth.rotation_deg;
      row.initial_translation = initial.translation;
      row.initial_rotation = initial.rotation_deg;
      std::printf("  %s %.3f m %.2f deg %.3f s", m.c_str(), row.translation_error,
                  row.rotation_error, row.seconds);
      if (csv.is_open())
        writeRow(csv, row);
      rows.push_back(row);
    }
    // Rows reach the file pair by pair, so a run stopped early (a scheduler's time limit)
    // keeps everything it finished.
    if (csv.is_open())
      csv.flush();
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    std::printf("  (eta %.0f s)\n", elapsed / (k + 1) * (pairs.size() - k - 1));
    std::fflush(stdout);
  }
  return true;
}

int
run(int argc, char** argv)
{
  if (pcl::console::find_switch(argc, argv, "-h") || argc < 2) {
    printHelp(argv[0]);
    return argc < 2 ? 2 : 0;
  }
  using pcl_mi::apps::OptionValue;
  const std::string bad_option = pcl_mi::apps::checkOptions(
      argc, argv, 0,
      pcl_mi::apps::join(
          {{"-kitti", OptionValue::Text},      {"-list", OptionValue::Text},
           {"-merge", OptionValue::Files},     {"-csv", OptionValue::Text},
           {"-methods", OptionValue::Text},    {"-sequences", OptionValue::Text},
           {"-frames", OptionValue::Number},   {"-poses", OptionValue::Text},
           {"-distance", OptionValue::Numbers}, {"-max_yaw", OptionValue::Number},
           {"-pairs", OptionValue::Text},      {"-stride", OptionValue::Number},
           {"-repeat", OptionValue::Number},   {"-shuffle", OptionValue::Number},
           {"-directions", OptionValue::Text}, {"-perturb", OptionValue::Numbers},
           {"-seed", OptionValue::Number},     {"-success", OptionValue::Numbers},
           {"-shard", OptionValue::Text},      {"-reuse_target", OptionValue::None}},
          pcl_mi::apps::miOptionTable(pcl_mi::apps::MiOptionSet::Tuning)));
  if (!bad_option.empty()) {
    print_error("pcl_mi_compare: %s\n", bad_option.c_str());
    return 2;
  }
  const MiArguments mi{argc, argv};
  Options o;
  if (!parseOptions(argc, argv, mi, o))
    return 1;
  const int merge_at = pcl::console::find_argument(argc, argv, "-merge");
  if (merge_at >= 0)
    return merge(argc, argv, merge_at, o);
  std::vector<Pair> forward_pairs, pairs;
  std::map<std::string, Cloud::Ptr> clouds;
  if (!forwardPairs(o, forward_pairs) || !shardPairs(o, forward_pairs, pairs, clouds))
    return 1;
  if (pairs.empty()) {
    print_error("pcl_mi_compare: no pair matches the selection\n");
    return 1;
  }
  // After the shard's share is taken: shuffling changes the order, never the rows.
  if (o.shuffle_seed > 0)
    std::shuffle(pairs.begin(), pairs.end(), std::mt19937(static_cast<unsigned>(o.shuffle_seed)));
  print_info("pcl_mi_compare: %zu alignments per method (%s guess, shard %d/%d%s), methods %s\n",
             pairs.size(), o.perturb.empty() ? "identity" : "perturbed", o.shard, o.shards,
             o.shuffle_seed > 0 ? ", shuffled" : "", o.methods_arg.c_str());

  std::vector<Row> rows;
  if (!alignAll(o, mi, pairs, clouds, rows))
    return 1;
  printTables(rows, o.methods, o.success);
  return 0;
}

} // namespace

int
main(int argc, char** argv)
{
  return pcl_mi::apps::guardedMain("pcl_mi_compare", [&] { return run(argc, argv); });
}
