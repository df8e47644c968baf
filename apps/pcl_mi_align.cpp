/*
 * pcl_mi_align: aligns a source scan onto a target scan by mutual information and writes
 * the result for pcl_viewer.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "app_util.h"
#include "mi_options.h"

#include <pcl_mi/io.h>
#include <pcl_mi/mutual_information_registration.h>

#include <pcl/common/transforms.h>
#include <pcl/console/parse.h>
#include <pcl/console/print.h>

#ifdef PCL_MI_WITH_VISUALIZATION
#include "align_view.h"

#include <dlfcn.h>
#include <unistd.h>
#endif

#include <Eigen/Geometry>

#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

using pcl::console::print_error;
using pcl::console::print_info;
using pcl::console::print_value;

namespace {

void
printHelp(const char* program)
{
  print_info(
      "Aligns SOURCE onto TARGET by maximising the mutual information of voxel features.\n"
      "\n"
      "Usage: %s SOURCE TARGET [options]\n"
      "  SOURCE, TARGET        .pcd, .ply or KITTI Velodyne .bin (float32 x y z reflectance)\n"
      "Options:\n"
      "  -guess tx,ty,tz,roll,pitch,yaw  initial guess, metres and degrees (default 0)\n"
      "  -guess_file FILE      initial guess as a 4x4 (or 3x4) matrix in a text file\n"
      "  -reference FILE       reference source-to-target transform (4x4 or 3x4 text):\n"
      "                        prints the error of the result against it\n"
      "  -transform FILE       also write the final transformation there as 4x4 text (the\n"
      "                        format -guess_file and -reference read)\n"
      "  -aligned FILE         aligned source cloud (default aligned.pcd)\n"
      "  -merged FILE          target (grey) + aligned source (red) as XYZRGB for\n"
      "                        pcl_viewer (default merged.pcd)\n"
      "  -no_output            write no clouds (the transform still goes to -transform)\n"
      "  -view                 show before (guess) and after side by side in a PCL viewer\n"
      "  -screenshot FILE.png  save that side-by-side view as an image (works under Xvfb:\n"
      "                        xvfb-run -a pcl_mi_align ... -screenshot view.png)\n"
      "  -h, --help            this help\n"
      "Exit codes: 0 converged, 3 not converged, 1 failed, 2 bad command line.\n"
      "\n%s",
      program, pcl_mi::apps::miOptionsHelp(pcl_mi::apps::MiOptionSet::All).c_str());
}

Eigen::Matrix4d
transformFromGuess(const Eigen::Matrix<double, 6, 1>& g)
{
  Eigen::Affine3d t = Eigen::Translation3d(g[0], g[1], g[2]) *
                      Eigen::AngleAxisd(g[5], Eigen::Vector3d::UnitZ()) *
                      Eigen::AngleAxisd(g[4], Eigen::Vector3d::UnitY()) *
                      Eigen::AngleAxisd(g[3], Eigen::Vector3d::UnitX());
  return t.matrix();
}

/** Reads \a flag's tx,ty,tz,roll,pitch,yaw (angles in degrees) into \a out, angles in
 * radians. Returns -1 when the flag is absent, 1 when read, 0 when malformed (said why). */
int
parsePoseVector(int argc, char** argv, const char* flag, Eigen::Matrix<double, 6, 1>& out)
{
  std::vector<double> values;
  if (pcl::console::parse_x_arguments(argc, argv, flag, values) < 0)
    return -1;
  if (!pcl_mi::apps::poseVectorFromDegrees(values, out)) {
    print_error("pcl_mi_align: %s takes 6 comma-separated values, got %zu\n", flag,
                values.size());
    return 0;
  }
  return 1;
}

/** Shows (or, with \a screenshot, saves) target + source under the guess on the left and
 * target + aligned source on the right, seen from above, with the viewer module
 * (apps/align_view.cpp), loaded now: beside the app, else where it is installed. */
