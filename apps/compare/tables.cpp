/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "compare/tables.h"

#include "app_util.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

namespace pcl_mi {
namespace compare {

using pcl_mi::apps::median;

namespace {

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

/** How far each method's hasConverged() can be trusted: of the results that said converged,
 * the share that missed the bound (1 - precision), and of the results within the bound, the
 * share that said converged (recall). */
void
printVerdict(const std::vector<Row>& rows,
             const std::vector<std::string>& methods,
             const std::vector<double>& bound)
{
  std::printf("\nVerdict (hasConverged) against the success bound\n%-14s %9s %9s %9s %9s\n",
              "method", "converged", "wrong", "right", "recall");
  for (const auto& m : methods) {
    int said = 0, wrong = 0, right = 0, found = 0;
    for (const auto& r : rows) {
      if (r.method != m)
        continue;
      const bool ok = succeeded(r, bound);
      said += r.converged;
      wrong += r.converged && !ok;
      right += ok;
      found += r.converged && ok;
    }
    std::printf("%-14s %9d %8.1f%% %9d %8.1f%%\n", m.c_str(), said,
                said ? 100.0 * wrong / said : 0.0, right, right ? 100.0 * found / right : 0.0);
  }
  std::printf("(wrong: share of the converged results outside the bound; recall: share of the "
              "results within it that said converged)\n");
}

/** Why MI's results did not say converged, by kind (Row::refusal), with how many of them
 * were within the bound anyway: the right results each rule holds back. Only for methods
 * whose rows carry the kind. */
void
printRefusals(const std::vector<Row>& rows,
              const std::vector<std::string>& methods,
              const std::vector<double>& bound)
{
  bool any = false;
  for (const auto& m : methods) {
    std::map<std::string, std::pair<int, int>> by_kind; // rows, right
    for (const auto& r : rows)
      if (r.method == m && !r.converged && !r.refusal.empty()) {
        auto& count = by_kind[r.refusal];
        ++count.first;
        count.second += succeeded(r, bound);
      }
    if (by_kind.empty())
      continue;
    if (!any)
      std::printf("\nNot converged, by kind of reason (the CSV's refusal column)\n"
                  "%-14s %-26s %6s %6s\n",
                  "method", "refusal", "rows", "right");
    any = true;
    for (const auto& [kind, count] : by_kind)
      std::printf("%-14s %-26s %6d %6d\n", m.c_str(), kind.c_str(), count.first, count.second);
  }
  if (any)
    std::printf("(right: within the success bound all the same; the search capped: its "
                "iteration cap, or a capped runner-up's or reverse search's optimum, ended it "
                "before its tolerance)\n");
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

/** Scan to map (-reuse_target): per method, the median time of the alignments against a
 * target it kept apart from those that prepared their target (the first against each map),
 * which the runtime tables mix. Nothing for rows without the distinction (other methods,
 * runs without -reuse_target, rows read from a CSV). */
void
printKeptTargets(const std::vector<Row>& rows, const std::vector<std::string>& methods)
{
  const int name_width = methodColumnWidth(methods);
  const auto cell = [](const std::vector<double>& v) {
    char text[32] = "-";
    if (!v.empty())
      std::snprintf(text, sizeof(text), "%.2f", median(v));
    return std::string(text);
  };
  bool header = false;
  for (const auto& m : methods) {
    std::vector<double> kept, prepared;
    for (const auto& r : rows)
      if (r.method == m && r.target_reuse != Row::TargetReuse::kNone)
        (r.target_reuse == Row::TargetReuse::kKept ? kept : prepared)
            .push_back(1000.0 * r.seconds);
    if (kept.empty() && prepared.empty())
      continue;
    if (!header) {
      std::printf("\nScan to map (-reuse_target): median per alignment [ms]\n"
                  "%-*s %12s %10s %16s %10s\n",
                  name_width, "method", "kept target", "median", "prepared target", "median");
      header = true;
    }
    std::printf("%-*s %12zu %10s %16zu %10s\n", name_width, m.c_str(), kept.size(),
                cell(kept).c_str(), prepared.size(), cell(prepared).c_str());
  }
  if (header)
    std::printf("(the first alignment against each target prepares it; the others keep it)\n");
}

/** Where MI's time goes: per method, the median over its rows of each stage of
 * pcl_mi::AlignmentResult::stages (the search's levels summed; the verification with the
 * second-optimum probes and the restarts around a refused result), and of what lies outside
 * the engine (PCL's align() and the output cloud, the target's derived resolution). Rows
 * read from a CSV carry no stages and are left out. */
void
printStages(const std::vector<Row>& rows, const std::vector<std::string>& methods)
{
  const char* const columns[] = {"prepare", "search", "refinement", "verification", "outside",
                                 "total"};
  const int name_width = methodColumnWidth(methods);
  bool header = false;
  for (const auto& m : methods) {
    std::vector<double> ms[6];
    for (const auto& row : rows) {
      if (row.method != m || row.stages.empty())
        continue;
      double stage[6] = {0, 0, 0, 0, 0, 1000.0 * row.seconds};
      for (const StageTiming& t : row.stages) {
        const bool verifying = t.name == "verification" || t.name == "second optimum" ||
                               t.name == "steadiness" || t.name == "reverse confirmation";
        // The rest are the search's: "search ...", "restarts", "runners-up", "second
        // search", "shifted optima".
        const int k = t.name == "prepare" ? 0 : t.name == "refinement" ? 2 : verifying ? 3 : 1;
        stage[k] += t.total_ms;
      }
      stage[4] = stage[5] - stage[0] - stage[1] - stage[2] - stage[3];
      for (int k = 0; k < 6; ++k)
        ms[k].push_back(stage[k]);
    }
    if (ms[0].empty())
      continue;
    if (!header) {
      std::printf("\nMI stages, median per alignment [ms]\n%-*s %6s", name_width, "method",
                  "rows");
      for (const char* c : columns)
        std::printf(" %12s", c);
      std::printf("\n");
      header = true;
    }
    std::printf("%-*s %6zu", name_width, m.c_str(), ms[0].size());
    for (auto& v : ms)
      std::printf(" %12.2f", median(v));
    std::printf("\n");
  }
  if (header)
    std::printf("(each column is its own median, so they need not add up to the total)\n");
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

} // namespace

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
  printStages(rows, methods);
  printKeptTargets(rows, methods);
  printVerdict(rows, methods, bound);
  printRefusals(rows, methods, bound);
  printBias(rows, methods, bound);
}

} // namespace compare
} // namespace pcl_mi
