/*
 * pcl_mi apps: small helpers the command-line apps share (header-only, no PCL, so the
 * engine-only pcl_mi_backend_bench can use them too).
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_mi/types.h>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <initializer_list>
#include <exception>
#include <new>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace pcl_mi {
namespace apps {

/** What kept \a result from converging, in a few words: "failed", the verdict's refusal
 * (refusalName()), or "the search capped" where the verdict passed the result but the
 * search did not meet its tolerances; empty where it converged. */
inline std::string
notConvergedKind(const AlignmentResult& result)
{
  if (result.converged)
    return {};
  if (!result.error.empty())
    return "failed";
  if (result.verification.refusal != Refusal::None)
    return refusalName(result.verification.refusal);
  return "the search capped";
}

/** Splits \a s at \a sep, dropping empty items ("a,,b" -> {"a", "b"}). */
inline std::vector<std::string>
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

/** Median of \a v; NaN when empty. */
inline double
median(std::vector<double> v)
{
  if (v.empty())
    return NAN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/** [tx, ty, tz, roll, pitch, yaw] with the angles in degrees, as the apps take it on the
 * command line, into \a out with the angles in radians; false unless there are 6 values. */
inline bool
poseVectorFromDegrees(const std::vector<double>& values, Eigen::Matrix<double, 6, 1>& out)
{
  if (values.size() != 6)
    return false;
  for (int i = 0; i < 6; ++i)
    out[i] = i < 3 ? values[i] : values[i] * M_PI / 180.0;
  return true;
}

/** Reference poses of KITTI sequence \a sequence under \a root. \a kind "semantic":
 * sequences/SS/poses.txt (SemanticKITTI's LiDAR-SLAM poses); "gt": poses/SS.txt (KITTI's
 * GPS/INS ground truth, the odometry benchmark's own layout); "auto": the SemanticKITTI file
 * where it exists, else the ground truth. Empty for any other kind. */
inline std::string
kittiPosesPath(const std::string& root, const std::string& sequence, const std::string& kind)
{
  const std::string semantic = root + "/sequences/" + sequence + "/poses.txt";
  const std::string gt = root + "/poses/" + sequence + ".txt";
  if (kind == "semantic")
    return semantic;
  if (kind == "gt")
    return gt;
  if (kind == "auto")
    return std::ifstream(semantic).good() ? semantic : gt;
  return "";
}

/** What follows a command-line option. */
enum class OptionValue {
  None,    ///< a switch
  Number,  ///< one number
  Numbers, ///< comma-separated numbers
  Text,    ///< one word
  Files    ///< one or more words up to the next option (e.g. -merge A.csv B.csv)
};

/** A command-line option an app knows. */
struct Option {
  const char* name;
  OptionValue value;
  /** Help: the option as written with its value, then what it does (may be empty). */
  std::string usage = {}, help = {};
};

/** Help lines of \a options, the usage column padded to 22 characters. */
inline std::string
optionsHelp(const std::vector<Option>& options)
{
  std::string text;
  for (const Option& o : options) {
    std::string usage = "  " + (o.usage.empty() ? std::string(o.name) : o.usage);
    text += usage.size() < 23 ? usage + std::string(24 - usage.size(), ' ') : usage + "\n" +
                                                                               std::string(24, ' ');
    // Continuation lines of the help keep the column.
    for (const char c : o.help)
      text += c == '\n' ? std::string("\n") + std::string(24, ' ') : std::string(1, c);
    text += "\n";
  }
  return text;
}

/** \a a followed by \a b. */
inline std::vector<Option>
join(std::vector<Option> a, const std::vector<Option>& b)
{
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

/** Empty when every argument after the first \a positional ones is a known option followed
 * by a value of the right kind; otherwise a one-line reason naming the first that is not
 * (a misspelled option would otherwise be ignored, and the run go on with a default). */
inline std::string
checkOptions(int argc, char** argv, int positional, const std::vector<Option>& options)
{
  auto isNumber = [](const std::string& word) {
    char* end = nullptr;
    std::strtod(word.c_str(), &end);
    return !word.empty() && end == word.c_str() + word.size();
  };
  for (int i = 1 + positional; i < argc; ++i) {
    const std::string arg = argv[i];
    const Option* known = nullptr;
    for (const Option& o : options)
      if (arg == o.name)
        known = &o;
    if (!known)
      return "unknown option '" + arg + "' (-h lists the options)";
    if (known->value == OptionValue::None)
      continue;
    if (i + 1 >= argc)
      return "option " + arg + " needs a value";
    if (known->value == OptionValue::Files) {
      while (i + 1 < argc && argv[i + 1][0] != '-')
        ++i;
      continue;
    }
    const std::string value = argv[++i];
    bool ok = true;
    if (known->value == OptionValue::Number)
      ok = isNumber(value);
    else if (known->value == OptionValue::Numbers)
      for (const std::string& item : split(value, ','))
        ok = ok && isNumber(item);
    if (!ok)
      return "option " + arg + " takes " +
             (known->value == OptionValue::Number ? "a number" : "comma-separated numbers") +
             ", got '" + value + "'";
  }
  return {};
}

/** The one exception boundary of an app: runs \a body and returns its exit code; whatever
 * escapes it (out of memory, PCL's IOException on an unwritable file, ...) becomes one line
 * on stderr and exit code 1, instead of "terminate called" and SIGABRT. */
template <typename Body>
int
guardedMain(const char* app, Body&& body)
{
  try {
    return body();
  }
  catch (const std::bad_alloc&) {
    std::fprintf(stderr, "%s: out of memory\n", app);
  }
  catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", app, e.what());
  }
  catch (...) {
    std::fprintf(stderr, "%s: unknown error\n", app);
  }
  return 1;
}

} // namespace apps
} // namespace pcl_mi
