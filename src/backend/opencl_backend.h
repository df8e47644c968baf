/*
 * pcl_mi: the OpenCL backend's entry points. Only built with PCL_MI_WITH_OPENCL; no
 * OpenCL type appears here.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "backend/scoring_backend.h"

#include <memory>
#include <string>

namespace pcl_mi {
namespace backend {

/** \brief An OpenCL device with its context and built kernels (opaque). */
struct OpenClDevice;

/** \brief The device at (platform, device) index, or with -1/-1 the first GPU, else the
 * first device; opened and its kernels built once per process. Null (with \a error: the
 * OpenCL error name, and the build log if the kernels do not build) when unavailable. */
std::shared_ptr<OpenClDevice>
openClDevice(int platform, int device, std::string& error);

/** \brief The device's name as its driver reports it. */
std::string
openClDeviceName(const OpenClDevice& device);

/** \brief True when the device openClDevice(platform, device) would open is a GPU or
 * accelerator, false for a CPU device (e.g. PoCL's) or, with \a error, for none. Only
 * enumerates devices: no context, no kernel build. */
bool
openClDeviceIsOffload(int platform, int device, std::string& error);

/** \brief A backend on \a device; with \a profile_device every command is timed with
 * device events; with \a batch it prefersBatches(). Throws std::runtime_error on OpenCL
 * errors. */
std::unique_ptr<ScoringBackend>
makeOpenClBackend(std::shared_ptr<OpenClDevice> device, bool profile_device, bool batch);

} // namespace backend
} // namespace pcl_mi
