/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "mi_options.h"

#include <cstdio>
#include <cstring>

namespace pcl_mi {
namespace apps {

std::vector<Option>
miOptionTable(MiOptionSet set)
{
  std::vector<Option> table = {
      {"-resolution", OptionValue::Number},     {"-steps", OptionValue::Numbers},
      {"-max_iterations", OptionValue::Number}, {"-heading_starts", OptionValue::Number},
      {"-position_starts", OptionValue::Number}, {"-narrow_view_starts", OptionValue::Number},
      {"-levels", OptionValue::Number},         {"-subdivision", OptionValue::Number},
      {"-restarts", OptionValue::Number},       {"-refinement", OptionValue::Text},
      {"-refinement_resolution", OptionValue::Number}, {"-backend", OptionValue::Text},
      {"-opencl_device", OptionValue::Numbers}};
  if (set == MiOptionSet::All) {
    table.push_back({"-profile", OptionValue::None});
    table.push_back({"-feature", OptionValue::Text});
    table.push_back({"-paper", OptionValue::None});
  }
  return table;
}

std::string
miOptionsHelp(MiOptionSet set)
{
  const Parameters d;
  const double deg = 180.0 / M_PI;
  const auto& s = d.search.simplex_steps;
  char text[4096];
  std::snprintf(
      text, sizeof text,
      "MI parameters:\n"
      "  -resolution R         voxel size in the clouds' units (default %g; metres for\n"
      "                        KITTI). The refinement cube and the translation tolerance\n"
      "                        follow it; the steps do not\n"
      "  -steps tx,ty,tz,roll,pitch,yaw  initial simplex: how far the guess may be off,\n"
      "                        in the clouds' units and degrees; 0 pins a parameter\n"
      "                        (default %g,%g,%g,%.3g,%.3g,%.3g)\n"
      "%s"
      "  -max_iterations N     Nelder-Mead iteration cap over all starts (default %d)\n"
      "  -heading_starts N     start the coarsest search from N headings spread over\n"
      "                        360 deg, for a heading that may be off by more than about\n"
      "                        60 deg (default %d)\n"
      "  -position_starts N    also start it from N positions around the guess (half the\n"
      "                        x/y steps away) (default %d)\n"
      "  -narrow_view_starts N position starts used instead when either cloud covers less\n"
      "                        than 180 deg of azimuth about its origin (default %d; 0 = off)\n"
      "  -levels N             coarse-to-fine pyramid levels (default %d; 1 = single grid)\n"
      "  -subdivision N        source samples per voxel edge (default %d; 0 = every point)\n"
      "  -restarts N           restarts on the finest searched level (default %d)\n"
      "  -refinement on|off    refine the MI optimum on the target's distributions\n"
      "                        (default on)\n"
      "  -refinement_resolution R  cube edge of the refinement (default 0: 0.7 * resolution)\n"
      "%s"
      "  -backend cpu|opencl|auto   where the cost evaluations run (default cpu; auto:\n"
      "                        OpenCL on a GPU when every point is evaluated, else cpu)\n"
      "  -opencl_device P,D    OpenCL platform and device index as clinfo -l lists them\n"
      "                        (default: the first GPU, else the first device)\n"
      "%s",
      d.grid.resolution, s[0], s[1], s[2], s[3] * deg, s[4] * deg, s[5] * deg,
      set == MiOptionSet::All
          ? "  -feature varz|count   voxel feature: variance of z or point count (default varz)\n"
          : "",
      kDefaultMaxIterations, d.search.heading_starts, d.search.position_starts,
      d.search.narrow_view_position_starts, d.grid.pyramid_levels,
      d.sampling.source_subdivision, d.search.restarts,
      set == MiOptionSet::All
          ? "  -paper                the paper's exact method: one simplex, one grid, every\n"
            "                        point, no mirrored start, restarts or refinement\n"
          : "",
      set == MiOptionSet::All
          ? "  -profile              print where the time went, stage by stage, and the\n"
            "                        backend's own (OpenCL: kernel times from device events)\n"
          : "");
  return text;
}

const char*
optionValue(int argc, char** argv, const char* name)
{
  for (int i = 1; i + 1 < argc; ++i)
    if (std::strcmp(argv[i], name) == 0)
      return argv[i + 1];
  return nullptr;
}

bool
hasSwitch(int argc, char** argv, const char* name)
{
  for (int i = 1; i < argc; ++i)
    if (std::strcmp(argv[i], name) == 0)
      return true;
  return false;
}

namespace {

/** Reads an int option into \a out when present. */
void
readInt(int argc, char** argv, const char* name, int& out)
{
  if (const char* v = optionValue(argc, argv, name))
    out = std::atoi(v);
}

void
readDouble(int argc, char** argv, const char* name, double& out)
{
  if (const char* v = optionValue(argc, argv, name))
    out = std::atof(v);
}

std::vector<double>
readNumbers(const char* value)
{
  std::vector<double> numbers;
  for (const std::string& item : split(value, ','))
    numbers.push_back(std::atof(item.c_str()));
  return numbers;
}

} // namespace

std::string
applyMiOptions(int argc, char** argv, Parameters& p, int& max_iterations)
{
  if (hasSwitch(argc, argv, "-paper"))
    p = Parameters::paper();
  readDouble(argc, argv, "-resolution", p.grid.resolution);
  if (const char* v = optionValue(argc, argv, "-steps"))
    if (!poseVectorFromDegrees(readNumbers(v), p.search.simplex_steps))
      return "-steps takes 6 comma-separated values";
  if (const char* v = optionValue(argc, argv, "-feature")) {
    const std::string feature = v;
    if (feature != "varz" && feature != "count")
      return "-feature must be varz or count, got '" + feature + "'";
    p.grid.feature = feature == "varz" ? Feature::VarianceZ : Feature::PointCount;
  }
  readInt(argc, argv, "-max_iterations", max_iterations);
  readInt(argc, argv, "-heading_starts", p.search.heading_starts);
  readInt(argc, argv, "-position_starts", p.search.position_starts);
  readInt(argc, argv, "-narrow_view_starts", p.search.narrow_view_position_starts);
  readInt(argc, argv, "-levels", p.grid.pyramid_levels);
  readInt(argc, argv, "-subdivision", p.sampling.source_subdivision);
  readInt(argc, argv, "-restarts", p.search.restarts);
  if (const char* v = optionValue(argc, argv, "-refinement")) {
    const std::string refinement = v;
    if (refinement != "on" && refinement != "off")
      return "-refinement must be on or off, got '" + refinement + "'";
    p.refinement.method =
        refinement == "on" ? Refinement::PointToDistribution : Refinement::None;
  }
  readDouble(argc, argv, "-refinement_resolution", p.refinement.resolution);
  if (const char* v = optionValue(argc, argv, "-backend"))
    if (!parseBackend(v, p.backend.type))
      return std::string("-backend must be cpu, opencl or auto, got '") + v + "'";
  if (const char* v = optionValue(argc, argv, "-opencl_device")) {
    const std::vector<double> device = readNumbers(v);
    if (device.size() != 2)
      return "-opencl_device needs PLATFORM,DEVICE";
    p.backend.opencl_platform = static_cast<int>(device[0]);
    p.backend.opencl_device = static_cast<int>(device[1]);
  }
  // Device events cost time per evaluation, so only a profiled run takes them.
  if (hasSwitch(argc, argv, "-profile"))
    p.backend.profile_device = true;
  std::string invalid = p.validate();
  if (invalid.empty())
    invalid = maxIterationsError(max_iterations);
  return invalid;
}

} // namespace apps
} // namespace pcl_mi