bool
showBeforeAfter(const pcl::PointCloud<pcl::PointXYZI>::ConstPtr& target,
                const pcl::PointCloud<pcl::PointXYZI>::ConstPtr& before,
                const pcl::PointCloud<pcl::PointXYZI>::ConstPtr& after,
                const std::string& screenshot)
{
#ifdef PCL_MI_WITH_VISUALIZATION
  char exe[4096];
  const ssize_t n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
  const std::string app = n > 0 ? std::string(exe, static_cast<std::size_t>(n)) : std::string();
  const std::string app_dir = app.substr(0, app.rfind('/') + 1);
  std::string tried;
  void* module = nullptr;
  for (const std::string& path :
       {app_dir + PCL_MI_VIEW_MODULE_FILE,
        app_dir + PCL_MI_VIEW_MODULE_DIR + "/" + PCL_MI_VIEW_MODULE_FILE}) {
    module = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (module)
      break;
    const char* why = dlerror();
    tried += "\n  " + (why ? std::string(why) : path);
  }
  const auto show = module ? reinterpret_cast<pcl_mi::apps::ShowBeforeAfter>(
                                 dlsym(module, pcl_mi::apps::kShowBeforeAfterSymbol))
                           : nullptr;
  if (!show) {
    print_error("pcl_mi_align: cannot load the viewer module for -view and -screenshot:%s\n",
                module ? "\n  it has no entry point" : tried.c_str());
    return false;
  }
  // Never unloaded: the viewer runs once, at the end of the app.
  return show(target, before, after, screenshot);
#else
  (void)target, (void)before, (void)after, (void)screenshot;
  print_error("pcl_mi_align: built without PCL's visualization module; -view and "
              "-screenshot are unavailable\n");
  return false;
#endif
}

using Cloud = pcl::PointCloud<pcl::PointXYZI>;
using Registration = pcl::MutualInformationRegistration<pcl::PointXYZI>;

/** Help, or a command line this app refuses: the exit code (help 0, refused 2); -1 to go
 * on. */
int
checkCommandLine(int argc, char** argv)
{
  if (pcl::console::find_switch(argc, argv, "-h") ||
      pcl::console::find_switch(argc, argv, "--help")) {
    printHelp(argv[0]);
    return 0;
  }
  if (argc < 3) {
    printHelp(argv[0]);
    return 2;
  }
  using pcl_mi::apps::OptionValue;
  const std::string bad_option = pcl_mi::apps::checkOptions(
      argc, argv, 2,
      pcl_mi::apps::join(
          {{"-guess", OptionValue::Numbers}, {"-guess_file", OptionValue::Text},
           {"-reference", OptionValue::Text}, {"-transform", OptionValue::Text},
           {"-aligned", OptionValue::Text}, {"-merged", OptionValue::Text},
           {"-view", OptionValue::None}, {"-screenshot", OptionValue::Text},
           {"-no_output", OptionValue::None}},
          pcl_mi::apps::miOptionTable(pcl_mi::apps::MiOptionSet::All)));
  if (!bad_option.empty()) {
    print_error("pcl_mi_align: %s\n", bad_option.c_str());
    return 2;
  }
  return -1;
}

/** Reads the transform file \a flag names into \a transform; true when the flag is absent
 * (\a transform untouched, \a given false) or the file was read, false (said why) when not. */
bool
readTransformFile(int argc,
                  char** argv,
                  const char* flag,
                  Eigen::Matrix4d& transform,
                  bool& given)
{
  std::string path;
  given = pcl::console::parse_argument(argc, argv, flag, path) > 0;
  if (!given)
    return true;
  const std::string error = pcl_mi::io::loadTransform(path, transform);
  if (!error.empty())
    print_error("pcl_mi_align: %s\n", error.c_str());
  return error.empty();
}

/** The guess (-guess, then -guess_file over it) and the reference (-reference); false (said
 * why) when one is malformed or unreadable. */
bool
readPoses(int argc,
          char** argv,
          Eigen::Matrix4d& guess,
          Eigen::Matrix4d& reference,
          bool& has_reference)
{
  guess = reference = Eigen::Matrix4d::Identity();
  Eigen::Matrix<double, 6, 1> guess_values;
  switch (parsePoseVector(argc, argv, "-guess", guess_values)) {
  case 0:
    return false;
  case 1:
    guess = transformFromGuess(guess_values);
  }
  bool guess_file_given = false;
  return readTransformFile(argc, argv, "-guess_file", guess, guess_file_given) &&
         readTransformFile(argc, argv, "-reference", reference, has_reference);
}

/** The verdict, the confidence, the restarts of a result the verdict first refused, the
 * alignment of the clouds swapped and the standard deviations of the last alignment, which
 * ran under the iteration cap \a max_iterations. */
