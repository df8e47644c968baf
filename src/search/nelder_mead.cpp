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

NelderMeadResult
minimizeNelderMead(const std::function<double(const Eigen::VectorXd&)>& f,
                   const Eigen::VectorXd& x0,
                   const Eigen::VectorXd& steps,
                   const NelderMeadOptions& options)
{
  const Eigen::Index n = x0.size();
  NelderMeadResult result;
  auto evaluate = [&](const Eigen::VectorXd& x) {
    ++result.evaluations;
    return f(x);
  };

  std::vector<Eigen::VectorXd> vertices(n + 1, x0);
  std::vector<double> values(n + 1);
  for (Eigen::Index i = 0; i < n; ++i)
    vertices[i + 1][i] += steps[i];
  for (Eigen::Index v = 0; v <= n; ++v)
    values[v] = evaluate(vertices[v]);

  std::vector<std::size_t> order(n + 1);
  const Eigen::VectorXd tolerance =
      options.tolerance.size() == n ? options.tolerance : Eigen::VectorXd::Zero(n);

  while (true) {
    // Stable sort keeps the older vertex first among equal values: on the plateaus of a
    // quantised cost this stops the simplex from cycling between equal vertices.
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
      return values[a] < values[b];
    });
    const std::size_t best = order.front();
    const std::size_t worst = order.back();
    const std::size_t second_worst = order[n - 1];

    if (simplexWithinTolerance(vertices, best, tolerance)) {
      result.converged = true;
      break;
    }
    if (result.iterations >= options.max_iterations)
      break;
    ++result.iterations;

    Eigen::VectorXd centroid = Eigen::VectorXd::Zero(n);
    for (Eigen::Index v = 0; v <= n; ++v)
      if (static_cast<std::size_t>(v) != worst)
        centroid += vertices[v];
    centroid /= static_cast<double>(n);

    const Eigen::VectorXd reflected = centroid + (centroid - vertices[worst]);
    const double f_reflected = evaluate(reflected);

    if (f_reflected < values[best]) {
      const Eigen::VectorXd expanded = centroid + 2.0 * (centroid - vertices[worst]);
      const double f_expanded = evaluate(expanded);
      if (f_expanded < f_reflected) {
        vertices[worst] = expanded;
        values[worst] = f_expanded;
      }
      else {
        vertices[worst] = reflected;
        values[worst] = f_reflected;
      }
      continue;
    }
    if (f_reflected < values[second_worst]) {
      vertices[worst] = reflected;
      values[worst] = f_reflected;
      continue;
    }

    // Contract towards the better of the reflected point and the worst vertex.
    const bool outside = f_reflected < values[worst];
    const Eigen::VectorXd contracted =
        outside ? Eigen::VectorXd(centroid + 0.5 * (reflected - centroid))
                : Eigen::VectorXd(centroid + 0.5 * (vertices[worst] - centroid));
    const double f_contracted = evaluate(contracted);
    if (f_contracted < (outside ? f_reflected : values[worst])) {
      vertices[worst] = contracted;
      values[worst] = f_contracted;
      continue;
    }

    // Shrink every vertex towards the best one.
    for (Eigen::Index v = 0; v <= n; ++v) {
      if (static_cast<std::size_t>(v) == best)
        continue;
      vertices[v] = vertices[best] + 0.5 * (vertices[v] - vertices[best]);
      values[v] = evaluate(vertices[v]);
    }
  }

  const auto best_it = std::min_element(values.begin(), values.end());
  const std::size_t best = static_cast<std::size_t>(best_it - values.begin());
  result.x = vertices[best];
  result.value = values[best];
  return result;
}

} // namespace core
} // namespace pcl_mi
