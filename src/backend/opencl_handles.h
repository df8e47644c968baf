/*
 * pcl_mi: what the OpenCL backend's files share: the OpenCL headers at the version the
 * kernels target, error reporting, owning handles for OpenCL objects and the device.
 * Private to src/backend; no public header sees an OpenCL type.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>

#include <chrono>
#include <cstddef>
#include <string>
#include <utility>

namespace pcl_mi {
namespace backend {

using Clock = std::chrono::steady_clock;

/** Milliseconds since \a start. */
double
millisecondsSince(Clock::time_point start);

/** The name of an OpenCL error code, with a hint for the common set-up mistakes. */
const char*
errorName(cl_int code);

/** Throws std::runtime_error naming the failed call and the error. */
void
check(cl_int status, const char* what);

/** Sole owner of one OpenCL object: released with its owner, movable, not copyable. */
template <typename T, cl_int (*Release)(T)>
class ClHandle {
public:
  ClHandle() = default;
  explicit ClHandle(T object) : object_(object) {}
  ClHandle(ClHandle&& o) noexcept : object_(std::exchange(o.object_, nullptr)) {}
  ClHandle&
  operator=(ClHandle&& o) noexcept
  {
    if (this != &o) {
      reset();
      object_ = std::exchange(o.object_, nullptr);
    }
    return *this;
  }
  ClHandle(const ClHandle&) = delete;
  ClHandle&
  operator=(const ClHandle&) = delete;
  ~ClHandle() { reset(); }

  T
  get() const
  {
    return object_;
  }
  explicit operator bool() const
  {
    return object_ != nullptr;
  }
  /** Releases the object held and returns where a call may store a new one. */
  T*
  out()
  {
    reset();
    return &object_;
  }
  void
  reset()
  {
    if (object_)
      Release(object_);
    object_ = nullptr;
  }

private:
  T object_ = nullptr;
};

using ClContext = ClHandle<cl_context, clReleaseContext>;
using ClProgram = ClHandle<cl_program, clReleaseProgram>;
using ClQueue = ClHandle<cl_command_queue, clReleaseCommandQueue>;
using ClKernel = ClHandle<cl_kernel, clReleaseKernel>;
using ClEvent = ClHandle<cl_event, clReleaseEvent>;
using ClMem = ClHandle<cl_mem, clReleaseMemObject>;

/** A device buffer and its size. */
class Buffer {
public:
  /** Replaces the buffer by one of \a bytes (at least 16, so that empty inputs still bind). */
  void
  allocate(cl_context context, std::size_t bytes);
  cl_mem
  get() const
  {
    return mem_.get();
  }
  std::size_t
  bytes() const
  {
    return bytes_;
  }

private:
  ClMem mem_;
  std::size_t bytes_ = 0;
};

/** A device with its context and built program, shared by every backend on it. */
struct OpenClDevice {
  cl_platform_id platform = nullptr;
  cl_device_id device = nullptr;
  ClContext context;
  ClProgram program;
  std::string name;
  double build_ms = 0.0;
};

} // namespace backend
} // namespace pcl_mi
