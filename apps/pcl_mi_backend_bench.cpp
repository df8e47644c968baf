/*
 * pcl_mi_backend_bench: times the registration engine on each scoring backend (CPU, OpenCL)
 * on KITTI pairs, with the OpenCL kernels' own times per stage. It uses only the
 * PCL-free engine (pcl_mi::RegistrationCore) and reads KITTI .bin scans itself, so it can be
 * built for a GPU machine that has no PCL (scripts/build_backend_bench.sh). A benchmark, not
 * a test: the figures depend on the machine and its load.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "app_util.h"

#include <pcl_mi/kitti.h>
#include <pcl_mi/registration_core.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

using pcl_mi::apps::median;
using pcl_mi::apps::split;

namespace {

struct Pair {
  std::string sequence;
  int target_frame = 0, source_frame = 0;
  pcl_mi::PointList target, source;
  Eigen::Matrix4d reference; // source to target
};

double
rotationErrorDeg(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b)
{
  const Eigen::Matrix3d r = a.topLeftCorner<3, 3>().transpose() * b.topLeftCorner<3, 3>();
  const double c = std::clamp((r.trace() - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c) * 180.0 / M_PI;
}

pcl_mi::Parameters
configParameters(const std::string& name, std::string& error)
{
  if (name == "default")
    return pcl_mi::Parameters();
  if (name == "paper")
    return pcl_mi::Parameters::paper();
  error = "unknown configuration '" + name + "' (default, paper)";
  return pcl_mi::Parameters();
}

void
usage()
{
  std::printf(
      "Usage: pcl_mi_backend_bench [options]\n"
      "Times RegistrationCore alignments (both clouds set, then align) and single cost\n"
      "evaluations per backend on KITTI pairs (both directions, identity guess), and prints\n"
      "the OpenCL kernels' times.\n"
      "  -kitti DIR           KITTI odometry root (default data/kitti)\n"
      "  -pairs S:I:J,...     pairs as sequence:target frame:source frame (default\n"
      "                       00:0:9,02:0:6, the bundled pairs)\n"
      "  -poses semantic|gt|auto   reference poses: sequences/SS/poses.txt, poses/SS.txt,\n"
      "                       or the first where it exists, else the second (default auto)\n"
      "  -backends LIST       from cpu, opencl (batching auto), opencl-batch (always in\n"
      "                       batches), opencl-single (one pose per round trip)\n"
      "                       (default cpu,opencl)\n"
      "  -configs LIST        default (pcl_mi's defaults), paper (Parameters::paper(): 1 m\n"
      "                       grid, every point in every evaluation) (default both)\n"
      "  -repeat N            alignments per pair, direction, backend and configuration;\n"
      "                       the first is a warm-up and not timed (default 5)\n"
      "  -evaluations N       single cost evaluations timed per row at poses drawn around\n"
      "                       the reference, +-2 m and +-5 deg (default 200)\n"
      "  -threads N           Parameters::num_threads (default: the configuration's)\n"
      "  -opencl_device P,D   OpenCL platform and device (default: first GPU, else first)\n");
}

struct Row {
  std::string pair, config, backend;
  double median_align_s = 0.0, error_m = 0.0, error_deg = 0.0, evaluations = 0.0;
  double median_eval_us = 0.0, first_s = 0.0;
  std::uint64_t histogram_hash = 0; // of the joint histograms at every evaluation pose
  Eigen::Matrix4d transformation;
  std::vector<pcl_mi::StageTiming> profile; // of the timed cost evaluations
  std::vector<pcl_mi::StageTiming> align_stages, align_profile; // of the last alignment
  std::string backend_name;
};

/** The command line. */
struct Options {
  std::string root = "data/kitti", pairs = "00:0:9,02:0:6", poses_kind = "auto";
  std::vector<std::string> backends, configs; // -backends, -configs: see parseOptions()
  int repeat = 5, evaluations = 200, threads = 0;
  int platform = -1, device = -1; // OpenCL
};

/** Reads the command line into \a o: the exit code where it ends the run (help 0, a bad
 * option 1, said why), else -1. */
