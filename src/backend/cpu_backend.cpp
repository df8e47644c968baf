/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "backend/scoring_backend.h"

#include "backend/moved_samples.h"

#include "features/feature_binning.h"
#include "util/zeroed_array.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>

namespace pcl_mi {
namespace backend {

namespace {

/** Voxelises the transformed source straight into the target's grid, so the work per
 * evaluation is one pass over the samples (per block of them, the arithmetic four at a time,
 * then the moments) plus one over the occupied voxels in the overlap; the voxels empty in
 * both clouds are counted, not visited. */
class CpuBackend final : public ScoringBackend {
public:
  const char*
  name() const override
  {
    return "cpu";
  }

  void
  setTarget(std::shared_ptr<const core::TargetGrid> target) override
  {
    target_ = std::move(target);
    // One spare cell past the grid collects the samples outside it.
    moments_ = core::ZeroedArray<core::VoxelMoments>(target_->geometry.cellCount() + 1);
    moments_.returnsZeroed(); // clearTouched() ends every compute()
    touched_count_ = 0;
  }

  void
  setSource(std::shared_ptr<const core::SourceSamples> source) override
  {
    source_ = std::move(source);
    columns_ = std::make_unique<SampleColumns>(*source_);
  }

  void
  appendProfile(std::vector<StageTiming>& stages) const override
  {
    if (calls_ == 0)
      return;
    StageTiming& stage = stageNamed(stages, "cpu: joint histogram");
    stage.calls += calls_;
    stage.total_ms += total_ms_;
  }

  void
  resetProfile() override
  {
    calls_ = 0;
    total_ms_ = 0.0;
  }

