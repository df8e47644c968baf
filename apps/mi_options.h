/*
 * pcl_mi apps: the MI parameters every app takes on its command line, in one table:
 * checked, documented and applied by the same code in each app (no PCL, so the
 * engine-only pcl_mi_backend_bench uses it too).
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "app_util.h"

#include <pcl_mi/parameters.h>

#include <string>
#include <vector>

namespace pcl_mi {
namespace apps {

/** Which MI options an app takes: all of them, or only those that tune a method the app
 * names itself (pcl_mi_compare's mi-varz, mi-n-paper, ... choose feature and search). */
enum class MiOptionSet { All, Tuning };

/** The MI options of \a set, for checkOptions(). */
std::vector<Option>
miOptionTable(MiOptionSet set);

/** Their help lines, with the library's defaults (so the help cannot drift from them). */
std::string
miOptionsHelp(MiOptionSet set);

/** Applies the MI options given on the command line to \a parameters and
 * \a max_iterations; -paper first replaces the parameters by Parameters::paper(). Returns
 * an empty string, or a one-line reason when a value is out of range. Options absent from
 * the command line leave their values alone. */
std::string
applyMiOptions(int argc, char** argv, Parameters& parameters, int& max_iterations);

/** The value after option \a name, or null when \a name is absent. */
const char*
optionValue(int argc, char** argv, const char* name);

/** True when the switch \a name is present. */
bool
hasSwitch(int argc, char** argv, const char* name);

} // namespace apps
} // namespace pcl_mi
