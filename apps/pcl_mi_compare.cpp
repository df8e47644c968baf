/*
 * pcl_mi_compare: side-by-side MI-VARZ, MI-N, PCL GICP and PCL NDT on real KITTI pairs with
 * reference poses, all through one pcl::Registration& code path, in one run. Prints the
 * paper's tables (mean error per initial-error bin, runtime, success), writes one CSV row per
 * (pair, method), and shards: -shard k/N runs every N-th pair, -merge combines the CSVs.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "app_util.h"
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
using Cloud = pcl::PointCloud<pcl::PointXYZ>;

using pcl_mi::apps::median;
using pcl_mi::apps::split;

namespace {

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

/** One CSV row: a (pair, method) result. */
struct Row {
  std::string sequence, direction, method;
  int target = 0, source = 0;
  double true_translation = 0, true_rotation = 0;       // m, deg: the reference motion
  double initial_translation = 0, initial_rotation = 0; // m, deg: error of the guess
  double translation_error = 0, rotation_error = 0;     // m, deg: error of the result
  double seconds = 0;
  bool converged = false;
  int evaluations = 0;
  /** Signed translation error (m) in the pair's travel frame: along the reference
   * translation, to its left and up (the clouds' z is up). NaN where undefined (a reference
   * translation too short or vertical) or unknown (rows of files without these columns).
   * Kept as read rather than derived from the rounded transforms below, so -merge writes
   * back exactly what the shards wrote. */
  Eigen::Vector3d travel_error = Eigen::Vector3d::Constant(NAN);
  /** The result and the reference, source to target (NaN in rows of older files). */
  Eigen::Matrix4d estimate = Eigen::Matrix4d::Constant(NAN);
  Eigen::Matrix4d reference = Eigen::Matrix4d::Constant(NAN);
};

/** The first 14 columns are the original format, which readRows() still accepts; the columns
 * after them keep what an analysis beyond these tables needs: the signed error components and
 * both transforms (top three rows, row-major). */
std::string
csvHeader(bool with_poses)
{
  std::string h = "sequence,target,source,direction,true_translation_m,true_rotation_deg,"
                  "initial_translation_m,initial_rotation_deg,method,translation_error_m,"
                  "rotation_error_deg,seconds,converged,evaluations";
  if (!with_poses)
    return h;
  h += ",along_error_m,left_error_m,up_error_m";
  for (const char* name : {"estimate", "reference"})
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        h += "," + std::string(name) + "_" + std::to_string(r) + std::to_string(c);
  return h;
}
constexpr std::size_t kLegacyFields = 14;
constexpr std::size_t kFields = kLegacyFields + 3 + 2 * 12;

/** \a error = estimate - reference translation (target frame) along the reference
 * translation, to its left and up; NaN where the travel direction is undefined. */
Eigen::Vector3d
travelFrameError(const Eigen::Matrix4d& estimate, const Eigen::Matrix4d& reference)
{
  const Eigen::Vector3d t = reference.topRightCorner<3, 1>();
  const Eigen::Vector3d along = t.normalized();
  const Eigen::Vector3d left_raw = Eigen::Vector3d::UnitZ().cross(along);
  // Below 1 mm of motion, or within 0.6 deg of vertical, "along" and "left" say nothing.
  if (!(t.norm() > 1e-3) || !(left_raw.norm() > 1e-2))
    return Eigen::Vector3d::Constant(NAN);
  const Eigen::Vector3d left = left_raw.normalized();
  const Eigen::Vector3d up = along.cross(left);
  const Eigen::Vector3d error = estimate.topRightCorner<3, 1>() - t;
  return {error.dot(along), error.dot(left), error.dot(up)};
}