  void
  jointHistogram(const Eigen::Matrix3f& rotation,
                 const Eigen::Vector3f& translation,
                 JointHistogram& histogram) override
  {
    const auto start = std::chrono::steady_clock::now();
    compute(rotation, translation, histogram);
    ++calls_;
    total_ms_ +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }

private:
  void
  compute(const Eigen::Matrix3f& rotation,
          const Eigen::Vector3f& translation,
          JointHistogram& histogram)
  {
    const core::GridGeometry& g = target_->geometry;
    const int num_bins = target_->binning.num_bins + 1;
    histogram.num_bins = num_bins;
    histogram.counts.assign(static_cast<std::size_t>(num_bins) * num_bins, 0);
    histogram.overlap_voxels = 0;

    // One pass maps the samples into grid coordinates, reduces their bounding box and
    // accumulates the integer moments of those inside the target grid. Every such sample
    // lies inside the source's box too, so they are exactly the samples in the overlap
    // (box intersection) computed below. The test runs on floats so far samples are never
    // cast to int.
    const core::GridPose pose = core::gridPose(g, rotation, translation);
    const Eigen::Vector3f grid_end = g.dims.cast<float>();
    const std::size_t spare_cell = g.cellCount();
    const bool has_covariance = source_->has_covariance;
    const std::vector<core::SourceSample>& samples = source_->samples;
    Eigen::Vector3f min = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
    Eigen::Vector3f max = -min;
    // Room for every sample to open a new cell, so the append below needs no branch; kept
    // between calls, since growing it would clear it first.
    if (touched_.size() < samples.size())
      touched_.resize(samples.size());
    std::size_t touched = 0;
    // Per block, the arithmetic first (vectorised), then the moments, which each depend on
    // the voxel the last sample touched.
    for (std::size_t begin = 0; begin < samples.size(); begin += kMovedBlock) {
      const std::size_t end = std::min(samples.size(), begin + kMovedBlock);
      moveSamples(pose, g.dims, *columns_, begin, end, block_, min, max);
      for (std::size_t i = begin; i < end; ++i) {
        const std::size_t k = i - begin;
        // Samples outside the grid go to a spare cell past its end instead of branching
        // away: whether a sample is inside is as good as random, and mispredicted branches
        // cost more than the arithmetic.
        const std::size_t cell =
            block_.inside[k] ? g.cellIndex(block_.ix[k], block_.iy[k], block_.iz[k]) : spare_cell;
        core::VoxelMoments& m = moments_[cell];
        touched_[touched] = static_cast<std::uint32_t>(cell);
        touched += m.count == 0;
        if (!has_covariance)
          m.add(block_.height[k]);
        else
          m.add(block_.height[k], samples[i].count, block_.variance[k]);
      }
    }

    touched_count_ = touched;

    // Overlap: intersection of the two bounding boxes, in whole voxels.
    Eigen::Vector3i lo, hi;
    bool overlap = !samples.empty();
    for (int a = 0; a < 3 && overlap; ++a) {
      // Clamp both ends to [-1, grid end] before converting: a far-off pose must not
      // overflow the integer cast, whichever side of the grid it lies on.
      const auto voxel = [&](float v) {
        return static_cast<int>(std::floor(std::min(std::max(v, -1.0f), grid_end[a])));
      };
      lo[a] = std::max(0, voxel(min[a]));
      hi[a] = std::min(g.dims[a] - 1, voxel(max[a]));
      overlap = lo[a] <= hi[a];
    }
    if (!overlap) {
      clearTouched();
      return;
    }
    histogram.overlap_voxels = static_cast<std::uint64_t>(hi.x() - lo.x() + 1) *
                               (hi.y() - lo.y() + 1) * (hi.z() - lo.z() + 1);

    // Histogram: every occupied target voxel in the overlap as target-only (bin, 0), then
    // the source-occupied voxels, each taking its target voxel (if any) back out of
    // target-only; what is left is empty in both. The target's voxels are read in their
    // order, without a look at the source's moments, which lie anywhere in a large grid.
    const auto index = [num_bins](int x, int y) {
      return static_cast<std::size_t>(x) * num_bins + y;
    };
    std::uint64_t counted = 0;
    // Only the rows of cells that cross the overlap: a map much larger than the scan holds
    // most of its voxels outside it.
    const std::vector<core::OccupiedVoxel>& occupied = target_->occupied;
    const std::vector<std::uint32_t>& row_starts = target_->row_starts;
    for (int iz = lo.z(); iz <= hi.z(); ++iz)
      for (int iy = lo.y(); iy <= hi.y(); ++iy) {
        const std::size_t row = static_cast<std::size_t>(iz) * g.dims.y() + iy;
        for (std::uint32_t k = row_starts[row]; k < row_starts[row + 1]; ++k) {
          const core::OccupiedVoxel& v = occupied[k];
          if (v.ix >= lo.x() && v.ix <= hi.x()) {
            ++histogram.counts[index(v.bin, 0)];
            ++counted;
          }
        }
      }
    for (std::size_t i = 0; i < touched_count_; ++i) {
      const std::uint32_t cell = touched_[i];
      if (cell == spare_cell)
        continue;
      const int target_bin = target_->bins[cell];
      const int source_bin = core::voxelBin(target_->feature, target_->binning, moments_[cell]);
      ++histogram.counts[index(target_bin, source_bin)];
      if (target_bin != 0)
        --histogram.counts[index(target_bin, 0)];
      else
        ++counted;
    }
    histogram.counts[0] += static_cast<std::uint32_t>(histogram.overlap_voxels - counted);

    clearTouched();
  }

  void
  clearTouched()
  {
    for (std::size_t i = 0; i < touched_count_; ++i)
      moments_[touched_[i]] = core::VoxelMoments{};
    touched_count_ = 0;
  }

  std::shared_ptr<const core::TargetGrid> target_;
  std::shared_ptr<const core::SourceSamples> source_;
  std::unique_ptr<SampleColumns> columns_;  // source_ in columns
  MovedBlock block_;                        // where the current block's samples land
  core::ZeroedArray<core::VoxelMoments> moments_; // per target cell, zero between calls
  /** Cells with source points this call: the first touched_count_ entries (the rest are
   * room left from earlier calls). */
  std::vector<std::uint32_t> touched_;
  std::size_t touched_count_ = 0;
  int calls_ = 0;
  double total_ms_ = 0.0;
};

} // namespace

std::unique_ptr<ScoringBackend>
makeCpuBackend()
{
  return std::make_unique<CpuBackend>();
}

} // namespace backend
} // namespace pcl_mi
