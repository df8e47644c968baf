/*
 * pcl_mi: wall-clock stages, closed one after the other (AlignmentResult::stages).
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_mi/types.h>

#include <chrono>
#include <string>
#include <vector>

namespace pcl_mi {
namespace core {

/** \brief Times consecutive stages: each end() closes the stage that began at the previous
 * end() (or at construction). */
class StageClock {
public:
  /** \brief Appends the stage \a name with \a calls to \a stages and starts the next. */
  void
  end(std::vector<StageTiming>& stages, std::string name, int calls)
  {
    const auto now = std::chrono::steady_clock::now();
    stages.push_back(
        {std::move(name), calls, std::chrono::duration<double, std::milli>(now - start_).count()});
    start_ = now;
  }

private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

} // namespace core
} // namespace pcl_mi