int
parseOptions(int argc, char** argv, Options& o)
{
  std::string backends = "cpu,opencl", configs = "default,paper", device;
  const std::map<std::string, std::string*> texts = {
      {"-kitti", &o.root},           {"-pairs", &o.pairs},     {"-poses", &o.poses_kind},
      {"-backends", &backends},      {"-configs", &configs},   {"-opencl_device", &device}};
  const std::map<std::string, int*> numbers = {
      {"-repeat", &o.repeat}, {"-evaluations", &o.evaluations}, {"-threads", &o.threads}};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      usage();
      return 0;
    }
    if (!texts.count(a) && !numbers.count(a)) {
      std::fprintf(stderr, "pcl_mi_backend_bench: unknown option '%s' (see -h)\n", a.c_str());
      return 1;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "pcl_mi_backend_bench: %s needs a value\n", a.c_str());
      return 1;
    }
    const std::string value = argv[++i];
    if (texts.count(a))
      *texts.at(a) = value;
    else
      *numbers.at(a) = std::atoi(value.c_str());
  }
  o.backends = split(backends, ',');
  o.configs = split(configs, ',');
  if (o.repeat < 2 || o.evaluations < 1 || o.threads < 0 ||
      pcl_mi::apps::kittiPosesPath("", "", o.poses_kind).empty()) {
    std::fprintf(stderr, "pcl_mi_backend_bench: -repeat must be >= 2, -evaluations >= 1, "
                         "-threads >= 0, -poses semantic, gt or auto\n");
    return 1;
  }
  if (!device.empty() && std::sscanf(device.c_str(), "%d,%d", &o.platform, &o.device) != 2) {
    std::fprintf(stderr, "pcl_mi_backend_bench: -opencl_device expects P,D\n");
    return 1;
  }
  return -1;
}

/** Every pair of \a o, each in both directions (the backward one: source = the earlier
 * scan), scans and reference read once; false (said why) when one cannot be read. */
bool
loadPairs(const Options& o, std::vector<Pair>& pairs)
{
  std::map<std::string, std::pair<Eigen::Matrix4d, std::vector<Eigen::Matrix4d>>> sequences;
  for (const auto& spec : split(o.pairs, ',')) {
    const auto f = split(spec, ':');
    if (f.size() != 3) {
      std::fprintf(stderr, "pcl_mi_backend_bench: bad pair '%s' (S:I:J)\n", spec.c_str());
      return false;
    }
    Pair p;
    p.sequence = f[0];
    p.target_frame = std::atoi(f[1].c_str());
    p.source_frame = std::atoi(f[2].c_str());
    if (!sequences.count(p.sequence)) {
      Eigen::Matrix4d tr;
      std::vector<Eigen::Matrix4d> poses;
      std::string error = pcl_mi::kitti::loadCalibrationTr(
          o.root + "/sequences/" + p.sequence + "/calib.txt", tr);
      if (error.empty())
        error = pcl_mi::kitti::loadPoses(
            pcl_mi::apps::kittiPosesPath(o.root, p.sequence, o.poses_kind), poses);
      if (!error.empty()) {
        std::fprintf(stderr, "pcl_mi_backend_bench: %s\n", error.c_str());
        return false;
      }
      sequences[p.sequence] = {tr, poses};
    }
    const auto& [tr, poses] = sequences[p.sequence];
    if (std::max(p.target_frame, p.source_frame) >= static_cast<int>(poses.size()) ||
        std::min(p.target_frame, p.source_frame) < 0) {
      std::fprintf(stderr, "pcl_mi_backend_bench: pair '%s' is outside the poses file\n",
                   spec.c_str());
      return false;
    }
    p.reference = pcl_mi::kitti::relativeVelodyneTransform(tr, poses[p.target_frame],
                                                           poses[p.source_frame]);
    std::string error = pcl_mi::kitti::loadScan(
        pcl_mi::kitti::scanPath(o.root, p.sequence, p.target_frame), p.target);
    if (error.empty())
      error = pcl_mi::kitti::loadScan(
          pcl_mi::kitti::scanPath(o.root, p.sequence, p.source_frame), p.source);
    if (!error.empty()) {
      std::fprintf(stderr, "pcl_mi_backend_bench: %s\n", error.c_str());
      return false;
    }
    pairs.push_back(p);
    Pair b;
    b.sequence = p.sequence;
    b.target_frame = p.source_frame;
    b.source_frame = p.target_frame;
    b.target = p.source;
    b.source = p.target;
    b.reference = p.reference.inverse();
    pairs.push_back(b);
  }
  return true;
}