void
writeRow(std::ostream& out, const Row& r)
{
  out << r.sequence << ',' << r.target << ',' << r.source << ',' << r.direction << ','
      << r.true_translation << ',' << r.true_rotation << ',' << r.initial_translation << ','
      << r.initial_rotation << ',' << r.method << ',' << r.translation_error << ','
      << r.rotation_error << ',' << r.seconds << ',' << r.converged << ',' << r.evaluations;
  for (int i = 0; i < 3; ++i)
    out << ',' << r.travel_error[i];
  const auto precision = out.precision(9); // enough for a float transform to round-trip
  for (const Eigen::Matrix4d* m : {&r.estimate, &r.reference})
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 4; ++j)
        out << ',' << (*m)(i, j);
  out.precision(precision);
  out << '\n';
}

/** Reads rows written by writeRow(); false with \a error on a malformed file. */
bool
readRows(const std::string& path, std::vector<Row>& rows, std::string& error)
{
  std::ifstream in(path);
  if (!in) {
    error = "cannot open '" + path + "'";
    return false;
  }
  std::string line;
  int number = 0;
  const std::string legacy_header = csvHeader(false), header = csvHeader(true);
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line == legacy_header || line == header)
      continue;
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string item;
    while (std::getline(ss, item, ','))
      f.push_back(item);
    try {
      if (f.size() != kLegacyFields && f.size() != kFields)
        throw std::invalid_argument("field count");
      Row r;
      r.sequence = f[0];
      r.target = std::stoi(f[1]);
      r.source = std::stoi(f[2]);
      r.direction = f[3];
      r.true_translation = std::stod(f[4]);
      r.true_rotation = std::stod(f[5]);
      r.initial_translation = std::stod(f[6]);
      r.initial_rotation = std::stod(f[7]);
      r.method = f[8];
      r.translation_error = std::stod(f[9]);
      r.rotation_error = std::stod(f[10]);
      r.seconds = std::stod(f[11]);
      r.converged = f[12] == "1";
      r.evaluations = std::stoi(f[13]);
      if (f.size() == kFields) {
        std::size_t k = kLegacyFields;
        for (int i = 0; i < 3; ++i)
          r.travel_error[i] = std::stod(f[k++]);
        for (Eigen::Matrix4d* m : {&r.estimate, &r.reference}) {
          m->row(3) << 0.0, 0.0, 0.0, 1.0;
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 4; ++j)
              (*m)(i, j) = std::stod(f[k++]);
        }
      }
      rows.push_back(r);
    }
    catch (const std::exception&) {
      error = "'" + path + "' line " + std::to_string(number) + " is not a pcl_mi_compare row";
      return false;
    }
  }
  return true;
}

double
yawDegrees(const Eigen::Matrix4d& t)
{
  return std::atan2(t(1, 0), t(0, 0)) * 180.0 / M_PI;
}

/** Overrides of the MI defaults from the command line (negative: keep the default). */
/** The command line, whose MI options tune every MI method (apps/mi_options.h). */
struct MiArguments {
  int argc;
  char** argv;
};

/** gicp-coarse: voxel leaf (m) of both clouds and the correspondence distance (m). */
constexpr float kCoarseGicpLeaf = 0.25f;
constexpr double kCoarseGicpCorrespondence = 5.0;
/** gicp-fine: voxel leaf (m), correspondence distance (m) and iteration cap; its tolerances
 * are tight enough that only the cap or a zero step stops it. */
constexpr float kFineGicpLeaf = 0.2f;
constexpr double kFineGicpCorrespondence = 1.0;
constexpr int kFineGicpIterations = 200;
constexpr double kFineGicpTolerance = 1e-12;

/** Voxel leaf (m) a method filters both clouds with before registering, 0 for none. */
float
methodLeaf(const std::string& name)
{
  return name == "gicp-coarse" ? kCoarseGicpLeaf : name == "gicp-fine" ? kFineGicpLeaf : 0.0f;
}

