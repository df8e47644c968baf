/*
 * pcl_mi: finding an OpenCL device, and building the kernels on it once per process.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "backend/opencl_backend.h"
#include "backend/opencl_handles.h"

#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace pcl_mi {
namespace backend {

extern const char* const kJointHistogramKernelSource; // generated from kernels/

namespace {

std::string
deviceString(cl_device_id device, cl_device_info what)
{
  std::size_t size = 0;
  clGetDeviceInfo(device, what, 0, nullptr, &size);
  std::string value(size, '\0');
  clGetDeviceInfo(device, what, size, value.data(), nullptr);
  while (!value.empty() && value.back() == '\0')
    value.pop_back();
  return value;
}

std::string
kernelSource()
{
  // Developers may edit the kernels without rebuilding: PCL_MI_KERNEL_DIR overrides the
  // copy embedded at build time.
  if (const char* dir = std::getenv("PCL_MI_KERNEL_DIR")) {
    std::stringstream text;
    for (const char* file : {"voxel_math.h", "joint_histogram.cl"}) { // as embedded
      const std::string path = std::string(dir) + "/" + file;
      std::ifstream in(path);
      if (!in)
        throw std::runtime_error("OpenCL: PCL_MI_KERNEL_DIR is set but " + path +
                                 " cannot be read");
      text << in.rdbuf() << '\n';
    }
    return text.str();
  }
  return kJointHistogramKernelSource;
}

/** An enumerated device, before anything is created on it. */
struct Candidate {
  cl_platform_id platform;
  cl_device_id device;
  bool gpu;
  bool offload; // a GPU or an accelerator, not the host's CPU
};

/** The device at (platform, device) index, or with -1/-1 the first GPU, else the first
 * device. Enumeration only; throws std::runtime_error when there is none. */
Candidate
chooseDevice(int platform_index, int device_index)
{
  cl_uint num_platforms = 0;
  cl_int status = clGetPlatformIDs(0, nullptr, &num_platforms);
  if (status != CL_SUCCESS || num_platforms == 0)
    throw std::runtime_error(std::string("OpenCL: no platform found (") +
                             (status != CL_SUCCESS ? errorName(status) : "0 platforms") +
                             "); install an ICD such as pocl-opencl-icd");
  std::vector<cl_platform_id> platforms(num_platforms);
  check(clGetPlatformIDs(num_platforms, platforms.data(), nullptr), "clGetPlatformIDs");

  // Explicit indices pick one device; otherwise the first GPU, else the first device.
  std::vector<Candidate> candidates;
  for (cl_uint p = 0; p < num_platforms; ++p) {
    if (platform_index >= 0 && static_cast<cl_uint>(platform_index) != p)
      continue;
    cl_uint num_devices = 0;
    if (clGetDeviceIDs(platforms[p], CL_DEVICE_TYPE_ALL, 0, nullptr, &num_devices) !=
            CL_SUCCESS ||
        num_devices == 0)
      continue;
    std::vector<cl_device_id> devices(num_devices);
    check(clGetDeviceIDs(platforms[p], CL_DEVICE_TYPE_ALL, num_devices, devices.data(), nullptr),
          "clGetDeviceIDs");
    for (cl_uint d = 0; d < num_devices; ++d) {
      if (device_index >= 0 && static_cast<cl_uint>(device_index) != d)
        continue;
      cl_device_type type = 0;
      clGetDeviceInfo(devices[d], CL_DEVICE_TYPE, sizeof(type), &type, nullptr);
      candidates.push_back({platforms[p], devices[d], (type & CL_DEVICE_TYPE_GPU) != 0,
                            (type & (CL_DEVICE_TYPE_GPU | CL_DEVICE_TYPE_ACCELERATOR)) != 0});
    }
  }
  if (candidates.empty()) {
    std::ostringstream s;
    s << "OpenCL: no device found";
    if (platform_index >= 0 || device_index >= 0)
      s << " at platform " << platform_index << ", device " << device_index;
    throw std::runtime_error(s.str());
  }
  Candidate chosen = candidates.front();
  if (platform_index < 0 && device_index < 0)
    for (const Candidate& c : candidates)
      if (c.gpu) {
        chosen = c;
        break;
      }
  return chosen;
}

std::shared_ptr<OpenClDevice>
openDevice(int platform_index, int device_index)
{
  const Candidate chosen = chooseDevice(platform_index, device_index);
  auto device = std::make_shared<OpenClDevice>();
  device->platform = chosen.platform;
  device->device = chosen.device;
  device->name = deviceString(chosen.device, CL_DEVICE_NAME);
  if (deviceString(chosen.device, CL_DEVICE_EXTENSIONS).find("cl_khr_fp64") == std::string::npos)
    throw std::runtime_error("OpenCL: device '" + device->name +
                             "' lacks cl_khr_fp64, which the feature binning needs to match "
                             "the CPU bit for bit");
  cl_int error = CL_SUCCESS;
  device->context = ClContext(clCreateContext(nullptr, 1, &chosen.device, nullptr, nullptr, &error));
  check(error, "clCreateContext");

  const auto start = Clock::now();
  const std::string source = kernelSource();
  const char* text = source.c_str();
  const std::size_t length = source.size();
  device->program = ClProgram(
      clCreateProgramWithSource(device->context.get(), 1, &text, &length, &error));
  check(error, "clCreateProgramWithSource");
  error = clBuildProgram(device->program.get(), 1, &chosen.device, "-cl-std=CL1.2", nullptr, nullptr);
  if (error != CL_SUCCESS) {
    std::size_t size = 0;
    clGetProgramBuildInfo(device->program.get(), chosen.device, CL_PROGRAM_BUILD_LOG, 0, nullptr, &size);
    std::string log(size, '\0');
    clGetProgramBuildInfo(device->program.get(), chosen.device, CL_PROGRAM_BUILD_LOG, size, log.data(),
                          nullptr);
    throw std::runtime_error(std::string("OpenCL: building the kernels for '") + device->name +
                             "' failed: " + errorName(error) + "\nbuild log:\n" + log);
  }
  device->build_ms = millisecondsSince(start);
  return device;
}

} // namespace

std::shared_ptr<OpenClDevice>
openClDevice(int platform, int device, std::string& error)
{
  // One context and program per device for the whole process: building the program is
  // the slowest step of all (hundreds of ms on PoCL).
  static std::mutex mutex;
  static std::map<std::pair<int, int>, std::shared_ptr<OpenClDevice>> devices;
  static std::map<std::pair<int, int>, std::string> failures;
  std::lock_guard<std::mutex> lock(mutex);
  const auto key = std::make_pair(platform, device);
  if (auto found = devices.find(key); found != devices.end())
    return found->second;
  if (auto failed = failures.find(key); failed != failures.end()) {
    error = failed->second;
    return nullptr;
  }
  try {
    auto opened = openDevice(platform, device);
    devices[key] = opened;
    return opened;
  }
  catch (const std::exception& e) {
    error = failures[key] = e.what();
    return nullptr;
  }
}

std::string
openClDeviceName(const OpenClDevice& device)
{
  return device.name;
}

bool
openClDeviceIsOffload(int platform, int device, std::string& error)
{
  try {
    return chooseDevice(platform, device).offload;
  }
  catch (const std::exception& e) {
    error = e.what();
    return false;
  }
}

} // namespace backend
} // namespace pcl_mi