/** The parameters of configuration \a config on backend \a backend of \a o (opencl-batch and
 * opencl-single: OpenCL with Batching::On and Off); false (said why) for an unknown name. */
bool
backendParameters(const Options& o,
                  const std::string& config,
                  const std::string& backend,
                  pcl_mi::Parameters& parameters)
{
  std::string error;
  parameters = configParameters(config, error);
  std::string backend_type = backend;
  if (backend == "opencl-batch" || backend == "opencl-single") {
    backend_type = "opencl";
    parameters.backend.batching =
        backend == "opencl-batch" ? pcl_mi::Batching::On : pcl_mi::Batching::Off;
  }
  if (!error.empty() || !pcl_mi::parseBackend(backend_type, parameters.backend.type)) {
    std::fprintf(stderr, "pcl_mi_backend_bench: %s\n",
                 error.empty() ? ("unknown backend '" + backend + "'").c_str() : error.c_str());
    return false;
  }
  parameters.backend.opencl_platform = o.platform;
  parameters.backend.opencl_device = o.device;
  if (o.threads > 0)
    parameters.num_threads = o.threads;
  return true;
}

/** \a count poses around \a reference, +-2 m and +-5 deg, the same for every backend. */
std::vector<Eigen::Matrix4d>
posesAround(const Eigen::Matrix4d& reference, int count)
{
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<Eigen::Matrix4d> poses;
  for (int e = 0; e < count; ++e) {
    const Eigen::Affine3d delta =
        Eigen::Translation3d(2.0 * unit(rng), 2.0 * unit(rng), 0.2 * unit(rng)) *
        Eigen::AngleAxisd(5.0 * M_PI / 180.0 * unit(rng), Eigen::Vector3d::UnitZ());
    poses.push_back(delta.matrix() * reference);
  }
  return poses;
}

/** Evaluates the cost at every pose of \a poses, each timed into \a microseconds (if not
 * null); false (said why) when an evaluation fails. */