/** Settings that use no knowledge of the true pose; see the README's comparison notes. */
std::unique_ptr<pcl::Registration<pcl::PointXYZ, pcl::PointXYZ>>
makeMethod(const std::string& name, const MiArguments& mi_arguments)
{
  if (name.rfind("mi-", 0) == 0) { // mi-varz, mi-n, and the paper's search: mi-varz-paper
    auto mi = std::make_unique<pcl::MutualInformationRegistration<pcl::PointXYZ>>();
    const bool paper = name.size() > 6 && name.substr(name.size() - 6) == "-paper";
    const std::string feature = paper ? name.substr(3, name.size() - 9) : name.substr(3);
    if (feature != "varz" && feature != "n")
      return nullptr;
    pcl_mi::Parameters p = paper ? pcl_mi::Parameters::paper() : pcl_mi::Parameters();
    p.grid.feature = feature == "n" ? pcl_mi::Feature::PointCount : pcl_mi::Feature::VarianceZ;
    int max_iterations = mi->getMaximumIterations();
    if (!pcl_mi::apps::applyMiOptions(mi_arguments.argc, mi_arguments.argv, p, max_iterations)
             .empty())
      return nullptr;
    mi->setMaximumIterations(max_iterations);
    if (!mi->setParameters(p))
      return nullptr;
    return mi;
  }
  if (name == "gicp")
    return std::make_unique<pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ>>();
  if (name == "gicp-coarse") {
    // The configuration the small_gicp anchor is quoted with, in PCL's implementation: both
    // clouds on a 0.25 m voxel grid (see runMethod), 20 neighbours per covariance, a
    // generous 5 m correspondence distance (small_gicp defaults to 1 m).
    auto gicp =
        std::make_unique<pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ>>();
    gicp->setCorrespondenceRandomness(20);
    gicp->setMaxCorrespondenceDistance(kCoarseGicpCorrespondence);
    return gicp;
  }
  if (name == "gicp-fine") {
    // GICP run to its own optimum on near-full-resolution clouds: an accuracy reference for
    // a known basin (e.g. chained after MI, "mi-varz+gicp-fine"), far too slow otherwise.
    auto gicp =
        std::make_unique<pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ>>();
    gicp->setMaxCorrespondenceDistance(kFineGicpCorrespondence);
    gicp->setMaximumIterations(kFineGicpIterations);
    gicp->setTransformationEpsilon(kFineGicpTolerance);
    gicp->setEuclideanFitnessEpsilon(kFineGicpTolerance);
    gicp->setRotationEpsilon(kFineGicpTolerance);
    return gicp;
  }
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

/** Keeps one point (the centroid) per \a leaf cube. */
Cloud::Ptr
downsampled(const Cloud::Ptr& cloud, float leaf)
{
  Cloud::Ptr out(new Cloud);
  pcl::VoxelGrid<pcl::PointXYZ> filter;
  filter.setLeafSize(leaf, leaf, leaf);
  filter.setInputCloud(cloud);
  filter.filter(*out);
  return out;
}

/** True for a method name or a chain of them ("A+B": B started from A's result). */
bool
knownMethod(const std::string& name, const MiArguments& mi)
{
  const auto plus = name.rfind('+');
  if (plus == std::string::npos)
    return makeMethod(name, mi) != nullptr;
  return knownMethod(name.substr(0, plus), mi) && makeMethod(name.substr(plus + 1), mi) != nullptr;
}

Row
runMethod(const std::string& chain,
          const Cloud::Ptr& source,
          const Cloud::Ptr& target,
          const Pair& pair,
          const MiArguments& mi)
{
  // A chain "A+B" runs B from A's result; its time is the sum, its evaluations A's.
  const auto plus = chain.rfind('+');
  const std::string name = plus == std::string::npos ? chain : chain.substr(plus + 1);
  Pair start_pair = pair;
  Row previous;
  if (plus != std::string::npos) {
    previous = runMethod(chain.substr(0, plus), source, target, pair, mi);
    start_pair.guess = previous.estimate;
  }
  auto reg = makeMethod(name, mi);
  const auto start = std::chrono::steady_clock::now();
  Cloud::Ptr input = source, reference_cloud = target;
  if (methodLeaf(name) > 0.0f) {
    input = downsampled(source, methodLeaf(name));
    reference_cloud = downsampled(target, methodLeaf(name));
  }
  if (name == "ndt") { // the NDT tutorial registers a 0.2 m voxel-filtered source
    input.reset(new Cloud);
    pcl::ApproximateVoxelGrid<pcl::PointXYZ> filter;
    filter.setLeafSize(0.2f, 0.2f, 0.2f);
    filter.setInputCloud(source);
    filter.filter(*input);
  }
  reg->setInputSource(input);
  reg->setInputTarget(reference_cloud);
  Cloud aligned;
  reg->align(aligned, start_pair.guess.cast<float>());
  Row o;
  o.method = chain;
  o.seconds = previous.seconds +
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  o.estimate = reg->getFinalTransformation().cast<double>();
  o.reference = pair.reference;
  const auto e = pcl_mi::io::poseError(o.estimate, pair.reference);
  o.translation_error = e.translation;
  o.travel_error = travelFrameError(o.estimate, pair.reference);
  o.rotation_error = e.rotation_deg;
  o.converged = reg->hasConverged();
  o.evaluations = previous.evaluations;
  if (auto* mi = dynamic_cast<pcl::MutualInformationRegistration<pcl::PointXYZ>*>(reg.get()))
    o.evaluations = mi->getNumberOfEvaluations();
  return o;
}

double
mean(const std::vector<double>& v)
{
  double s = 0;
  for (double x : v)
    s += x;
  return v.empty() ? NAN : s / v.size();
}

bool
succeeded(const Row& r, const std::vector<double>& bound)
{
  return r.translation_error < bound[0] && r.rotation_error < bound[1];
}

/** Width of the summary tables' method column: the longest name, at least 14. */
int
methodColumnWidth(const std::vector<std::string>& methods)
{
  int width = 14;
  for (const auto& m : methods)
    width = std::max(width, static_cast<int>(m.size()));
  return width;
}

/** Prints one table: rows are bins of an initial-error value, columns the methods. */
void
printTable(const std::string& title,
           const std::vector<Row>& rows,
           const std::vector<std::string>& methods,
           double bin_width,
           int bins,
           const char* unit,
           const std::function<double(const Row&)>& key,
           const std::function<double(const std::vector<const Row*>&)>& statistic,
           const char* format)
{
  // Each column is as wide as its method's name (chains are long), at least 10.
  std::vector<int> width;
  for (const auto& m : methods)
    width.push_back(std::max(10, static_cast<int>(m.size())));
  std::printf("\n%s\n%-10s", title.c_str(), "bin");
  for (std::size_t m = 0; m < methods.size(); ++m)
    std::printf(" %*s", width[m], methods[m].c_str());
  std::printf(" %6s\n", "pairs");
  for (int b = 0; b < bins; ++b) {
    const double lo = b * bin_width, hi = (b + 1) * bin_width;
    std::vector<std::vector<const Row*>> per_method(methods.size());
    for (const auto& r : rows) {
      const double k = key(r);
      if (k < lo || k >= hi)
        continue;
      for (std::size_t m = 0; m < methods.size(); ++m)
        if (r.method == methods[m])
          per_method[m].push_back(&r);
    }
    if (per_method.front().empty())
      continue;
    char label[32];
    std::snprintf(label, sizeof(label), "%g-%g %s", lo, hi, unit);
    std::printf("%-10s", label);
    for (std::size_t m = 0; m < methods.size(); ++m) {
      char cell[64] = "-";
      if (!per_method[m].empty())
        std::snprintf(cell, sizeof(cell), format, statistic(per_method[m]));
      const char* text = cell + std::strspn(cell, " ");
      std::printf(" %*s", width[m], text);
    }
    std::printf(" %6zu\n", per_method.front().size());
  }
}

/** Mean signed error of the successful rows, per method and direction, as a percentage of
 * the pair's reference translation: a method that overshoots or drifts sideways shows it here
 * where the unsigned means hide it, and a bias that every method shares points at the
 * reference poses (e.g. the calibration that brings them into the sensor frame) rather than
 * at a method. The directions stay apart because a disagreement with the reference about
 * where the later scan is keeps its sign along and left of the motion when the pair is run
 * backwards, but flips it up: a scan lower than the reference says makes the forward motion
 * descend and the backward one climb. */
void
printBias(const std::vector<Row>& rows,
          const std::vector<std::string>& methods,
          const std::vector<double>& bound)
{
  bool header = false;
  const int name_width = methodColumnWidth(methods);
  for (const auto& m : methods)
    for (const char* direction : {"forward", "backward"}) {
      std::vector<double> along, left, up;
      for (const auto& row : rows) {
        if (row.method != m || row.direction != direction || !succeeded(row, bound) ||
            !row.travel_error.allFinite())
          continue;
        const Eigen::Vector3d percent = 100.0 * row.travel_error / row.true_translation;
        along.push_back(percent[0]);
        left.push_back(percent[1]);
        up.push_back(percent[2]);
      }
      if (along.empty())
        continue;
      if (!header) {
        std::printf("\nMean signed translation error of the successful rows [%% of the "
                    "reference translation]\n%-*s %-9s %6s %9s %9s %9s\n",
                    name_width, "method", "direction", "rows", "along", "left", "up");
        header = true;
      }
      std::printf("%-*s %-9s %6zu %+9.3f %+9.3f %+9.3f\n", name_width, m.c_str(), direction,
                  along.size(), mean(along), mean(left), mean(up));
    }
  if (header)
    std::printf("(along: + = beyond the reference motion; left of and above the direction of "
                "motion, z up)\n");
}

void
printTables(const std::vector<Row>& rows,
            const std::vector<std::string>& methods,
            const std::vector<double>& bound)
{
  auto by_translation = [](const Row& r) { return r.initial_translation; };
  auto by_rotation = [](const Row& r) { return r.initial_rotation; };
  auto mean_of = [](double Row::*field) {
    return [field](const std::vector<const Row*>& v) {
      std::vector<double> x;
      for (const Row* r : v)
        x.push_back(r->*field);
      return mean(x);
    };
  };
  auto median_seconds = [](const std::vector<const Row*>& v) {
    std::vector<double> x;
    for (const Row* r : v)
      x.push_back(r->seconds);
    return median(x);
  };
  auto success_rate = [&](const std::vector<const Row*>& v) {
    int ok = 0;
    for (const Row* r : v)
      ok += succeeded(*r, bound);
    return 100.0 * ok / v.size();
  };
  printTable("Mean translation error [m] by initial translation error", rows, methods, 1.0,
             40, "m", by_translation, mean_of(&Row::translation_error), " %10.3f");
  printTable("Mean rotation error [deg] by initial rotation error", rows, methods, 2.0, 90,
             "deg", by_rotation, mean_of(&Row::rotation_error), " %10.3f");
  printTable("Median runtime [s] by initial translation error", rows, methods, 1.0, 40, "m",
             by_translation, median_seconds, " %10.3f");
  char title[128];
  std::snprintf(title, sizeof(title),
                "Success rate [%%] (< %.2f m and < %.2f deg) by initial translation error",
                bound[0], bound[1]);
  printTable(title, rows, methods, 1.0, 40, "m", by_translation, success_rate, " %10.1f");

  const int name_width = methodColumnWidth(methods);
  std::printf("\n%-*s %6s %9s %9s %9s %9s %10s %10s %8s\n", name_width, "method", "rows",
              "success", "mean_t", "mean_r", "max_t", "median_s", "mean_evals", "vs_first");
  double first_time = NAN;
  for (const auto& m : methods) {
    std::vector<double> t, r, s, ev;
    int ok = 0;
    for (const auto& row : rows) {
      if (row.method != m)
        continue;
      t.push_back(row.translation_error);
      r.push_back(row.rotation_error);
      s.push_back(row.seconds);
      ev.push_back(row.evaluations);
      ok += succeeded(row, bound);
    }
    if (t.empty())
      continue;
    if (std::isnan(first_time))
      first_time = median(s);
    std::printf("%-*s %6zu %8.1f%% %9.3f %9.3f %9.3f %10.3f %10.1f %7.1fx\n", name_width, m.c_str(),
                t.size(), 100.0 * ok / t.size(), mean(t), mean(r),
                *std::max_element(t.begin(), t.end()), median(s), mean(ev),
                median(s) / first_time);
  }
  std::printf("(errors in m and deg; vs_first: median time relative to %s)\n",
              methods.front().c_str());
  printBias(rows, methods, bound);
}

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
      "  -sequences 00,02      sequences (default: 00,01,02,05,08)\n"
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
           {"-shard", OptionValue::Text}},
          pcl_mi::apps::miOptionTable(pcl_mi::apps::MiOptionSet::Tuning)));
  if (!bad_option.empty()) {
    print_error("pcl_mi_compare: %s\n", bad_option.c_str());
    return 2;
  }
  std::string root, sequences_arg = "00,01,02,05,08", poses_kind = "auto";
  std::string methods_arg = "mi-varz,mi-n,gicp,ndt", directions = "both", csv_path, pairs_arg;
  std::string shard_arg;
  int frames = 10, stride = 1, seed = 1, repeat = 1, shuffle_seed = 0;
  double max_yaw = 20.0;
  std::vector<double> distance{1.0, 10.0}, perturb, success{0.5, 2.0};
  pcl::console::parse_argument(argc, argv, "-kitti", root);
  pcl::console::parse_argument(argc, argv, "-sequences", sequences_arg);
  pcl::console::parse_argument(argc, argv, "-poses", poses_kind);
  if (pcl_mi::apps::kittiPosesPath("", "", poses_kind).empty()) {
    print_error("pcl_mi_compare: -poses must be semantic, gt or auto, got '%s'\n",
                poses_kind.c_str());
    return 1;
  }
  pcl::console::parse_argument(argc, argv, "-methods", methods_arg);
  pcl::console::parse_argument(argc, argv, "-directions", directions);
  pcl::console::parse_argument(argc, argv, "-csv", csv_path);
  pcl::console::parse_argument(argc, argv, "-pairs", pairs_arg);
  pcl::console::parse_argument(argc, argv, "-shard", shard_arg);
  pcl::console::parse_argument(argc, argv, "-frames", frames);
  pcl::console::parse_argument(argc, argv, "-stride", stride);
  pcl::console::parse_argument(argc, argv, "-seed", seed);
  pcl::console::parse_argument(argc, argv, "-repeat", repeat);
  pcl::console::parse_argument(argc, argv, "-shuffle", shuffle_seed);
  pcl::console::parse_argument(argc, argv, "-max_yaw", max_yaw);
  const MiArguments mi{argc, argv};
  {
    pcl_mi::Parameters p;
    int max_iterations = pcl_mi::kDefaultMaxIterations;
    const std::string invalid = pcl_mi::apps::applyMiOptions(argc, argv, p, max_iterations);
    if (!invalid.empty()) {
      print_error("pcl_mi_compare: %s\n", invalid.c_str());
      return 1;
    }
  }
  pcl::console::parse_x_arguments(argc, argv, "-distance", distance);
  pcl::console::parse_x_arguments(argc, argv, "-perturb", perturb);
  pcl::console::parse_x_arguments(argc, argv, "-success", success);
  const auto methods = split(methods_arg, ',');
  for (const auto& m : methods)
    if (!knownMethod(m, mi)) {
      print_error("pcl_mi_compare: unknown method '%s'\n", m.c_str());
      return 1;
    }
  if (distance.size() != 2 || success.size() != 2 ||
      !(perturb.empty() || perturb.size() == 2 || perturb.size() == 3) || stride < 1 || repeat < 1 ||
      shuffle_seed < 0) {
    print_error("pcl_mi_compare: bad arguments (see -h)\n");
    return 1;
  }

  // Merge mode: combine shard CSVs and print the tables.
  const int merge_at = pcl::console::find_argument(argc, argv, "-merge");
  if (merge_at >= 0) {
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
    if (!csv_path.empty()) {
      std::ofstream csv(csv_path);
      csv << csvHeader(true) << '\n';
      for (const auto& r : rows)
        writeRow(csv, r);
    }
    std::vector<std::string> present;
    for (const auto& m : methods)
      if (std::any_of(rows.begin(), rows.end(), [&](const Row& r) { return r.method == m; }))
        present.push_back(m);
    if (present.empty()) {
      print_error("pcl_mi_compare: the rows hold none of the methods %s\n", methods_arg.c_str());
      return 1;
    }
    printTables(rows, present, success);
    return 0;
  }

  int shard = 1, shards = 1;
  if (!shard_arg.empty() &&
      (std::sscanf(shard_arg.c_str(), "%d/%d", &shard, &shards) != 2 || shards < 1 ||
       shard < 1 || shard > shards)) {
    print_error("pcl_mi_compare: -shard takes K/N with 1 <= K <= N, got '%s'\n",
                shard_arg.c_str());
    return 1;
  }
  std::map<std::tuple<std::string, int, int>, bool> wanted_pairs;
  for (const auto& p : split(pairs_arg, ',')) {
    const auto sij = split(p, ':');
    if (sij.size() != 3) {
      print_error("pcl_mi_compare: -pairs takes SS:i:j items\n");
      return 1;
    }
    wanted_pairs[{sij[0], std::stoi(sij[1]), std::stoi(sij[2])}] = true;
  }

  // Candidate pairs in their forward direction (source = the later scan), from KITTI or
  // from a list.
  std::vector<Pair> forward_pairs;
  std::string list_path;
  if (pcl::console::parse_argument(argc, argv, "-list", list_path) > 0) {
    std::string error;
    if (!readPairList(list_path, forward_pairs, error)) {
      print_error("pcl_mi_compare: %s\n", error.c_str());
      return 1;
    }
  }
  else {
    if (root.empty()) {
      print_error("pcl_mi_compare: -kitti DIR or -list FILE is required (see -h)\n");
      return 1;
    }
    for (const auto& seq : split(sequences_arg, ',')) {
      Eigen::Matrix4d tr;
      std::vector<Eigen::Matrix4d> poses;
      std::string error =
          pcl_mi::kitti::loadCalibrationTr(root + "/sequences/" + seq + "/calib.txt", tr);
      if (error.empty()) {
        const std::string poses_path = pcl_mi::apps::kittiPosesPath(root, seq, poses_kind);
        error = pcl_mi::kitti::loadPoses(poses_path, poses);
        if (error.empty())
          print_info("pcl_mi_compare: sequence %s: reference poses from %s\n", seq.c_str(),
                     poses_path.c_str());
      }
      if (!error.empty()) {
        print_error("pcl_mi_compare: %s\n", error.c_str());
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
          Pair p;
          p.sequence = seq;
          p.target_frame = i;
          p.source_frame = j;
          p.target_path = pcl_mi::kitti::scanPath(root, seq, i);
          p.source_path = pcl_mi::kitti::scanPath(root, seq, j);
          p.reference = t_ij;
          forward_pairs.push_back(p);
        }
    }
  }

  // Every shard enumerates the same pairs and draws the same perturbations, then keeps its
  // share, so shards together give exactly the rows of one unsharded run.
  std::mt19937 rng(seed);
  std::vector<Pair> pairs;
  std::map<std::string, Cloud::Ptr> clouds;
  int candidate = 0, enumerated = 0;
  for (const Pair& forward : forward_pairs) {
    if (candidate++ % stride)
      continue;
    for (int dir = 0; dir < 2; ++dir) {
      if ((dir == 0 && directions == "backward") || (dir == 1 && directions == "forward"))
        continue;
      Pair p = forward;
      if (dir == 1) { // source = the earlier scan: the motion points backwards
        p.backward = true;
        std::swap(p.source_frame, p.target_frame);
        std::swap(p.source_path, p.target_path);
        p.reference = forward.reference.inverse();
      }
      p.guess = Eigen::Matrix4d::Identity();
      if (!perturb.empty()) {
        std::uniform_real_distribution<double> unit(0.0, 1.0);
        const double a = 2.0 * M_PI * unit(rng);
        const double t = perturb.size() == 2
                             ? perturb[0]
                             : perturb[0] + (perturb[1] - perturb[0]) * unit(rng);
        const double yaw_max = perturb.back();
        const double yaw = perturb.size() == 2 ? (unit(rng) < 0.5 ? -yaw_max : yaw_max)
                                               : yaw_max * (2.0 * unit(rng) - 1.0);
        Eigen::Affine3d d = Eigen::Translation3d(t * std::cos(a), t * std::sin(a), 0.0) *
                            Eigen::AngleAxisd(yaw * M_PI / 180.0, Eigen::Vector3d::UnitZ());
        p.guess = d.matrix() * p.reference;
      }
      if (enumerated++ % shards != shard - 1)
        continue;
      pairs.push_back(p);
      for (const std::string& path : {p.source_path, p.target_path}) {
        if (clouds.count(path))
          continue;
        pcl::PointCloud<pcl::PointXYZI> xyzi;
        const std::string error = pcl_mi::io::loadCloud(path, xyzi);
        if (!error.empty()) {
          print_error("pcl_mi_compare: %s\n", error.c_str());
          return 1;
        }
        auto cloud = pcl::make_shared<Cloud>();
        pcl::copyPointCloud(xyzi, *cloud);
        clouds[path] = cloud;
      }
    }
  }
  if (pairs.empty()) {
    print_error("pcl_mi_compare: no pair matches the selection\n");
    return 1;
  }
  // After the shard's share is taken: shuffling changes the order, never the rows.
  if (shuffle_seed > 0)
    std::shuffle(pairs.begin(), pairs.end(), std::mt19937(static_cast<unsigned>(shuffle_seed)));
  print_info("pcl_mi_compare: %zu alignments per method (%s guess, shard %d/%d%s), methods %s\n",
             pairs.size(), perturb.empty() ? "identity" : "perturbed", shard, shards,
             shuffle_seed > 0 ? ", shuffled" : "", methods_arg.c_str());

  std::ofstream csv;
  if (!csv_path.empty()) {
    csv.open(csv_path);
    if (!csv) {
      print_error("pcl_mi_compare: cannot write '%s'\n", csv_path.c_str());
      return 1;
    }
    csv << csvHeader(true) << '\n';
  }
  std::vector<Row> rows;
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
    for (const auto& m : methods) {
      Row row = runMethod(m, src, tgt, p, mi);
      if (repeat > 1) { // report the median time; the results are identical every run
        std::vector<double> seconds{row.seconds};
        for (int r = 1; r < repeat; ++r)
          seconds.push_back(runMethod(m, src, tgt, p, mi).seconds);
        std::nth_element(seconds.begin(), seconds.begin() + repeat / 2, seconds.end());
        row.seconds = seconds[static_cast<std::size_t>(repeat / 2)];
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
  printTables(rows, methods, success);
  return 0;
}

} // namespace

int
main(int argc, char** argv)
{
  return pcl_mi::apps::guardedMain("pcl_mi_compare", [&] { return run(argc, argv); });
}
