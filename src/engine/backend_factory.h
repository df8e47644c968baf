/*
 * pcl_mi: which scoring backend the parameters ask for, and making one: the engine's
 * reading of BackendParameters (the backends themselves know no parameters).
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "backend/scoring_backend.h"

#include <pcl_mi/parameters.h>

#include <memory>
#include <string>

namespace pcl_mi {
namespace backend {
struct OpenClDevice;
} // namespace backend

namespace core {

/** \brief Makes the backends of one target: the CPU, or the OpenCL device chosen once. */
class BackendFactory {
public:
  /** \brief Chooses for \a backend (with the sampling, on which Backend::Auto depends).
   * False (with \a error) only when OpenCL was requested explicitly and is unavailable;
   * Backend::Auto falls back to the CPU with a warning(). */
  bool
  choose(const BackendParameters& backend, const SamplingParameters& sampling, std::string& error);

  /** \brief A new backend of the chosen kind. */
  std::unique_ptr<backend::ScoringBackend>
  make() const;

  /** \brief "cpu" or "opencl (device name)". */
  const std::string&
  name() const
  {
    return name_;
  }

  /** \brief Non-empty when Backend::Auto fell back to the CPU: why. */
  const std::string&
  warning() const
  {
    return warning_;
  }

private:
  std::shared_ptr<backend::OpenClDevice> device_; // null: the CPU
  bool profile_device_ = false;
  bool batch_ = false;
  std::string name_ = "cpu";
  std::string warning_;
};

} // namespace core
} // namespace pcl_mi
