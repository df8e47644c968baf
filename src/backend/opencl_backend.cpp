/*
 * pcl_mi: the OpenCL backend. Runs kernels/joint_histogram.cl; the target's grid, the
 * source samples and the voxel moments live on the device, allocated once per target and
 * source and reused by every evaluation. A batch of poses is scored in one round trip:
 * the poses go up, every kernel runs over all of them, and their joint histograms (and
 * overlap sizes) come back in one read; each pose has its own device scratch.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "backend/opencl_backend.h"
#include "backend/opencl_handles.h"

#include "features/feature_binning.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <iterator>
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
  OpenClBackend(std::shared_ptr<OpenClDevice> device, bool profile_device, bool batch)
      : device_(std::move(device)), profiling_(profile_device), batch_(batch)
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
    auto start = Clock::now();
    bins_.allocate(device_->context.get(), target_->bins.size());
    std::vector<DeviceOccupiedVoxel> occupied;
    occupied.reserve(target_->occupied.size());
    for (const auto& v : target_->occupied)
      occupied.push_back({v.cell, v.ix, v.iy, v.iz, v.bin});
    occupied_.allocate(device_->context.get(), occupied.size() * sizeof(DeviceOccupiedVoxel));
    addHost("memory allocation", millisecondsSince(start));
    scratch_poses_ = 0; // sized for the new grid on the next evaluation

    start = Clock::now();
    check(clEnqueueWriteBuffer(queue_.get(), bins_.get(), CL_FALSE, 0, target_->bins.size(),
                               target_->bins.data(), 0, nullptr, nullptr),
          "uploading the target bins");
    if (!occupied.empty())
      check(clEnqueueWriteBuffer(queue_.get(), occupied_.get(), CL_FALSE, 0, occupied_.bytes(),
                                 occupied.data(), 0, nullptr, nullptr),
            "uploading the occupied voxels");
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
    groups_ = std::max<std::size_t>(1, roundUp(n, kGroupSize) / kGroupSize);
    addHost("memory allocation", millisecondsSince(start));
    scratch_poses_ = 0; // sized for the new source on the next evaluation
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
    one_.resize(1);
    jointHistograms({rotation}, {translation}, one_);
    histogram = std::move(one_[0]);
  }

  bool
  prefersBatches() const override
  {
    return batch_;
  }

  void
  jointHistograms(const std::vector<Eigen::Matrix3f>& rotations,
                  const std::vector<Eigen::Vector3f>& translations,
                  std::vector<JointHistogram>& histograms) override
  {
    const std::size_t batch = rotations.size();
    const std::size_t most = mostPosesPerLaunch();
    if (batch > most) {
      histograms.clear();
      std::vector<JointHistogram> part;
      for (std::size_t first = 0; first < batch; first += most) {
        const auto from = static_cast<std::ptrdiff_t>(first);
        const auto to = static_cast<std::ptrdiff_t>(std::min(batch, first + most));
        jointHistograms({rotations.begin() + from, rotations.begin() + to},
                        {translations.begin() + from, translations.begin() + to}, part);
        std::move(part.begin(), part.end(), std::back_inserter(histograms));
      }
      return;
    }
    const core::GridGeometry& g = target_->geometry;
    const int num_bins = target_->binning.num_bins + 1;
    const std::size_t side2 = static_cast<std::size_t>(num_bins) * num_bins;
    histograms.resize(batch);
    for (JointHistogram& h : histograms) {
      h.num_bins = num_bins;
      h.counts.assign(side2, 0);
      h.overlap_voxels = 0;
    }
    const std::size_t n = source_->samples.size();
    if (n == 0 || batch == 0)
      return;
    const auto round_trip = Clock::now();
    reserveScratch(batch);

    // The same float operations as the CPU backend, in the same order.
    std::vector<DevicePose> poses(batch);
    for (std::size_t b = 0; b < batch; ++b) {
      const core::GridPose grid_pose = core::gridPose(g, rotations[b], translations[b]);
      DevicePose& pose = poses[b];
      for (int row = 0; row < 3; ++row)
        for (int col = 0; col < 3; ++col)
          pose.r[3 * row + col] = grid_pose.rotation(row, col);
      for (int a = 0; a < 3; ++a) {
        pose.t[a] = grid_pose.translation[a];
        pose.rz[a] = grid_pose.rotation_z[a];
      }
      pose.variance_scale = grid_pose.variance_scale;
    }
    const cl_int4 dims = {{g.dims.x(), g.dims.y(), g.dims.z(), 0}};
    const cl_uint num_samples = static_cast<cl_uint>(n);
    const cl_uint has_covariance = source_->has_covariance ? 1u : 0u;
    const cl_uint feature = target_->feature == Feature::PointCount ? 1u : 0u;
    const cl_uint occupied_bins = static_cast<cl_uint>(target_->binning.num_bins);
    const cl_double max_value = target_->binning.max_value;
    const cl_uint spare_cell = static_cast<cl_uint>(g.cellCount());
    const cl_uint moments_stride = spare_cell + 1;
    const cl_uint num_occupied = static_cast<cl_uint>(target_->occupied.size());
    const cl_uint num_groups = static_cast<cl_uint>(groups_);

    // The histograms, the counters and the touched voxels' moments are zero here: the
    // previous batch cleared them after its results were read (or reserveScratch() did), so
    // the clearing runs while the host computes the entropies, not on the critical path.
    ClEvent events[7];
    check(clEnqueueWriteBuffer(queue_.get(), poses_.get(), CL_FALSE, 0, batch * sizeof(DevicePose),
                               poses.data(), 0, nullptr, event(events[0])),
          "uploading the poses");
    const std::size_t sample_range[2] = {groups_ * kGroupSize, batch};
    const std::size_t group[2] = {kGroupSize, 1};
    setArgs(map_samples_.get(), samples_.get(), num_samples, poses_.get(), dims, has_covariance,
            moments_.get(), moments_stride, touched_.get(), counters_.get(), group_boxes_.get(),
            Local{6 * kGroupSize * sizeof(cl_float)});
    enqueue(map_samples_, sample_range, group, events[1], "map_samples");

    const std::size_t reduce_range[2] = {kReduceGroupSize, batch};
    const std::size_t reduce_group[2] = {kReduceGroupSize, 1};
    setArgs(reduce_overlap_.get(), group_boxes_.get(), num_groups, num_samples, dims, overlap_.get(),
            Local{6 * kReduceGroupSize * sizeof(cl_float)});
    enqueue(reduce_overlap_, reduce_range, reduce_group, events[2], "reduce_overlap");

    setArgs(histogram_touched_.get(), touched_.get(), num_samples, counters_.get(), moments_.get(),
            moments_stride, bins_.get(), feature, occupied_bins, max_value, spare_cell,
            joint_.get(), Local{side2 * sizeof(cl_uint)});
    enqueue(histogram_touched_, sample_range, group, events[3], "histogram_touched");

    const std::size_t occupied_range[2] = {std::max(kGroupSize, roundUp(num_occupied, kGroupSize)),
                                           batch};
    setArgs(histogram_target_only_.get(), occupied_.get(), num_occupied, moments_.get(),
            moments_stride, overlap_.get(), occupied_bins, joint_.get(),
            Local{static_cast<std::size_t>(num_bins) * sizeof(cl_uint)});
    enqueue(histogram_target_only_, occupied_range, group, events[4], "histogram_target_only");

    // One read brings back every histogram; the overlap boxes follow on the same queue.
    std::vector<cl_uint> joint(batch * side2);
    std::vector<cl_int> overlap(batch * 8);
    check(clEnqueueReadBuffer(queue_.get(), joint_.get(), CL_FALSE, 0, joint.size() * sizeof(cl_uint),
                              joint.data(), 0, nullptr, event(events[5])),
          "reading the histograms");
    check(clEnqueueReadBuffer(queue_.get(), overlap_.get(), CL_TRUE, 0, overlap.size() * sizeof(cl_int),
                              overlap.data(), 0, nullptr, event(events[6])),
          "reading the overlaps");

    static const char* const kStage[7] = {"copy to device",    "voxel mapping",
                                          "find overlap",      "feature histogram",
                                          "feature histogram", "copy to host",
                                          "copy to host"};
    for (int e = 0; e < 7; ++e)
      accountDevice(kStage[e], events[e]);
    // The previous batch's clearing finished before this one started (in-order queue).
    accountPending();

    // Clear for the next batch, off the critical path: flushed now, waited for by the next
    // batch's first command.
    setArgs(clear_touched_.get(), touched_.get(), num_samples, counters_.get(), moments_.get(),
            moments_stride);
    enqueue(clear_touched_, sample_range, group, pending_[0], "clear_touched");
    const cl_uint joint_size = static_cast<cl_uint>(side2);
    const cl_uint num_counters = kNumCounters;
    setArgs(reset_histogram_.get(), joint_.get(), joint_size, counters_.get(), num_counters);
    const std::size_t reset_range[2] = {kGroupSize, batch};
    enqueue(reset_histogram_, reset_range, group, pending_[1], "reset_histogram");
    check(clFlush(queue_.get()), "clFlush");

    for (std::size_t b = 0; b < batch; ++b) {
      const cl_int* box = overlap.data() + 8 * b;
      if (!box[6])
        continue;
      JointHistogram& h = histograms[b];
      std::copy(joint.begin() + static_cast<std::ptrdiff_t>(b * side2),
                joint.begin() + static_cast<std::ptrdiff_t>((b + 1) * side2), h.counts.begin());
      h.overlap_voxels = static_cast<std::uint64_t>(box[3] - box[0] + 1) *
                         (box[4] - box[1] + 1) * (box[5] - box[2] + 1);
      std::uint64_t counted = 0;
      for (const std::uint32_t c : h.counts)
        counted += c;
      h.counts[0] += static_cast<std::uint32_t>(h.overlap_voxels - counted);
    }
    addHost("round trips", millisecondsSince(round_trip));
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

  // kernels/joint_histogram.cl's PCL_MI_NUM_COUNTERS.
  static constexpr cl_uint kNumCounters = 4;

  void
  enqueue(const ClKernel& kernel, const std::size_t* global, const std::size_t* local,
          ClEvent& done, const char* what)
  {
    check(clEnqueueNDRangeKernel(queue_.get(), kernel.get(), 2, nullptr, global, local, 0, nullptr,
                                 event(done)),
          what);
  }

  /** Poses scored in one launch: as many as keep the per-pose voxel moments within
   * kScratchBytes, so that a large batch of a fine grid does not exhaust the device. */
  std::size_t
  mostPosesPerLaunch() const
  {
    const std::size_t per_pose = (target_->geometry.cellCount() + 1) * 4 * sizeof(cl_uint);
    return std::max<std::size_t>(1, kScratchBytes / per_pose);
  }

  static constexpr std::size_t kScratchBytes = std::size_t(256) << 20;

  /** Device scratch for \a batch poses of the current target and source, zeroed when it is
   * (re)allocated; kept, and grown only, across batches. */
  void
  reserveScratch(std::size_t batch)
  {
    if (batch <= scratch_poses_)
      return;
    const auto start = Clock::now();
    // The previous batch's clearing may still be queued on the buffers replaced here.
    check(clFinish(queue_.get()), "clFinish");
    accountPending();
    cl_context context = device_->context.get();
    const std::size_t cells = target_->geometry.cellCount() + 1; // a spare cell, as on the CPU
    const std::size_t side = static_cast<std::size_t>(target_->binning.num_bins) + 1;
    poses_.allocate(context, batch * sizeof(DevicePose));
    moments_.allocate(context, batch * cells * 4 * sizeof(cl_uint));
    touched_.allocate(context, batch * source_->samples.size() * sizeof(cl_uint));
    counters_.allocate(context, batch * kNumCounters * sizeof(cl_uint));
    group_boxes_.allocate(context, batch * groups_ * 6 * sizeof(cl_float));
    overlap_.allocate(context, batch * 8 * sizeof(cl_int));
    joint_.allocate(context, batch * side * side * sizeof(cl_uint));
    addHost("memory allocation", millisecondsSince(start));
    const cl_uint zero = 0;
    for (const Buffer* b : {&moments_, &counters_, &joint_})
      check(clEnqueueFillBuffer(queue_.get(), b->get(), &zero, sizeof(zero), 0, b->bytes(), 0,
                                nullptr, nullptr),
            "clearing the device scratch");
    scratch_poses_ = batch;
  }

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
  bool batch_ = false;
  ClQueue queue_;
  ClKernel map_samples_, reduce_overlap_, histogram_touched_, histogram_target_only_,
      clear_touched_, reset_histogram_;
  /** The clearing queued after the last evaluation's read-back, for the profile. */
  ClEvent pending_[2];
  std::shared_ptr<const core::TargetGrid> target_;
  std::shared_ptr<const core::SourceSamples> source_;
  Buffer bins_, occupied_, samples_;
  /** Per-pose scratch, for scratch_poses_ poses (0: to be sized by the next batch). */
  Buffer poses_, moments_, joint_, counters_, overlap_, touched_, group_boxes_;
  std::size_t scratch_poses_ = 0;
  std::size_t groups_ = 1;
  std::vector<JointHistogram> one_;
  std::vector<StageTiming> profile_;
};

} // namespace

std::unique_ptr<ScoringBackend>
makeOpenClBackend(std::shared_ptr<OpenClDevice> device, bool profile_device, bool batch)
{
  return std::make_unique<OpenClBackend>(std::move(device), profile_device, batch);
}

} // namespace backend
} // namespace pcl_mi
