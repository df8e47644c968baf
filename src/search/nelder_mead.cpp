/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "search/nelder_mead.h"

#include <algorithm>
#include <numeric>
#include <vector>

namespace pcl_mi {
namespace core {

namespace {

bool
simplexWithinTolerance(const std::vector<Eigen::VectorXd>& vertices,
                       std::size_t best,
                       const Eigen::VectorXd& tolerance)
{
  for (std::size_t v = 0; v < vertices.size(); ++v) {
    if (v == best)
      continue;
    const Eigen::VectorXd d = (vertices[v] - vertices[best]).cwiseAbs();
    if ((d.array() > tolerance.array()).any())
      return false;
  }
  return true;
}

} // namespace

NelderMeadRun::NelderMeadRun(const Eigen::VectorXd& x0,
                             const Eigen::VectorXd& steps,
                             const NelderMeadOptions& options)
: options_(options)
{
  const Eigen::Index n = x0.size();
  tolerance_ = options.tolerance.size() == n ? options.tolerance : Eigen::VectorXd::Zero(n);
  vertices_.assign(static_cast<std::size_t>(n + 1), x0);
  for (Eigen::Index i = 0; i < n; ++i)
    vertices_[static_cast<std::size_t>(i + 1)][i] += steps[i];
  values_.assign(vertices_.size(), 0.0);
  request_ = vertices_;
}

void
NelderMeadRun::reply(const std::vector<double>& values)
{
  ++counts_.requests;
  switch (phase_) {
  case Phase::kSimplex:
    values_ = values;
    counts_.evaluations += static_cast<int>(values_.size());
    beginIteration();
    return;
  case Phase::kShrink:
    for (std::size_t v = 0, k = 0; v < vertices_.size(); ++v)
      if (v != best_)
        values_[v] = values[k++];
    counts_.evaluations += static_cast<int>(values.size());
    beginIteration();
    return;
  case Phase::kCandidates:
    for (std::size_t k = 0; k < asked_.size(); ++k) {
      candidate_values_[asked_[k]] = values[k];
      known_[asked_[k]] = true;
    }
    decide();
    return;
  }
}

void
NelderMeadRun::beginIteration()
{
  // Stable sort keeps the older vertex first among equal values: on the plateaus of a
  // quantised cost this stops the simplex from cycling between equal vertices.
  const std::size_t n = vertices_.size() - 1;
  std::vector<std::size_t> order(n + 1);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return values_[a] < values_[b]; });
  best_ = order.front();
  worst_ = order.back();
  second_worst_ = order[n - 1];
  request_.clear();
  if (simplexWithinTolerance(vertices_, best_, tolerance_)) {
    counts_.converged = true;
    return;
  }
  if (counts_.iterations >= options_.max_iterations)
    return;
  ++counts_.iterations;

  Eigen::VectorXd centroid = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n));
  for (std::size_t v = 0; v <= n; ++v)
    if (v != worst_)
      centroid += vertices_[v];
  centroid /= static_cast<double>(n);
  const Eigen::VectorXd& worst = vertices_[worst_];
  candidates_[kReflected] = centroid + (centroid - worst);
  candidates_[kExpanded] = centroid + 2.0 * (centroid - worst);
  // Contraction towards the better of the reflected point and the worst vertex.
  candidates_[kOutsideContracted] = centroid + 0.5 * (candidates_[kReflected] - centroid);
  candidates_[kInsideContracted] = centroid + 0.5 * (worst - centroid);
  std::fill(std::begin(known_), std::end(known_), false);
  std::fill(std::begin(used_), std::end(used_), false);
  phase_ = Phase::kCandidates;
  if (options_.speculative) {
    // Every candidate now; each is then used as if it had been asked for alone.
    asked_ = {kReflected, kExpanded, kOutsideContracted, kInsideContracted};
    for (const Candidate c : asked_)
      request_.push_back(candidates_[c]);
    return;
  }
  decide();
}