void
printVerdict(const Registration& reg, int max_iterations)
{
  print_info("Converged: ");
  const pcl_mi::AlignmentResult& result = reg.getLastResult();
  if (reg.hasConverged()) {
    print_value(result.verification.reverse_confirmed
                    ? "yes (confirmed by the alignment of the clouds swapped)\n"
                    : "yes (search converged, result verified)\n");
  }
  else {
    // getLastError()'s cause, with the cap named as this app takes it.
    const std::string why = pcl_mi::notConvergedCause(
        result, max_iterations, "-max_iterations " + std::to_string(max_iterations));
    print_value("no (%s)\n", pcl_mi::apps::notConvergedKind(result).c_str());
    print_info("Why: ");
    print_value("%s\n", why.c_str());
  }
  const pcl_mi::Verification& v = result.verification;
  print_info("Confidence: ");
  print_value("%.3f", reg.getConfidence());
  const bool degenerate = v.refusal == pcl_mi::Refusal::Degenerate && !v.unsteady;
  print_info(" (probability of < 0.5 m and < 2 deg%s)\n",
             degenerate && v.sensors_in_place
                 ? ", the share of degenerate results that left the sensors in place and were "
                   "right"
             : degenerate ? ", from the evidence at the result: along the free direction the pose "
                            "is only as good as the guess was there"
                          : "");
  // A refused result's restarts: where they end apart, the confidence is no longer the
  // evidence's.
  if (!std::isnan(v.restart_turn_deg)) {
    print_info("Restarts of the refinement from 2 deg turns: ");
    if (std::isinf(v.restart_turn_deg))
      print_value("one left the basin");
    else
      print_value("ended up to %.2f deg and %.3f away", v.restart_turn_deg, v.restart_shift);
    print_info(" (%s)\n", v.unsteady ? "unsteady: the confidence is the share of such results "
                                       "that were right"
                     : v.free_turns_held ? "steady: the refinement holds the turns the surfaces "
                                           "leave free"
                                         : "steady");
  }
  if (!std::isnan(v.reverse_shift)) {
    print_info("The clouds swapped: ");
    print_value("ended %.3f away and %.2f deg from the result", v.reverse_shift,
                v.reverse_turn_deg);
    print_info(" (%s)\n", v.reverse_confirmed
                              ? "confirms it"
                              : ("does not confirm it: " + v.reverse_reason).c_str());
  }
  const Eigen::Matrix<double, 6, 6> covariance = reg.getCovariance();
  if (covariance.diagonal().maxCoeff() > 0.0) {
    const Eigen::Matrix<double, 6, 1> sd = covariance.diagonal().cwiseSqrt();
    print_info("Standard deviations: ");
    print_value("x %.3f, y %.3f, z %.3f m; roll %.3f, pitch %.3f, yaw %.3f deg\n", sd[0], sd[1],
                sd[2], sd[3] * 180.0 / M_PI, sd[4] * 180.0 / M_PI, sd[5] * 180.0 / M_PI);
  }
}

/** What the search did beyond its plain path (the starts a narrow view adds, leveling,
 * runners-up, the reverse search, a shifted optimum) and the refinement's iterations. */
void
printSearchDetails(const Registration& reg, const pcl_mi::Parameters& parameters)
{
  const pcl_mi::AlignmentResult& result = reg.getLastResult();
  if (result.position_starts > 0) {
    print_info("Position starts: ");
    print_value("%d%s\n", result.position_starts,
                result.position_starts > parameters.search.position_starts
                    ? " (narrow field of view)"
                    : "");
  }
  if (result.yaw_starts > 0) {
    print_info("Yaw starts: ");
    print_value("%d (narrow field of view, +-%.0f deg)\n", result.yaw_starts,
                parameters.search.narrow_view_yaw_start * 180.0 / M_PI);
  }
  if (result.scanned_starts > 0) {
    print_info("Scanned starts: ");
    print_value("%d (narrow field of view)\n", result.scanned_starts);
  }
  if (result.refinement_stages > 1) {
    print_info("Refinement stages: ");
    print_value("%d (narrow field of view)\n", result.refinement_stages);
  }
  if (result.leveled) {
    print_info("Leveled: ");
    print_value("yes (the search ran along the target's up direction)\n");
  }
  if (result.runners_up_checked > 0) {
    print_info("Runners-up of the search checked: ");
    print_value("%d, %s\n", result.runners_up_checked,
                result.runner_up_kept
                    ? "one kept (it agrees better with the target on the finest grid)"
                    : "none kept");
  }
  if (result.reverse_search) {
    print_info("Reverse search: ");
    print_value("%s\n", result.reverse_kept
                            ? "kept (an optimum of the target searched onto the source agrees "
                              "better with the target on the finest grid)"
                            : "ran, not kept");
  }
  if (result.shifted_optimum_kept) {
    print_info("Shifted optimum: ");
    print_value("kept (a higher MI on the finest grid a few voxels across, at the same "
                "rotation)\n");
  }
  if (!std::isnan(reg.getVerification().lead)) {
    print_info("Lead over the optima a few voxels across: ");
    print_value("%+.0f %% of the MI (narrow field of view)\n", 100.0 * reg.getVerification().lead);
  }
  if (reg.getNumberOfRefinementIterations() > 0) {
    print_info("Refinement iterations: ");
    print_value("%d\n", reg.getNumberOfRefinementIterations());
  }
}

