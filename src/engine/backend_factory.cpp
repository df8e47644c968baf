/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "engine/backend_factory.h"

#ifdef PCL_MI_WITH_OPENCL
#include "backend/opencl_backend.h"
#endif

namespace pcl_mi {
namespace core {

bool
BackendFactory::choose(const BackendParameters& backend,
                       const SamplingParameters& sampling,
                       std::string& error)
{
  device_.reset();
  profile_device_ = backend.profile_device;
  batch_ = false;
  name_ = "cpu";
  warning_.clear();
  if (backend.type == Backend::Cpu)
    return true;
  // Auto takes OpenCL only where it was measured to be faster (docs/opencl.md): on a GPU
  // or accelerator, with every point in every evaluation. Sampled evaluations are too
  // light to hide the device's latency, and an OpenCL CPU device (PoCL) is slower than the
  // CPU backend on the same cores.
  if (backend.type == Backend::Auto && sampling.source_subdivision != 0)
    return true;
  std::string why;
#ifdef PCL_MI_WITH_OPENCL
  // A CPU device is decided on before its kernels are built; no device at all falls
  // through to openClDevice(), whose error becomes the warning.
  std::string no_device;
  if (backend.type == Backend::Auto &&
      !backend::openClDeviceIsOffload(backend.opencl_platform, backend.opencl_device, no_device) &&
      no_device.empty())
    return true;
  device_ = backend::openClDevice(backend.opencl_platform, backend.opencl_device, why);
  if (device_) {
    // Batches pay where a round trip outweighs the poses it scores: on a GPU, not on a
    // CPU device, where speculative poses are extra work on the same cores.
    std::string unused;
    batch_ = backend.batching == Batching::On ||
             (backend.batching == Batching::Auto &&
              backend::openClDeviceIsOffload(backend.opencl_platform, backend.opencl_device,
                                             unused));
    name_ = "opencl (" + backend::openClDeviceName(*device_) + ")";
    return true;
  }
#else
  why = "this pcl_mi was built without its OpenCL backend (PCL_MI_WITH_OPENCL=OFF or no "
        "OpenCL found at build time)";
#endif
  if (backend.type == Backend::OpenCL) {
    error = "the OpenCL backend was requested but is unavailable: " + why;
    return false;
  }
  warning_ = "no usable OpenCL device, using the CPU backend: " + why;
  return true;
}

std::unique_ptr<backend::ScoringBackend>
BackendFactory::make() const
{
#ifdef PCL_MI_WITH_OPENCL
  if (device_)
    return backend::makeOpenClBackend(device_, profile_device_, batch_);
#endif
  return backend::makeCpuBackend();
}

} // namespace core
} // namespace pcl_mi