void
NelderMeadRun::decide()
{
  // The value of candidate c, or false after asking for it.
  auto have = [&](Candidate c) {
    if (!known_[c]) {
      asked_ = {c};
      request_ = {candidates_[c]};
      return false;
    }
    used_[c] = true;
    return true;
  };
  request_.clear();
  if (!have(kReflected))
    return;
  const double f_reflected = candidate_values_[kReflected];
  if (f_reflected < values_[best_]) {
    if (!have(kExpanded))
      return;
    replaceWorst(candidate_values_[kExpanded] < f_reflected ? kExpanded : kReflected);
    return;
  }
  if (f_reflected < values_[second_worst_]) {
    replaceWorst(kReflected);
    return;
  }
  const bool outside = f_reflected < values_[worst_];
  const Candidate contracted = outside ? kOutsideContracted : kInsideContracted;
  if (!have(contracted))
    return;
  if (candidate_values_[contracted] < (outside ? f_reflected : values_[worst_])) {
    replaceWorst(contracted);
    return;
  }

  // Shrink every vertex towards the best one, all in one request.
  counts_.evaluations += static_cast<int>(std::count(std::begin(used_), std::end(used_), true));
  phase_ = Phase::kShrink;
  for (std::size_t v = 0; v < vertices_.size(); ++v) {
    if (v == best_)
      continue;
    vertices_[v] = vertices_[best_] + 0.5 * (vertices_[v] - vertices_[best_]);
    request_.push_back(vertices_[v]);
  }
}

void
NelderMeadRun::replaceWorst(Candidate c)
{
  counts_.evaluations += static_cast<int>(std::count(std::begin(used_), std::end(used_), true));
  vertices_[worst_] = candidates_[c];
  values_[worst_] = candidate_values_[c];
  beginIteration();
}

const Eigen::VectorXd*
NelderMeadRun::spare() const
{
  const bool reflection_alone =
      phase_ == Phase::kCandidates && asked_.size() == 1 && asked_.front() == kReflected;
  return reflection_alone && !known_[kInsideContracted] && !request_.empty()
             ? &candidates_[kInsideContracted]
             : nullptr;
}

void
NelderMeadRun::offerSpare(double value)
{
  candidate_values_[kInsideContracted] = value;
  known_[kInsideContracted] = true;
}

NelderMeadResult
NelderMeadRun::result() const
{
  NelderMeadResult r = counts_;
  const auto best = std::min_element(values_.begin(), values_.end());
  r.x = vertices_[static_cast<std::size_t>(best - values_.begin())];
  r.value = *best;
  return r;
}

NelderMeadResult
minimizeNelderMead(const std::function<double(const Eigen::VectorXd&)>& f,
                   const Eigen::VectorXd& x0,
                   const Eigen::VectorXd& steps,
                   const NelderMeadOptions& options)
{
  NelderMeadOptions one_at_a_time = options;
  one_at_a_time.speculative = false;
  NelderMeadRun run(x0, steps, one_at_a_time);
  runToEnd(run, [&](const std::vector<Eigen::VectorXd>& points, std::vector<double>& values) {
    for (std::size_t i = 0; i < points.size(); ++i)
      values[i] = f(points[i]);
  });
  return run.result();
}

int
runToEnd(NelderMeadRun& run, const BatchFunction& f)
{
  int rounds = 0;
  std::vector<double> values;
  for (; !run.finished(); ++rounds) {
    values.assign(run.request().size(), 0.0);
    f(run.request(), values);
    run.reply(values);
  }
  return rounds;
}

int
runTogether(std::vector<NelderMeadRun>& runs, const BatchFunction& f)
{
  int rounds = 0;
  std::vector<Eigen::VectorXd> batch;
  std::vector<double> values, part;
  while (true) {
    batch.clear();
    for (const NelderMeadRun& run : runs)
      batch.insert(batch.end(), run.request().begin(), run.request().end());
    if (batch.empty())
      return rounds;
    values.assign(batch.size(), 0.0);
    f(batch, values);
    ++rounds;
    std::size_t offset = 0;
    for (NelderMeadRun& run : runs) {
      const std::size_t count = run.request().size();
      if (count == 0)
        continue;
      part.assign(values.begin() + static_cast<std::ptrdiff_t>(offset),
                  values.begin() + static_cast<std::ptrdiff_t>(offset + count));
      offset += count;
      run.reply(part);
    }
  }
}

} // namespace core
} // namespace pcl_mi
