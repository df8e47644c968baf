/*
 * libFuzzer target: sequences of calls on pcl::MutualInformationRegistration as a user of
 * the PCL contract makes them: clouds set, replaced, cleared or nulled, indices in and out
 * of range, setters with any value, align() with rigid and non-rigid guesses,
 * getFitnessScore(), getCovariance() and evaluate() at any moment (docs/hardening.md,
 * classes 5, 6, 7, 9, 10, 11 and 12). Invariants: no crash, no hang; a result that says
 * converged has no error; a failed align() leaves the guess as the final transformation and
 * says why; the verdict names a refusal exactly where it gives a reason; the covariance is
 * finite.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "fuzz_input.h"

#include <pcl_mi/mutual_information_registration.h>

#include <pcl/console/print.h>

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <limits>

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Registration = pcl::MutualInformationRegistration<pcl::PointXYZ>;

using pcl_mi::fuzz::FuzzInput;

/** Mostly coordinates within +-327 m in 1 cm steps; NaN, FLT_MAX and 1e30 too. */
float
coordinate(FuzzInput& in)
{
  switch (in.byte()) {
  case 0xff:
    return std::numeric_limits<float>::quiet_NaN();
  case 0xfe:
    return FLT_MAX;
  case 0xfd:
    return 1e30f;
  default:
    return static_cast<float>(in.int16()) * 0.01f;
  }
}

Cloud::Ptr
makeCloud(FuzzInput& in)
{
  switch (in.byte() % 8) {
  case 0:
    return nullptr;
  case 1:
    return pcl::make_shared<Cloud>();
  default: {
    auto cloud = pcl::make_shared<Cloud>();
    const int n = 1 + in.byte() % 200;
    for (int i = 0; i < n && !in.empty(); ++i)
      cloud->push_back(pcl::PointXYZ(coordinate(in), coordinate(in), coordinate(in)));
    return cloud;
  }
  }
}

Eigen::Matrix4f
makeGuess(FuzzInput& in)
{
  Eigen::Matrix4f guess = Eigen::Matrix4f::Identity();
  switch (in.byte() % 6) {
  case 0:
    break;
  case 1:
    return Eigen::Matrix4f::Zero();
  case 2:
    guess.topLeftCorner<3, 3>() *= 1.0f + 0.01f * in.byte();
    break;
  case 3:
    guess(3, 0) = 0.5f;
    break;
  default:
    guess.topLeftCorner<3, 3>() =
        Eigen::AngleAxisf(0.05f * in.byte(), Eigen::Vector3f(coordinate(in), 1.0f, coordinate(in))
                                                 .normalized())
            .toRotationMatrix();
    guess.topRightCorner<3, 1>() << coordinate(in), coordinate(in), coordinate(in);
  }
  return guess;
}

} // namespace

extern "C" int
LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  FuzzInput in(data, size);
  Registration reg;
  reg.setMaximumIterations(30); // bounded work per input
  Cloud::Ptr source, target;
  for (int step = 0; step < 12 && !in.empty(); ++step) {
    switch (in.byte() % 11) {
    case 0:
      source = makeCloud(in);
      reg.setInputSource(source);
      break;
    case 1:
      target = makeCloud(in);
      reg.setInputTarget(target);
      break;
    case 2: {
      auto indices = pcl::make_shared<pcl::Indices>();
      const int n = in.byte() % 50;
      for (int i = 0; i < n; ++i)
        indices->push_back(static_cast<pcl::index_t>(in.byte()) - 5);
      reg.setIndices(indices);
      break;
    }
    case 3:
      reg.setMaximumIterations(static_cast<int>(in.byte() % 40) - 2);
      break;
    case 4: {
      const std::uint8_t r = in.byte();
      reg.setResolution(r < 240 ? 0.05 * (1 + r) : static_cast<double>(coordinate(in)));
      break;
    }
    case 5:
      reg.setNumberOfRestarts(in.byte() % 2 ? in.byte() % 8 : std::numeric_limits<int>::max());
      break;
    case 6: {
      const Eigen::Matrix4f guess = makeGuess(in);
      Cloud output;
      reg.align(output, guess);
      if (reg.hasConverged() && !reg.getLastError().empty())
        __builtin_trap();
      const Eigen::Matrix4f final_transformation = reg.getFinalTransformation();
      const bool is_guess = (final_transformation.array() == guess.array() ||
                             (final_transformation.array().isNaN() && guess.array().isNaN()))
                                .all();
      // A failure leaves the guess; a search that did not converge (its reason also in
      // getLastError()) leaves the best pose found.
      if (!reg.getLastResult().error.empty() && !is_guess)
        __builtin_trap();
      if (!reg.getLastError().empty() && reg.getLastResult().error.empty() &&
          reg.getLastError().rfind("not converged", 0) != 0)
        __builtin_trap();
      if (reg.getLastError().empty() && !reg.getFinalTransformation().allFinite())
        __builtin_trap();
      const pcl_mi::Verification& verdict = reg.getVerification();
      if ((verdict.refusal == pcl_mi::Refusal::None) != verdict.reason.empty())
        __builtin_trap();
      break;
    }
    case 7:
      (void)reg.getFitnessScore();
      // At any moment, after any change: the first call refines the last result again.
      if (!reg.getCovariance().allFinite())
        __builtin_trap();
      break;
    case 8:
      (void)reg.evaluate(makeGuess(in));
      break;
    case 9: {
      // A cloud set earlier grows, shrinks or empties in place, into new memory: the object
      // reads clouds in place and must not read where this one was.
      const Cloud::Ptr& cloud = in.byte() % 2 ? source : target;
      if (cloud) {
        cloud->resize(in.byte() % 220);
        cloud->points.shrink_to_fit();
      }
      break;
    }
    default: {
      const double s = in.byte() % 2 ? 1e-7 : 1.0;
      reg.setSimplexSteps((Registration::Vector6d() << s, s, s, 0.1 * s, 0.1 * s, s).finished());
    }
    }
  }
  return 0;
}