/** Where the last alignment's time went, stage by stage, and its backend's own stages. */
void
printProfile(const Registration& reg, double seconds)
{
  print_info("Profile (wall-clock, including setInputSource/Target: %.1f ms):\n", seconds * 1e3);
  print_info("  %-16s %8s %10s\n", "stage", "calls", "total ms");
  for (const pcl_mi::StageTiming& stage : reg.getLastResult().stages)
    print_value("  %-16s %8d %10.2f\n", stage.name.c_str(), stage.calls, stage.total_ms);
  print_info("Backend %s, its stages summed over the alignment:\n",
             reg.core().backendName().c_str());
  print_info("  %-30s %8s %10s\n", "stage", "calls", "total ms");
  for (const pcl_mi::StageTiming& stage : reg.getBackendProfile())
    print_value("  %-30s %8d %10.2f\n", stage.name.c_str(), stage.calls, stage.total_ms);
}

/** Writes the aligned source to \a aligned_path and target + aligned source to
 * \a merged_path; false (said why) when either cannot be written. */
bool
writeClouds(const std::string& aligned_path,
            const std::string& merged_path,
            const Cloud& target,
            const Cloud& aligned)
{
  std::string write_error = pcl_mi::io::savePcd(aligned_path, aligned);
  if (write_error.empty())
    write_error = pcl_mi::io::saveMergedPcd(merged_path, target, aligned);
  if (!write_error.empty())
    print_error("pcl_mi_align: %s\n", write_error.c_str());
  return write_error.empty();
}

/** Applies the MI options of the command line to \a reg, and gives the parameters it then
 * has; false (said why) when an option's value is refused. */
bool
configure(int argc, char** argv, Registration& reg, pcl_mi::Parameters& parameters)
{
  parameters = reg.getParameters();
  int max_iterations = reg.getMaximumIterations();
  const std::string invalid =
      pcl_mi::apps::applyMiOptions(argc, argv, parameters, max_iterations);
  if (!invalid.empty()) {
    print_error("pcl_mi_align: %s\n", invalid.c_str());
    return false;
  }
  reg.setParameters(parameters);
  reg.setMaximumIterations(max_iterations);
  return true;
}

/** Prints "Wrote PATH". */
void
printWrote(const std::string& path)
{
  print_info("Wrote ");
  print_value("%s\n", path.c_str());
}

