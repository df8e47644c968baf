/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "backend/opencl_handles.h"

#include <algorithm>
#include <sstream>
#include <stdexcept>

namespace pcl_mi {
namespace backend {

double
millisecondsSince(Clock::time_point start)
{
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

const char*
errorName(cl_int code)
{
  switch (code) {
#define PCL_MI_CL_ERROR(name)                                                              \
  case name:                                                                               \
    return #name;
    PCL_MI_CL_ERROR(CL_DEVICE_NOT_FOUND)
    PCL_MI_CL_ERROR(CL_DEVICE_NOT_AVAILABLE)
    PCL_MI_CL_ERROR(CL_COMPILER_NOT_AVAILABLE)
    PCL_MI_CL_ERROR(CL_MEM_OBJECT_ALLOCATION_FAILURE)
    PCL_MI_CL_ERROR(CL_OUT_OF_RESOURCES)
    PCL_MI_CL_ERROR(CL_OUT_OF_HOST_MEMORY)
    PCL_MI_CL_ERROR(CL_PROFILING_INFO_NOT_AVAILABLE)
    PCL_MI_CL_ERROR(CL_BUILD_PROGRAM_FAILURE)
    PCL_MI_CL_ERROR(CL_INVALID_VALUE)
    PCL_MI_CL_ERROR(CL_INVALID_DEVICE_TYPE)
    PCL_MI_CL_ERROR(CL_INVALID_PLATFORM)
    PCL_MI_CL_ERROR(CL_INVALID_DEVICE)
    PCL_MI_CL_ERROR(CL_INVALID_CONTEXT)
    PCL_MI_CL_ERROR(CL_INVALID_COMMAND_QUEUE)
    PCL_MI_CL_ERROR(CL_INVALID_MEM_OBJECT)
    PCL_MI_CL_ERROR(CL_INVALID_BUILD_OPTIONS)
    PCL_MI_CL_ERROR(CL_INVALID_PROGRAM)
    PCL_MI_CL_ERROR(CL_INVALID_PROGRAM_EXECUTABLE)
    PCL_MI_CL_ERROR(CL_INVALID_KERNEL_NAME)
    PCL_MI_CL_ERROR(CL_INVALID_KERNEL)
    PCL_MI_CL_ERROR(CL_INVALID_ARG_INDEX)
    PCL_MI_CL_ERROR(CL_INVALID_ARG_VALUE)
    PCL_MI_CL_ERROR(CL_INVALID_ARG_SIZE)
    PCL_MI_CL_ERROR(CL_INVALID_KERNEL_ARGS)
    PCL_MI_CL_ERROR(CL_INVALID_WORK_DIMENSION)
    PCL_MI_CL_ERROR(CL_INVALID_WORK_GROUP_SIZE)
    PCL_MI_CL_ERROR(CL_INVALID_WORK_ITEM_SIZE)
    PCL_MI_CL_ERROR(CL_INVALID_GLOBAL_OFFSET)
    PCL_MI_CL_ERROR(CL_INVALID_EVENT)
    PCL_MI_CL_ERROR(CL_INVALID_BUFFER_SIZE)
    PCL_MI_CL_ERROR(CL_INVALID_GLOBAL_WORK_SIZE)
#undef PCL_MI_CL_ERROR
  case -1001:
    return "CL_PLATFORM_NOT_FOUND_KHR (no OpenCL platform: is an ICD such as "
           "pocl-opencl-icd installed?)";
  default:
    return "unknown OpenCL error";
  }
}

/** Throws std::runtime_error naming the failed call and the error. */
void
check(cl_int status, const char* what)
{
  if (status != CL_SUCCESS) {
    std::ostringstream s;
    s << "OpenCL: " << what << " failed: " << errorName(status) << " (" << status << ")";
    throw std::runtime_error(s.str());
  }
}

void
Buffer::allocate(cl_context context, std::size_t bytes)
{
  cl_int error = CL_SUCCESS;
  mem_ = ClMem(
      clCreateBuffer(context, CL_MEM_READ_WRITE, std::max<std::size_t>(bytes, 16), nullptr, &error));
  check(error, "clCreateBuffer");
  bytes_ = bytes;
}

} // namespace backend
} // namespace pcl_mi
