/*
 * pcl_mi: the OpenCL backend. Runs kernels/joint_histogram.cl; the target's grid, the
 * source samples and the voxel moments live on the device, allocated once per target and
 * source and reused by every evaluation. Only the pose goes up and the joint histogram
 * (and the overlap size) comes back.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "backend/opencl_backend.h"
#include "backend/opencl_handles.h"

#include "features/feature_binning.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <stdexcept>
#include <vector>

namespace pcl_mi {
namespace backend {

namespace {

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

class OpenClBackend final : public ScoringBackend {
public:
  OpenClBackend(std::shared_ptr<OpenClDevice> device, bool profile_device)
      : device_(std::move(device)), profiling_(profile_device)
  {
    const auto start = Clock::now();
    cl_int error = CL_SUCCESS;
    queue_ = ClQueue(clCreateCommandQueue(device_->context.get(), device_->device,
                                          profiling_ ? CL_QUEUE_PROFILING_ENABLE : 0, &error));
    check(error, "clCreateCommandQueue");
    // Kernel objects hold their arguments, so every backend has its own.
    for (auto& [kernel, name] : {std::make_pair(&map_samples_, "map_samples"),
                                 std::make_pair(&reduce_overlap_, "reduce_overlap"),
                                 std::make_pair(&histogram_touched_, "histogram_touched"),
                                 std::make_pair(&histogram_target_only_, "histogram_target_only"),
                                 std::make_pair(&clear_touched_, "clear_touched"),
                                 std::make_pair(&reset_histogram_, "reset_histogram")}) {
      *kernel = ClKernel(clCreateKernel(device_->program.get(), name, &error));
      check(error, name);
    }
    counters_.allocate(device_->context.get(), kNumCounters * sizeof(cl_uint));
    overlap_.allocate(device_->context.get(), 8 * sizeof(cl_int));
    addHost("queue and kernels", millisecondsSince(start));
    addHost("program build (shared)", device_->build_ms);
  }

  ~OpenClBackend() override
  {
    // The handles release everything; the queued clearing must finish first.
    if (queue_)
      clFinish(queue_.get());
  }
  OpenClBackend(const OpenClBackend&) = delete;
  OpenClBackend&
  operator=(const OpenClBackend&) = delete;

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
    bins_.allocate(device_->context.get(), target_->bins.size());
    std::vector<DeviceOccupiedVoxel> occupied;
    occupied.reserve(target_->occupied.size());
    for (const auto& v : target_->occupied)
      occupied.push_back({v.cell, v.ix, v.iy, v.iz, v.bin});
    occupied_.allocate(device_->context.get(), occupied.size() * sizeof(DeviceOccupiedVoxel));
    // One spare cell past the grid, as on the CPU.
    moments_.allocate(device_->context.get(), (g.cellCount() + 1) * 4 * sizeof(cl_uint));
    const std::size_t side = static_cast<std::size_t>(target_->binning.num_bins) + 1;
    joint_.allocate(device_->context.get(), side * side * sizeof(cl_uint));
    addHost("memory allocation", millisecondsSince(start));

    start = Clock::now();
    check(clEnqueueWriteBuffer(queue_.get(), bins_.get(), CL_FALSE, 0, target_->bins.size(),
                               target_->bins.data(), 0, nullptr, nullptr),
          "uploading the target bins");
    if (!occupied.empty())
      check(clEnqueueWriteBuffer(queue_.get(), occupied_.get(), CL_FALSE, 0, occupied_.bytes(),
                                 occupied.data(), 0, nullptr, nullptr),
            "uploading the occupied voxels");
    const cl_uint zero = 0;
    check(clEnqueueFillBuffer(queue_.get(), moments_.get(), &zero, sizeof(zero), 0, moments_.bytes(),
                              0, nullptr, nullptr),
          "clearing the voxel moments");
    // Each evaluation leaves these zeroed for the next one; the first needs them zero too.
    check(clEnqueueFillBuffer(queue_.get(), joint_.get(), &zero, sizeof(zero), 0, joint_.bytes(), 0,
                              nullptr, nullptr),
          "clearing the histogram");
    check(clEnqueueFillBuffer(queue_.get(), counters_.get(), &zero, sizeof(zero), 0, counters_.bytes(),
                              0, nullptr, nullptr),
          "clearing the counters");
    check(clFinish(queue_.get()), "clFinish");
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
    samples_.allocate(device_->context.get(), n * sizeof(DeviceSample));
    touched_.allocate(device_->context.get(), n * sizeof(cl_uint));
    groups_ = std::max<std::size_t>(1, roundUp(n, kGroupSize) / kGroupSize);
    group_boxes_.allocate(device_->context.get(), groups_ * 6 * sizeof(cl_float));
    addHost("memory allocation", millisecondsSince(start));
    start = Clock::now();
    if (n > 0)
      check(clEnqueueWriteBuffer(queue_.get(), samples_.get(), CL_TRUE, 0, samples_.bytes(),
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
    ClEvent events[6];
    setArgs(map_samples_.get(), samples_.get(), num_samples, pose, dims, has_covariance, moments_.get(),
            touched_.get(), counters_.get(), group_boxes_.get(),
            Local{6 * kGroupSize * sizeof(cl_float)});
    const std::size_t sample_range = groups_ * kGroupSize;
    check(clEnqueueNDRangeKernel(queue_.get(), map_samples_.get(), 1, nullptr, &sample_range, &kGroupSize, 0,
                                 nullptr, event(events[0])),
          "map_samples");

    setArgs(reduce_overlap_.get(), group_boxes_.get(), num_groups, num_samples, dims, overlap_.get(),
            Local{6 * kReduceGroupSize * sizeof(cl_float)});
    check(clEnqueueNDRangeKernel(queue_.get(), reduce_overlap_.get(), 1, nullptr, &kReduceGroupSize,
                                 &kReduceGroupSize, 0, nullptr, event(events[1])),
          "reduce_overlap");

    setArgs(histogram_touched_.get(), touched_.get(), counters_.get(), moments_.get(), bins_.get(),
            feature, occupied_bins, max_value, spare_cell, joint_.get(),
            Local{side2 * sizeof(cl_uint)});
    check(clEnqueueNDRangeKernel(queue_.get(), histogram_touched_.get(), 1, nullptr, &sample_range,
                                 &kGroupSize, 0, nullptr, event(events[2])),
          "histogram_touched");

    const std::size_t occupied_range = std::max(kGroupSize, roundUp(num_occupied, kGroupSize));
    setArgs(histogram_target_only_.get(), occupied_.get(), num_occupied, moments_.get(),
            overlap_.get(), occupied_bins, joint_.get(),
            Local{static_cast<std::size_t>(num_bins) * sizeof(cl_uint)});
    check(clEnqueueNDRangeKernel(queue_.get(), histogram_target_only_.get(), 1, nullptr, &occupied_range,
                                 &kGroupSize, 0, nullptr, event(events[3])),
          "histogram_target_only");

    // One read brings back the histogram; the overlap box follows on the same queue.
    cl_int overlap[8] = {0};
    check(clEnqueueReadBuffer(queue_.get(), joint_.get(), CL_FALSE, 0, side2 * sizeof(cl_uint),
                              histogram.counts.data(), 0, nullptr, event(events[4])),
          "reading the histogram");
    check(clEnqueueReadBuffer(queue_.get(), overlap_.get(), CL_TRUE, 0, 7 * sizeof(cl_int), overlap, 0,
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
    setArgs(clear_touched_.get(), touched_.get(), counters_.get(), moments_.get());
    check(clEnqueueNDRangeKernel(queue_.get(), clear_touched_.get(), 1, nullptr, &sample_range, &kGroupSize,
                                 0, nullptr, event(pending_[0])),
          "clear_touched");
    const cl_uint joint_size = static_cast<cl_uint>(side2);
    const cl_uint num_counters = kNumCounters;
    setArgs(reset_histogram_.get(), joint_.get(), joint_size, counters_.get(), num_counters);
    check(clEnqueueNDRangeKernel(queue_.get(), reset_histogram_.get(), 1, nullptr, &kGroupSize, &kGroupSize,
                                 0, nullptr, event(pending_[1])),
          "reset_histogram");
    check(clFlush(queue_.get()), "clFlush");

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
  event(ClEvent& slot) const
  {
    return profiling_ ? slot.out() : nullptr;
  }

  /** Adds a finished command's device time to \a stage and releases its event (none
   * without profiling). */
  void
  accountDevice(const char* stage, ClEvent& finished)
  {
    if (!finished)
      return;
    cl_ulong begin = 0, end = 0;
    if (clGetEventProfilingInfo(finished.get(), CL_PROFILING_COMMAND_START, sizeof(begin),
                                &begin, nullptr) == CL_SUCCESS &&
        clGetEventProfilingInfo(finished.get(), CL_PROFILING_COMMAND_END, sizeof(end), &end,
                                nullptr) == CL_SUCCESS)
      addDevice(stage, static_cast<double>(end - begin) * 1e-6);
    finished.reset();
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
  ClQueue queue_;
  ClKernel map_samples_, reduce_overlap_, histogram_touched_, histogram_target_only_,
      clear_touched_, reset_histogram_;
  /** The clearing queued after the last evaluation's read-back, for the profile. */
  ClEvent pending_[2];
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
