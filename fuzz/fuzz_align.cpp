/*
 * libFuzzer target: RegistrationCore::align() on arbitrary small clouds, guesses and
 * parameters, NaN, Inf and absurd coordinates included. Any input must give a result or an
 * error, never a crash; invalid parameters must be refused by setParameters().
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "fuzz_input.h"

#include <pcl_mi/registration_core.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

namespace {

using pcl_mi::fuzz::FuzzInput;

/** Mostly coordinates within +-327 m in 1 cm steps; a few special values. */
float
coordinate(FuzzInput& in)
{
  switch (in.byte()) {
  case 0xff:
    return std::numeric_limits<float>::quiet_NaN();
  case 0xfe:
    return std::numeric_limits<float>::infinity();
  case 0xfd:
    return 1e7f * static_cast<float>(in.int16()); // far away
  default:
    return static_cast<float>(in.int16()) * 0.01f;
  }
}

pcl_mi::PointList
cloud(FuzzInput& in)
{
  const int n = in.byte() * 2; // up to 510 points
  pcl_mi::PointList points;
  for (int i = 0; i < n && !in.empty(); ++i) {
    const float x = coordinate(in), y = coordinate(in), z = coordinate(in);
    points.emplace_back(x, y, z);
  }
  return points;
}

} // namespace

extern "C" int
LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  FuzzInput in(data, size);
  pcl_mi::Parameters p;
  // Resolutions from 0.05 m to 12.8 m (fine ones exercise the grid-size cap) or, for a
  // high selector byte, an arbitrary (possibly invalid) value.
  const std::uint8_t r = in.byte();
  p.grid.resolution = r < 250 ? 0.05 * (1 + r) : static_cast<double>(coordinate(in));
  p.grid.feature = in.byte() % 2 ? pcl_mi::Feature::PointCount : pcl_mi::Feature::VarianceZ;
  p.grid.pyramid_levels = in.byte() % 4; // 0 is invalid
  p.sampling.source_subdivision = in.byte() % 5;
  p.refinement.method = in.byte() % 2 ? pcl_mi::Refinement::None : pcl_mi::Refinement::PointToDistribution;
  p.search.restarts = in.byte() % 3;
  p.search.symmetric_start = in.byte() % 2;
  p.num_threads = 1 + in.byte() % 2;
  const int max_iterations = 1 + in.byte() % 64; // bounded work per input
  p.refinement.max_iterations = 1 + in.byte() % 5;
  for (int i = 0; i < 6; ++i)
    if (in.byte() % 4 == 0)
      p.search.simplex_steps[i] = 0.0;
  pcl_mi::RegistrationCore core;
  if (!core.setParameters(p).empty())
    return 0; // refused, as it must be for invalid values
  core.setTarget(cloud(in));
  core.setSource(cloud(in));
  Eigen::Matrix4d guess = Eigen::Matrix4d::Identity();
  guess(0, 3) = coordinate(in);
  guess(1, 3) = coordinate(in);
  guess(2, 3) = coordinate(in);
  const float yaw = coordinate(in);
  guess(0, 0) = guess(1, 1) = std::cos(yaw);
  guess(0, 1) = -std::sin(yaw);
  guess(1, 0) = std::sin(yaw);
  const pcl_mi::AlignmentResult result = core.align(guess, max_iterations);
  // Success means a finite rigid transformation; failure means a reason.
  if (result.error.empty()) {
    if (!result.transformation.allFinite())
      __builtin_trap();
    const Eigen::Matrix3d rot = result.transformation.topLeftCorner<3, 3>();
    if ((rot * rot.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6)
      __builtin_trap();
  }
  else if (result.converged) {
    __builtin_trap();
  }
  return 0;
}
