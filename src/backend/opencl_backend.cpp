/*
 * pcl_mi: the OpenCL backend. Runs kernels/joint_histogram.cl; the target's grid, the
 * source samples and the voxel moments live on the device, allocated once per target and
 * source and reused by every evaluation. Only the pose goes up and the joint histogram
 * (and the overlap size) comes back.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#define CL_TARGET_OPENCL_VERSION 120
#include "backend/opencl_backend.h"

#include "features/feature_binning.h"

#include <CL/cl.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>

namespace pcl_mi {
namespace backend {

extern const char* const kJointHistogramKernelSource; // generated from kernels/*.cl

namespace {

using Clock = std::chrono::steady_clock;

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

// The device structs are kernels/voxel_math.h's, which host and kernels share.
using DeviceSample = voxel::pcl_mi_sample;
using DeviceOccupiedVoxel = voxel::pcl_mi_occupied_voxel;
using DevicePose = voxel::pcl_mi_grid_pose;
static_assert(sizeof(DeviceSample) == 48 && sizeof(DeviceOccupiedVoxel) == 20 &&
                  sizeof(DevicePose) == 64,
              "the OpenCL C compiler lays these structs out without padding");

constexpr std::size_t kGroupSize = 128;
constexpr std::size_t kReduceGroupSize = 128;

std::size_t
roundUp(std::size_t n, std::size_t multiple)
{
  return (n + multiple - 1) / multiple * multiple;
}

} // namespace

/** A device with its context and built program, shared by every backend on it. */
struct OpenClDevice {
  cl_platform_id platform = nullptr;
  cl_device_id device = nullptr;
  cl_context context = nullptr;
  cl_program program = nullptr;
  std::string name;
  double build_ms = 0.0;

  ~OpenClDevice()
  {
    if (program)
      clReleaseProgram(program);
    if (context)
      clReleaseContext(context);
  }
};

namespace {

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
  device->context = clCreateContext(nullptr, 1, &chosen.device, nullptr, nullptr, &error);
  check(error, "clCreateContext");

