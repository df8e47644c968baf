/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "mi_options.h"

#include <cstdio>
#include <cstring>

namespace pcl_mi {
namespace apps {

namespace {

std::string
format(const char* pattern, double a = 0, double b = 0, double c = 0, double d = 0,
       double e = 0, double f = 0)
{
  char text[512];
  std::snprintf(text, sizeof text, pattern, a, b, c, d, e, f);
  return text;
}

} // namespace

std::vector<Option>
miOptionTable(MiOptionSet set)
{
  // The defaults shown are the library's own, so the help cannot drift from them.
  const Parameters d;
  const double deg = 180.0 / M_PI;
  const auto& s = d.search.simplex_steps;
  using V = OptionValue;
  std::vector<Option> table = {
      {"-resolution", V::Number, "-resolution R",
       format("voxel size in the clouds' units; 0 = derived from the target's extent\n"
              "(default %g: 1 m on a street scan, about 0.125 m in a room). The refinement\n"
              "cube, the translation tolerance and steps in voxels follow it",
              d.grid.resolution)},
      {"-steps", V::Numbers, "-steps tx,ty,tz,roll,pitch,yaw",
       format("initial simplex: how far the guess may be off, in the clouds'\n"
              "units (negative: in voxels) and degrees; 0 pins a parameter\n"
              "(default %g,%g,%g,%.3g,%.3g,%.3g)",
              s[0], s[1], s[2], s[3] * deg, s[4] * deg, s[5] * deg)},
      {"-max_iterations", V::Number, "-max_iterations N",
       format("Nelder-Mead iteration cap over all starts (default %g)", kDefaultMaxIterations)},
      {"-heading_starts", V::Number, "-heading_starts N",
       format("start the coarsest search from N headings spread over 360 deg,\n"
              "for a heading that may be off by more than about 60 deg (default %g)",
              d.search.heading_starts)},
      {"-position_starts", V::Number, "-position_starts N",
       format("also start it from N positions around the guess (half the x/y\n"
              "steps away) (default %g)",
              d.search.position_starts)},
      {"-narrow_view_starts", V::Number, "-narrow_view_starts N",
       format("position starts used instead when either cloud covers less than\n"
              "180 deg of azimuth about its origin (default %g; 0 = off)",
              d.search.narrow_view_position_starts)},
      {"-narrow_view_tilt", V::Number, "-narrow_view_tilt DEG",
       format("roll and pitch steps used instead, when larger, for a narrow field\n"
              "of view, turning the source about its sensor (default %g; 0 = off)",
              d.search.narrow_view_tilt_step * 180.0 / M_PI)},
      {"-narrow_view_yaw", V::Number, "-narrow_view_yaw DEG",
       format("two more starts, turned by +-DEG of yaw, for a narrow field of view\n"
              "(default %g; 0 = off)",
              d.search.narrow_view_yaw_start * 180.0 / M_PI)},
      {"-narrow_view_scans", V::Number, "-narrow_view_scans N",
       format("starts at the best-scoring turns of a yaw/pitch(/roll) grid about the\n"
              "sensor, for a narrow field of view (default %g; 0 = none)",
              d.search.narrow_view_scanned_starts)},
      {"-second_search", V::Number, "-second_search N",
       format("headings of the wider second search a 360-degree pair gets when its\n"
              "result is not trusted (default %g; 0 = none)",
              d.search.second_search_headings)},
      {"-reverse_search", V::Text, "-reverse_search on|off",
       "where the result is not trusted, also search the target onto the source\n"
       "and keep one of its optima, inverted, where it shares surface and the\n"
       "finest grid prefers it (default on)"},
      {"-leveling", V::Text, "-leveling on|off",
       "search a 360-degree pair along the target's up where the clouds' up\n"
       "directions disagree by more than 5 deg (a sensor carried tilted) or agree\n"
       "on one more than 5 deg from z (a sensor mounted tilted) (default on)"},
      {"-coarse_nmi", V::Text, "-coarse_nmi on|off",
       "search the coarsest pyramid level on normalised MI, which the overlap a\n"
       "far search moves through does not bias (default on; off = MI everywhere)"},
      {"-levels", V::Number, "-levels N",
       format("coarse-to-fine pyramid levels (default %g; 1 = single grid)",
              d.grid.pyramid_levels)},
      {"-subdivision", V::Number, "-subdivision N",
       format("source samples per voxel edge (default %g; 0 = every point)",
              d.sampling.source_subdivision)},
      {"-restarts", V::Number, "-restarts N",
       format("restarts on the finest searched level (default %g)", d.search.restarts)},
      {"-refinement", V::Text, "-refinement on|off",
       "refine the MI optimum on the target's distributions (default on)"},
      {"-refinement_resolution", V::Number, "-refinement_resolution R",
       "cube edge of the refinement (default 0: 0.7 * resolution)"},
      {"-narrow_view_stages", V::Number, "-narrow_view_stages N",
       format("coarser refinement stages (cubes 2, 4, ... times larger) before the\n"
              "finest, for a narrow field of view (default %g; 0 = none)",
              d.refinement.narrow_view_stages)},
      {"-backend", V::Text, "-backend cpu|opencl|auto",
       "where the cost evaluations run (default cpu; auto: OpenCL on a GPU\n"
       "when every point is evaluated, else cpu)"},
      {"-opencl_device", V::Numbers, "-opencl_device P,D",
       "OpenCL platform and device index as clinfo -l lists them (default:\n"
       "the first GPU, else the first device)"},
      {"-units_per_metre", V::Number, "-units_per_metre U",
       format("the clouds' units in a metre (1000 for millimetres): a few lengths of\n"
              "the verdict and the refinement are in metres, everything else follows\n"
              "the resolution (default %g)",
              d.units_per_metre)},
      {"-batch", V::Text, "-batch auto|on|off",
       "hand the OpenCL backend a batch of poses per round trip (default auto:\n"
       "on a GPU, not on a CPU device); the same result either way"}};
  if (set == MiOptionSet::All) {
    table.push_back({"-feature", V::Text, "-feature varz|count",
                     "voxel feature: variance of z or point count (default varz)"});
    table.push_back({"-paper", V::None, "-paper",
                     "the paper's exact method: one simplex, one grid, every point, no\n"
                     "mirrored start, restarts or refinement"});
    table.push_back({"-profile", V::None, "-profile",
                     "print where the time went, stage by stage, and the backend's own\n"
                     "(OpenCL: kernel times from device events)"});
  }
  return table;
}

std::string
miOptionsHelp(MiOptionSet set)
{
  return "MI parameters:\n" + optionsHelp(miOptionTable(set));
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

/** Reads an on|off option into \a out when present; an error for any other value. */
std::string
readOnOff(int argc, char** argv, const char* name, bool& out)
{
  const char* v = optionValue(argc, argv, name);
  if (!v)
    return {};
  const std::string value = v;
  if (value != "on" && value != "off")
    return std::string(name) + " must be on or off, got '" + value + "'";
  out = value == "on";
  return {};
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
  if (const char* v = optionValue(argc, argv, "-narrow_view_tilt"))
    p.search.narrow_view_tilt_step = std::atof(v) * M_PI / 180.0;
  if (const char* v = optionValue(argc, argv, "-narrow_view_yaw"))
    p.search.narrow_view_yaw_start = std::atof(v) * M_PI / 180.0;
  readInt(argc, argv, "-narrow_view_scans", p.search.narrow_view_scanned_starts);
  readInt(argc, argv, "-second_search", p.search.second_search_headings);
  std::string error = readOnOff(argc, argv, "-leveling", p.search.leveling);
  if (error.empty())
    error = readOnOff(argc, argv, "-reverse_search", p.search.reverse_search);
  if (error.empty())
    error = readOnOff(argc, argv, "-coarse_nmi", p.search.coarse_normalized_mi);
  if (!error.empty())
    return error;
  readInt(argc, argv, "-levels", p.grid.pyramid_levels);
  readInt(argc, argv, "-subdivision", p.sampling.source_subdivision);
  readInt(argc, argv, "-restarts", p.search.restarts);
  bool refine = p.refinement.method != Refinement::None;
  error = readOnOff(argc, argv, "-refinement", refine);
  if (!error.empty())
    return error;
  p.refinement.method = refine ? Refinement::PointToDistribution : Refinement::None;
  readDouble(argc, argv, "-refinement_resolution", p.refinement.resolution);
  readInt(argc, argv, "-narrow_view_stages", p.refinement.narrow_view_stages);
  readDouble(argc, argv, "-units_per_metre", p.units_per_metre);
  if (const char* v = optionValue(argc, argv, "-backend"))
    if (!parseBackend(v, p.backend.type))
      return std::string("-backend must be cpu, opencl or auto, got '") + v + "'";
  if (const char* v = optionValue(argc, argv, "-batch"))
    if (!parseBatching(v, p.backend.batching))
      return std::string("-batch must be auto, on or off, got '") + v + "'";
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