int
run(int argc, char** argv)
{
  const int refused = checkCommandLine(argc, argv);
  if (refused >= 0)
    return refused;
  const std::string source_path = argv[1], target_path = argv[2];
  auto source = pcl::make_shared<Cloud>();
  auto target = pcl::make_shared<Cloud>();
  for (const auto& [path, cloud] : {std::make_pair(source_path, source),
                                    std::make_pair(target_path, target)}) {
    const std::string error = pcl_mi::io::loadCloud(path, *cloud);
    if (!error.empty()) {
      print_error("pcl_mi_align: %s\n", error.c_str());
      return 1;
    }
  }
  Eigen::Matrix4d guess, reference;
  bool has_reference = false;
  if (!readPoses(argc, argv, guess, reference, has_reference))
    return 1;

  // On the heap so that its internal copies of the clouds can go before the outputs are
  // written (large inputs).
  auto registration = std::make_unique<Registration>();
  auto& reg = *registration;
  std::string aligned_path = "aligned.pcd", merged_path = "merged.pcd", transform_path;
  pcl::console::parse_argument(argc, argv, "-transform", transform_path);
  pcl::console::parse_argument(argc, argv, "-aligned", aligned_path);
  pcl::console::parse_argument(argc, argv, "-merged", merged_path);

  pcl_mi::Parameters parameters;
  if (!configure(argc, argv, reg, parameters))
    return 1;
  const bool varz = parameters.grid.feature == pcl_mi::Feature::VarianceZ;

  const auto start = std::chrono::steady_clock::now();
  reg.setInputSource(source);
  reg.setInputTarget(target);
  const double resolution = reg.getResolution();
  print_info("Source: ");
  print_value("%s (%zu points)\n", source_path.c_str(), source->size());
  print_info("Target: ");
  print_value("%s (%zu points)\n", target_path.c_str(), target->size());
  print_info("MI-%s, resolution ", varz ? "VARZ" : "N");
  print_value("%g%s\n", resolution, parameters.grid.resolution == 0.0 ? " (derived)" : "");
  Cloud aligned;
  reg.align(aligned, guess.cast<float>());
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  if (!reg.getLastResult().error.empty()) {
    print_error("pcl_mi_align: alignment failed: %s\n", reg.getLastResult().error.c_str());
    return 1;
  }
  const Eigen::Matrix4d result = reg.getFinalTransformation().cast<double>();
  print_info("Final transformation (source to target):\n");
  for (int r = 0; r < 4; ++r)
    print_value("  %12.6f %12.6f %12.6f %12.6f\n", result(r, 0), result(r, 1), result(r, 2),
                result(r, 3));
  print_info("Mutual information: ");
  print_value("%.5f nats\n", reg.getFinalMutualInformation());
  if (!transform_path.empty()) {
    const std::string transform_error = pcl_mi::io::saveTransform(transform_path, result);
    if (!transform_error.empty()) {
      print_error("pcl_mi_align: %s\n", transform_error.c_str());
      return 1;
    }
  }
  print_info("Iterations: ");
  print_value("%d", reg.getFinalNumIteration());
  print_info(", cost evaluations: ");
  print_value("%d", reg.getNumberOfEvaluations());
  print_info(", time: ");
  print_value("%.3f s\n", seconds);
  printVerdict(reg, reg.getMaximumIterations());
  printSearchDetails(reg, parameters);
  if (pcl::console::find_switch(argc, argv, "-profile"))
    printProfile(reg, seconds);
  if (has_reference) {
    const auto e = pcl_mi::io::poseError(result, reference);
    print_info("Error against reference: ");
    print_value("%.3f m, %.3f deg\n", e.translation, e.rotation_deg);
  }

  const bool converged = reg.hasConverged();
  std::string screenshot;
  pcl::console::parse_argument(argc, argv, "-screenshot", screenshot);
  const bool show = pcl::console::find_switch(argc, argv, "-view") || !screenshot.empty();
  // Large inputs: the registration's copies and (unless shown) the source are not needed
  // for writing, and the merged file is streamed rather than built in memory.
  registration.reset();
  if (!show)
    source.reset();
  const bool write_clouds = !pcl::console::find_switch(argc, argv, "-no_output");
  if (write_clouds && !writeClouds(aligned_path, merged_path, *target, aligned))
    return 1;
  if (show) {
    auto before = pcl::make_shared<Cloud>();
    pcl::transformPointCloud(*source, *before, guess.cast<float>());
    auto after = pcl::make_shared<Cloud>(aligned);
    if (!showBeforeAfter(target, before, after, screenshot))
      return 1;
    if (!screenshot.empty())
      printWrote(screenshot);
  }
  if (!transform_path.empty())
    printWrote(transform_path);
  if (write_clouds) {
    print_info("Wrote ");
    print_value("%s", aligned_path.c_str());
    print_info(" and ");
    print_value("%s", merged_path.c_str());
    print_info(" (view: pcl_viewer %s)\n", merged_path.c_str());
  }
  return converged ? 0 : 3;
}

} // namespace

int
main(int argc, char** argv)
{
  return pcl_mi::apps::guardedMain("pcl_mi_align", [&] { return run(argc, argv); });
}