  const auto start = Clock::now();
  const std::string source = kernelSource();
  const char* text = source.c_str();
  const std::size_t length = source.size();
  device->program = clCreateProgramWithSource(device->context, 1, &text, &length, &error);
  check(error, "clCreateProgramWithSource");
  error = clBuildProgram(device->program, 1, &chosen.device, "-cl-std=CL1.2", nullptr, nullptr);
  if (error != CL_SUCCESS) {
    std::size_t size = 0;
    clGetProgramBuildInfo(device->program, chosen.device, CL_PROGRAM_BUILD_LOG, 0, nullptr, &size);
    std::string log(size, '\0');
    clGetProgramBuildInfo(device->program, chosen.device, CL_PROGRAM_BUILD_LOG, size, log.data(),
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

namespace {

/** A device buffer released with its owner. */
class Buffer {
public:
  Buffer() = default;
  Buffer(const Buffer&) = delete;
  Buffer&
  operator=(const Buffer&) = delete;
  ~Buffer() { reset(); }

  void
  allocate(cl_context context, std::size_t bytes)
  {
    reset();
    cl_int error = CL_SUCCESS;
    mem_ = clCreateBuffer(context, CL_MEM_READ_WRITE, std::max<std::size_t>(bytes, 16), nullptr,
                          &error);
    check(error, "clCreateBuffer");
    bytes_ = bytes;
  }
  void
  reset()
  {
    if (mem_)
      clReleaseMemObject(mem_);
    mem_ = nullptr;
    bytes_ = 0;
  }
  cl_mem
  get() const
  {
    return mem_;
  }
  std::size_t
  bytes() const
  {
    return bytes_;
  }

private:
  cl_mem mem_ = nullptr;
  std::size_t bytes_ = 0;
};

class OpenClBackend final : public ScoringBackend {
public:
  OpenClBackend(std::shared_ptr<OpenClDevice> device, bool profile_device)
      : device_(std::move(device)), profiling_(profile_device)
  {
    const auto start = Clock::now();
    cl_int error = CL_SUCCESS;
    queue_ = clCreateCommandQueue(device_->context, device_->device,
                                  profiling_ ? CL_QUEUE_PROFILING_ENABLE : 0, &error);
    check(error, "clCreateCommandQueue");
    // Kernel objects hold their arguments, so every backend has its own.
    for (auto& [kernel, name] : {std::make_pair(&map_samples_, "map_samples"),
                                 std::make_pair(&reduce_overlap_, "reduce_overlap"),
                                 std::make_pair(&histogram_touched_, "histogram_touched"),
                                 std::make_pair(&histogram_target_only_, "histogram_target_only"),
                                 std::make_pair(&clear_touched_, "clear_touched"),
                                 std::make_pair(&reset_histogram_, "reset_histogram")}) {
      *kernel = clCreateKernel(device_->program, name, &error);
      check(error, name);
    }
    counters_.allocate(device_->context, kNumCounters * sizeof(cl_uint));
    overlap_.allocate(device_->context, 8 * sizeof(cl_int));
    addHost("queue and kernels", millisecondsSince(start));
    addHost("program build (shared)", device_->build_ms);
  }

  ~OpenClBackend() override
  {
    if (queue_)
      clFinish(queue_);
    for (cl_event& e : pending_)
      if (e)
        clReleaseEvent(e);
    for (cl_kernel k : {map_samples_, reduce_overlap_, histogram_touched_,
                        histogram_target_only_, clear_touched_, reset_histogram_})
      if (k)
        clReleaseKernel(k);
    if (queue_)
      clReleaseCommandQueue(queue_);
  }

  const char*
  name() const override
  {
    return "opencl";
  }

  void
  setTarget(std::shared_ptr<const core::TargetGrid> target) override
  {
    target_ = std::move(target);
    const core::GridGeometry& g = target_->geometry;
    auto start = Clock::now();
    bins_.allocate(device_->context, target_->bins.size());
    std::vector<DeviceOccupiedVoxel> occupied;
    occupied.reserve(target_->occupied.size());
    for (const auto& v : target_->occupied)
      occupied.push_back({v.cell, v.ix, v.iy, v.iz, v.bin});
    occupied_.allocate(device_->context, occupied.size() * sizeof(DeviceOccupiedVoxel));
    // One spare cell past the grid, as on the CPU.
    moments_.allocate(device_->context, (g.cellCount() + 1) * 4 * sizeof(cl_uint));
    const std::size_t side = static_cast<std::size_t>(target_->binning.num_bins) + 1;
    joint_.allocate(device_->context, side * side * sizeof(cl_uint));
    addHost("memory allocation", millisecondsSince(start));

    start = Clock::now();
    check(clEnqueueWriteBuffer(queue_, bins_.get(), CL_FALSE, 0, target_->bins.size(),
                               target_->bins.data(), 0, nullptr, nullptr),
          "uploading the target bins");
    if (!occupied.empty())
      check(clEnqueueWriteBuffer(queue_, occupied_.get(), CL_FALSE, 0, occupied_.bytes(),
                                 occupied.data(), 0, nullptr, nullptr),
            "uploading the occupied voxels");
    const cl_uint zero = 0;
    check(clEnqueueFillBuffer(queue_, moments_.get(), &zero, sizeof(zero), 0, moments_.bytes(),
                              0, nullptr, nullptr),
          "clearing the voxel moments");
    // Each evaluation leaves these zeroed for the next one; the first needs them zero too.
    check(clEnqueueFillBuffer(queue_, joint_.get(), &zero, sizeof(zero), 0, joint_.bytes(), 0,
                              nullptr, nullptr),
          "clearing the histogram");
    check(clEnqueueFillBuffer(queue_, counters_.get(), &zero, sizeof(zero), 0, counters_.bytes(),
                              0, nullptr, nullptr),
          "clearing the counters");
    check(clFinish(queue_), "clFinish");
    addHost("copy to device", millisecondsSince(start));
  }

  void
  setSource(std::shared_ptr<const core::SourceSamples> source) override
  {
    source_ = std::move(source);
    const std::size_t n = source_->samples.size();
    std::vector<DeviceSample> samples(n);
    for (std::size_t i = 0; i < n; ++i) {
      const core::SourceSample& s = source_->samples[i];
      DeviceSample& d = samples[i];
      d.px = s.position.x();
      d.py = s.position.y();
      d.pz = s.position.z();
      d.count = s.count;
      std::memcpy(d.c, s.covariance, sizeof(d.c));
      d.pad[0] = d.pad[1] = 0.0f;
    }
    auto start = Clock::now();
    samples_.allocate(device_->context, n * sizeof(DeviceSample));
    touched_.allocate(device_->context, n * sizeof(cl_uint));
    groups_ = std::max<std::size_t>(1, roundUp(n, kGroupSize) / kGroupSize);
    group_boxes_.allocate(device_->context, groups_ * 6 * sizeof(cl_float));
    addHost("memory allocation", millisecondsSince(start));
    start = Clock::now();
    if (n > 0)
      check(clEnqueueWriteBuffer(queue_, samples_.get(), CL_TRUE, 0, samples_.bytes(),
                                 samples.data(), 0, nullptr, nullptr),
            "uploading the source samples");
    addHost("copy to device", millisecondsSince(start));
  }

  void
  jointHistogram(const Eigen::Matrix3f& rotation,
                 const Eigen::Vector3f& translation,
                 JointHistogram& histogram) override
  {
    const core::GridGeometry& g = target_->geometry;
    const int num_bins = target_->binning.num_bins + 1;
    histogram.num_bins = num_bins;
    histogram.counts.assign(static_cast<std::size_t>(num_bins) * num_bins, 0);
    histogram.overlap_voxels = 0;
    const std::size_t n = source_->samples.size();
    if (n == 0)
      return;

    // The same float operations as the CPU backend, in the same order.
    const core::GridPose grid_pose = core::gridPose(g, rotation, translation);
    DevicePose pose;
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 3; ++col)
        pose.r[3 * row + col] = grid_pose.rotation(row, col);
    for (int a = 0; a < 3; ++a) {
      pose.t[a] = grid_pose.translation[a];
      pose.rz[a] = grid_pose.rotation_z[a];
    }
    pose.variance_scale = grid_pose.variance_scale;
    const cl_int4 dims = {{g.dims.x(), g.dims.y(), g.dims.z(), 0}};
    const cl_uint num_samples = static_cast<cl_uint>(n);
    const cl_uint has_covariance = source_->has_covariance ? 1u : 0u;
    const cl_uint feature = target_->feature == Feature::PointCount ? 1u : 0u;
    const cl_uint occupied_bins = static_cast<cl_uint>(target_->binning.num_bins);
    const cl_double max_value = target_->binning.max_value;
    const cl_uint spare_cell = static_cast<cl_uint>(g.cellCount());
    const cl_uint num_occupied = static_cast<cl_uint>(target_->occupied.size());
    const cl_uint num_groups = static_cast<cl_uint>(groups_);
    const std::size_t side2 = static_cast<std::size_t>(num_bins) * num_bins;

    // The histogram, the counters and the touched voxels' moments are zero here: the previous
    // evaluation cleared them after its results were read (or setTarget() did), so the
    // clearing runs while the host computes the entropies, not on the critical path.
    cl_event events[6] = {nullptr, nullptr, nullptr, nullptr, nullptr, nullptr};
    setArgs(map_samples_, samples_.get(), num_samples, pose, dims, has_covariance, moments_.get(),
            touched_.get(), counters_.get(), group_boxes_.get(),
            Local{6 * kGroupSize * sizeof(cl_float)});
    const std::size_t sample_range = groups_ * kGroupSize;
    check(clEnqueueNDRangeKernel(queue_, map_samples_, 1, nullptr, &sample_range, &kGroupSize, 0,
                                 nullptr, event(events[0])),
          "map_samples");

    setArgs(reduce_overlap_, group_boxes_.get(), num_groups, num_samples, dims, overlap_.get(),
            Local{6 * kReduceGroupSize * sizeof(cl_float)});
    check(clEnqueueNDRangeKernel(queue_, reduce_overlap_, 1, nullptr, &kReduceGroupSize,
                                 &kReduceGroupSize, 0, nullptr, event(events[1])),
          "reduce_overlap");

    setArgs(histogram_touched_, touched_.get(), counters_.get(), moments_.get(), bins_.get(),
            feature, occupied_bins, max_value, spare_cell, joint_.get(),
            Local{side2 * sizeof(cl_uint)});
    check(clEnqueueNDRangeKernel(queue_, histogram_touched_, 1, nullptr, &sample_range,
                                 &kGroupSize, 0, nullptr, event(events[2])),
          "histogram_touched");

    const std::size_t occupied_range = std::max(kGroupSize, roundUp(num_occupied, kGroupSize));
    setArgs(histogram_target_only_, occupied_.get(), num_occupied, moments_.get(),
            overlap_.get(), occupied_bins, joint_.get(),
            Local{static_cast<std::size_t>(num_bins) * sizeof(cl_uint)});
    check(clEnqueueNDRangeKernel(queue_, histogram_target_only_, 1, nullptr, &occupied_range,
                                 &kGroupSize, 0, nullptr, event(events[3])),
          "histogram_target_only");

    // One read brings back the histogram; the overlap box follows on the same queue.
    cl_int overlap[8] = {0};
    check(clEnqueueReadBuffer(queue_, joint_.get(), CL_FALSE, 0, side2 * sizeof(cl_uint),
                              histogram.counts.data(), 0, nullptr, event(events[4])),
          "reading the histogram");
    check(clEnqueueReadBuffer(queue_, overlap_.get(), CL_TRUE, 0, 7 * sizeof(cl_int), overlap, 0,
                              nullptr, event(events[5])),
          "reading the overlap");

    static const char* const kStage[6] = {"voxel mapping",     "find overlap",
                                          "feature histogram", "feature histogram",
                                          "copy to host",      "copy to host"};
    for (int e = 0; e < 6; ++e)
      accountDevice(kStage[e], events[e]);
    // The previous evaluation's clearing finished before this one started (in-order queue).
    accountPending();

    // Clear for the next evaluation, off the critical path: flushed now, waited for by the
    // next evaluation's first kernel.
    setArgs(clear_touched_, touched_.get(), counters_.get(), moments_.get());
    check(clEnqueueNDRangeKernel(queue_, clear_touched_, 1, nullptr, &sample_range, &kGroupSize,
                                 0, nullptr, event(pending_[0])),
          "clear_touched");
    const cl_uint joint_size = static_cast<cl_uint>(side2);
    const cl_uint num_counters = kNumCounters;
    setArgs(reset_histogram_, joint_.get(), joint_size, counters_.get(), num_counters);
    check(clEnqueueNDRangeKernel(queue_, reset_histogram_, 1, nullptr, &kGroupSize, &kGroupSize,
                                 0, nullptr, event(pending_[1])),
          "reset_histogram");
    check(clFlush(queue_), "clFlush");

    if (!overlap[6]) {
      std::fill(histogram.counts.begin(), histogram.counts.end(), 0u);
      return;
    }
    histogram.overlap_voxels = static_cast<std::uint64_t>(overlap[3] - overlap[0] + 1) *
                               (overlap[4] - overlap[1] + 1) * (overlap[5] - overlap[2] + 1);
    std::uint64_t counted = 0;
    for (const std::uint32_t c : histogram.counts)
      counted += c;
    histogram.counts[0] += static_cast<std::uint32_t>(histogram.overlap_voxels - counted);
  }

  void
  appendProfile(std::vector<StageTiming>& stages) const override
  {
    for (const StageTiming& s : profile_) {
      StageTiming& stage = stageNamed(stages, s.name);
      // The backends of one device share its program: its build counts once.
      if (stage.calls > 0 && s.name.find("program build") != std::string::npos)
        continue;
      stage.calls += s.calls;
      stage.total_ms += s.total_ms;
    }
  }

  void
  resetProfile() override
  {
    profile_.clear();
  }

private:
  struct Local {
    std::size_t bytes;
  };

  void
  setArg(cl_kernel kernel, cl_uint index, const Local& local)
  {
    check(clSetKernelArg(kernel, index, local.bytes, nullptr), "clSetKernelArg (local)");
  }
  void
  setArg(cl_kernel kernel, cl_uint index, cl_mem mem)
  {
    check(clSetKernelArg(kernel, index, sizeof(cl_mem), &mem), "clSetKernelArg (buffer)");
  }
  template <typename T>
  void
  setArg(cl_kernel kernel, cl_uint index, const T& value)
  {
    check(clSetKernelArg(kernel, index, sizeof(T), &value), "clSetKernelArg");
  }
  template <typename... Args>
  void
  setArgs(cl_kernel kernel, const Args&... args)
  {
    cl_uint index = 0;
    (setArg(kernel, index++, args), ...);
  }

  void
  add(const std::string& name, double ms)
  {
    StageTiming& stage = stageNamed(profile_, name);
    ++stage.calls;
    stage.total_ms += ms;
  }
  void
  addDevice(const char* stage, double ms)
  {
    add(std::string("device: ") + stage, ms);
  }
  void
  addHost(const char* stage, double ms)
  {
    add(std::string("host: ") + stage, ms);
  }

  static constexpr cl_uint kNumCounters = 4;

  /** Where a command returns its event: \a slot when profiling, else nowhere (an event
   * the driver need not create or time). */
  cl_event*
  event(cl_event& slot) const
  {
    return profiling_ ? &slot : nullptr;
  }

  /** Adds a finished command's device time to \a stage and releases its event (none
   * without profiling). */
  void
  accountDevice(const char* stage, cl_event& finished)
  {
    if (!finished)
      return;
    cl_ulong begin = 0, end = 0;
    if (clGetEventProfilingInfo(finished, CL_PROFILING_COMMAND_START, sizeof(begin), &begin,
                                nullptr) == CL_SUCCESS &&
        clGetEventProfilingInfo(finished, CL_PROFILING_COMMAND_END, sizeof(end), &end,
                                nullptr) == CL_SUCCESS)
      addDevice(stage, static_cast<double>(end - begin) * 1e-6);
    clReleaseEvent(finished);
    finished = nullptr;
  }

  /** Accounts the previous evaluation's clearing (finished by now). */
  void
  accountPending()
  {
    accountDevice("clear moments", pending_[0]);
    accountDevice("clear histogram", pending_[1]);
  }

  std::shared_ptr<OpenClDevice> device_;
  bool profiling_ = false;
  cl_command_queue queue_ = nullptr;
  cl_kernel map_samples_ = nullptr, reduce_overlap_ = nullptr, histogram_touched_ = nullptr,
            histogram_target_only_ = nullptr, clear_touched_ = nullptr,
            reset_histogram_ = nullptr;
  /** The clearing queued after the last evaluation's read-back, for the profile. */
  cl_event pending_[2] = {nullptr, nullptr};
  std::shared_ptr<const core::TargetGrid> target_;
  std::shared_ptr<const core::SourceSamples> source_;
  Buffer bins_, occupied_, moments_, joint_, counters_, overlap_, samples_, touched_,
      group_boxes_;
  std::size_t groups_ = 1;
  std::vector<StageTiming> profile_;
};

} // namespace

std::unique_ptr<ScoringBackend>
makeOpenClBackend(std::shared_ptr<OpenClDevice> device, bool profile_device)
{
  return std::make_unique<OpenClBackend>(std::move(device), profile_device);
}

} // namespace backend
} // namespace pcl_mi