bool
evaluateAll(pcl_mi::RegistrationCore& core,
            const std::vector<Eigen::Matrix4d>& poses,
            std::vector<double>* microseconds)
{
  for (const Eigen::Matrix4d& pose : poses) {
    const auto t0 = std::chrono::steady_clock::now();
    std::string error;
    if (core.evaluate(pose, &error) < 0.0) {
      std::fprintf(stderr, "pcl_mi_backend_bench: %s\n", error.c_str());
      return false;
    }
    if (microseconds)
      microseconds->push_back(
          1e6 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return true;
}

/** Fingerprint (FNV-1a) of the joint histograms at \a poses, for comparing backends count for
 * count; false (said why) when one cannot be computed. */
bool
histogramHash(pcl_mi::RegistrationCore& core,
              const std::vector<Eigen::Matrix4d>& poses,
              std::uint64_t& hash)
{
  hash = 1469598103934665603ull;
  pcl_mi::JointHistogram histogram;
  for (const Eigen::Matrix4d& pose : poses) {
    std::string error;
    if (!core.jointHistogram(pose, histogram, &error)) {
      std::fprintf(stderr, "pcl_mi_backend_bench: %s\n", error.c_str());
      return false;
    }
    for (const std::uint32_t c : histogram.counts)
      hash = (hash ^ c) * 1099511628211ull;
    hash = (hash ^ histogram.overlap_voxels) * 1099511628211ull;
  }
  return true;
}

/** Times \a o.repeat alignments of \a p (the first a warm-up), then single evaluations, the
 * histograms' fingerprint and the backend's profile, into \a row; false (said why) on a
 * failure. */
bool
measure(const Options& o, const Pair& p, const pcl_mi::Parameters& parameters, Row& row)
{
  pcl_mi::RegistrationCore core;
  const std::string invalid = core.setParameters(parameters);
  if (!invalid.empty()) {
    std::fprintf(stderr, "pcl_mi_backend_bench: %s\n", invalid.c_str());
    return false;
  }
  std::vector<double> align_s, evals;
  pcl_mi::AlignmentResult result;
  for (int r = 0; r < o.repeat; ++r) {
    // What a pipeline pays per new pair: both clouds handed over (target features, device
    // buffers) and the alignment.
    const auto t0 = std::chrono::steady_clock::now();
    core.setTarget(p.target);
    core.setSource(p.source);
    result = core.align(Eigen::Matrix4d::Identity());
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!result.error.empty()) {
      std::fprintf(stderr, "pcl_mi_backend_bench: %s %s: %s\n", row.pair.c_str(),
                   row.backend.c_str(), result.error.c_str());
      return false;
    }
    if (r == 0)
      row.first_s = s;
    else { // the first alignment pays the backend's start-up
      align_s.push_back(s);
      evals.push_back(result.evaluations);
    }
  }
  row.backend_name = core.backendName();
  row.median_align_s = median(align_s);
  row.transformation = result.transformation;
  row.align_stages = result.stages;
  row.evaluations = median(evals);
  row.error_m =
      (result.transformation.topRightCorner<3, 1>() - p.reference.topRightCorner<3, 1>()).norm();
  row.error_deg = rotationErrorDeg(result.transformation, p.reference);

  const std::vector<Eigen::Matrix4d> poses = posesAround(p.reference, o.evaluations);
  std::vector<double> eval_us;
  if (!evaluateAll(core, poses, &eval_us) || !histogramHash(core, poses, row.histogram_hash))
    return false;
  row.median_eval_us = median(eval_us);

  // The backend stage tables come from a second pass with device profiling on: its events
  // slow every evaluation down, so the timings above ran without.
  pcl_mi::Parameters profiled = parameters;
  profiled.backend.profile_device = true;
  core.setParameters(profiled); // new backends, the same target and source
  core.align(Eigen::Matrix4d::Identity());
  row.align_profile = core.backendProfile();
  core.resetBackendProfile();
  if (!evaluateAll(core, poses, nullptr))
    return false;
  row.profile = core.backendProfile();
  return true;
}

/** One line per row; returns how many rows' histograms differ from another backend's on the
 * same pair and configuration. */
int
printRows(const Options& o, const std::vector<Row>& rows)
{
  std::printf("\nAlignments (identity guess; median of %d after a warm-up) and single cost "
              "evaluations (median of %d)\n",
              o.repeat - 1, o.evaluations);
  // "pose diff": largest difference of the final transformation's entries from another
  // backend's on the same pair and configuration; "histograms": whether the joint
  // histograms at every evaluation pose equal that backend's, count for count. The
  // backends' arithmetic is identical, so the diff should be 0 and the histograms equal.
  std::printf("%-11s %-7s %-7s %8s %8s %6s %7s %7s %9s %9s %10s  %s\n", "pair", "config",
              "backend", "first s", "align s", "evals", "err m", "err deg", "eval us",
              "pose diff", "histograms", "device");
  int mismatches = 0;
  for (const auto& r : rows) {
    double diff = 0.0;
    const char* same = "-";
    for (const auto& f : rows)
      if (&f != &r && f.pair == r.pair && f.config == r.config) {
        diff = (f.transformation - r.transformation).cwiseAbs().maxCoeff();
        same = f.histogram_hash == r.histogram_hash ? "equal" : "DIFFER";
        mismatches += f.histogram_hash != r.histogram_hash;
        break;
      }
    std::printf("%-11s %-7s %-7s %8.4f %8.4f %6.0f %7.3f %7.3f %9.1f %9.2g %10s  %s\n",
                r.pair.c_str(), r.config.c_str(), r.backend.c_str(), r.first_s,
                r.median_align_s, r.evaluations, r.error_m, r.error_deg, r.median_eval_us,
                diff, same, r.backend_name.c_str());
  }
  return mismatches;
}

/** Medians over pairs per (configuration, backend), and ratios to the first backend. */
void
printPerBackend(const Options& o, const std::vector<Row>& rows)
{
  std::printf("\nPer configuration and backend (median over pairs and directions)\n");
  std::printf("%-8s %-7s %9s %10s %9s\n", "config", "backend", "align s", "eval us",
              "vs first");
  for (const auto& config : o.configs) {
    double first = 0.0;
    for (const auto& backend : o.backends) {
      std::vector<double> a, e;
      for (const auto& r : rows)
        if (r.config == config && r.backend == backend) {
          a.push_back(r.median_align_s);
          e.push_back(r.median_eval_us);
        }
      const double ma = median(a);
      if (first == 0.0)
        first = ma;
      std::printf("%-8s %-7s %9.4f %10.1f %8.2fx\n", config.c_str(), backend.c_str(), ma,
                  median(e), ma / first);
    }
  }
}

/** The stages in \a member summed over the rows of each configuration and backend: per call
 * (in us) or per row (in ms). */
void
printStageTable(const Options& o,
                const std::vector<Row>& rows,
                const char* title,
                const char* unit,
                std::vector<pcl_mi::StageTiming> Row::*member,
                bool per_call)
{
  std::printf("\n%s\n%-8s %-7s %-32s %8s %10s\n", title, "config", "backend", "stage", "calls",
              unit);
  for (const auto& config : o.configs)
    for (const auto& backend : o.backends) {
      std::vector<std::string> order;
      std::map<std::string, std::pair<long, double>> sum;
      long num_rows = 0;
      for (const auto& r : rows)
        if (r.config == config && r.backend == backend) {
          ++num_rows;
          for (const auto& s : r.*member) {
            if (!sum.count(s.name))
              order.push_back(s.name);
            sum[s.name].first += s.calls;
            sum[s.name].second += s.total_ms;
          }
        }
      for (const auto& name : order) {
        const auto& [calls, ms] = sum[name];
        const double value =
            per_call ? (calls ? 1000.0 * ms / calls : 0.0) : (num_rows ? ms / num_rows : 0.0);
        std::printf("%-8s %-7s %-32s %8ld %10.2f\n", config.c_str(), backend.c_str(),
                    name.c_str(), calls, value);
      }
    }
}

int
run(int argc, char** argv)
{
  Options o;
  const int done = parseOptions(argc, argv, o);
  if (done >= 0)
    return done;
  std::vector<Pair> pairs;
  if (!loadPairs(o, pairs))
    return 1;

  std::vector<Row> rows;
  const std::size_t total = pairs.size() * o.configs.size() * o.backends.size();
  for (const auto& config : o.configs)
    for (const auto& backend : o.backends) {
      pcl_mi::Parameters parameters;
      if (!backendParameters(o, config, backend, parameters))
        return 1;
      for (const auto& p : pairs) {
        Row row;
        row.pair = p.sequence + ":" + std::to_string(p.source_frame) + "->" +
                   std::to_string(p.target_frame);
        row.config = config;
        row.backend = backend;
        std::fprintf(stderr, "[%zu/%zu] %s %s %s ...\n", rows.size() + 1, total,
                     row.pair.c_str(), config.c_str(), backend.c_str());
        if (!measure(o, p, parameters, row))
          return 1;
        rows.push_back(row);
      }
    }

  const int mismatches = printRows(o, rows);
  printPerBackend(o, rows);
  printStageTable(o, rows,
                  "Backend stages of the single evaluations (device profiling on), per call",
                  "us/call", &Row::profile, true);
  printStageTable(o, rows, "Stages of one alignment (the last of each row), mean over pairs",
                  "ms", &Row::align_stages, false);
  printStageTable(o, rows,
                  "Backend work within one alignment (device profiling on), mean over pairs",
                  "ms", &Row::align_profile, false);
  if (mismatches) {
    std::printf("\nThe backends' joint histograms differ (%d rows): a backend bug.\n",
                mismatches);
    return 2;
  }
  return 0;
}

} // namespace

int
main(int argc, char** argv)
{
  return pcl_mi::apps::guardedMain("pcl_mi_backend_bench", [&] { return run(argc, argv); });
}
