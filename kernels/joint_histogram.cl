/*
 * pcl_mi: one cost evaluation as OpenCL kernels, the paper's GPU pipeline:
 *   map_samples      transform the source samples and map them to voxels (map), with
 *                    per-work-group bounding boxes
 *   reduce_overlap   the bounding box of the moved source, intersected with the target's
 *                    grid (reduce)
 *   histogram_*      per-voxel features and the joint histogram (map into local-memory
 *                    integer histograms, merged with atomics)
 *   clear_touched    reset the voxels this evaluation touched
 * Every kernel scores a batch of poses at once: the second global dimension is the pose, and
 * each pose has its own moments, touched list, counters, boxes, overlap and histogram at a
 * fixed stride, so the poses of a batch never share a word and each one's histogram is the
 * one a batch of one gives.
 * The per-voxel arithmetic is kernels/voxel_math.h's, which the build prepends to this
 * file and the CPU backend includes, so the histograms are bit-for-bit the CPU backend's.
 * OpenCL C 1.2; the feature values use double (cl_khr_fp64), as the CPU does.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL FP_CONTRACT OFF

/* Integer moments of one voxel: count, sum of quantised heights, and the 64-bit sum of
 * their squares split into two words (OpenCL 1.2 has no 64-bit atomics). */
typedef struct {
  uint count;
  uint sum_q;
  uint sum_q2_lo;
  uint sum_q2_hi;
} Moments;

static void add_u64(volatile __global uint* lo, volatile __global uint* hi, ulong value)
{
  const uint low = (uint)value;
  const uint old = atomic_add(lo, low);
  uint carry = (uint)(value >> 32);
  if (old + low < old)
    carry += 1u;
  if (carry)
    atomic_add(hi, carry);
}

/* Work-group reduction of per-item boxes (6 floats each: min xyz, max xyz) into box[0..5];
 * min and max are exact in any order. */
static void reduce_boxes(__local float* box, const uint lid)
{
  barrier(CLK_LOCAL_MEM_FENCE);
  for (uint stride = get_local_size(0) / 2; stride > 0; stride /= 2) {
    if (lid < stride)
      for (int a = 0; a < 3; ++a) {
        box[6 * lid + a] = fmin(box[6 * lid + a], box[6 * (lid + stride) + a]);
        box[6 * lid + 3 + a] = fmax(box[6 * lid + 3 + a], box[6 * (lid + stride) + 3 + a]);
      }
    barrier(CLK_LOCAL_MEM_FENCE);
  }
}

static void store_box(__local float* box, const uint lid, const float3 mn, const float3 mx)
{
  box[6 * lid + 0] = mn.x;
  box[6 * lid + 1] = mn.y;
  box[6 * lid + 2] = mn.z;
  box[6 * lid + 3] = mx.x;
  box[6 * lid + 4] = mx.y;
  box[6 * lid + 5] = mx.z;
}

/* Per-pose strides, in elements: moments (cells + 1), touched (samples), counters. */
#define PCL_MI_NUM_COUNTERS 4u

__kernel void map_samples(__global const pcl_mi_sample* samples,
                          const uint num_samples,
                          __global const pcl_mi_grid_pose* poses,
                          const int4 dims,
                          const uint has_covariance,
                          __global Moments* moments,
                          const uint moments_stride,
                          __global uint* touched,
                          __global uint* counters,   /* [0]: touched cells */
                          __global float* group_boxes, /* 6 per work-group */
                          __local float* box)          /* 6 per work-item */
{
  const uint i = get_global_id(0);
  const uint lid = get_local_id(0);
  const size_t b = get_global_id(1);
  const pcl_mi_grid_pose pose = poses[b];
  moments += b * moments_stride;
  touched += b * num_samples;
  counters += b * PCL_MI_NUM_COUNTERS;
  group_boxes += b * 6 * get_num_groups(0);
  float3 mn = (float3)(FLT_MAX, FLT_MAX, FLT_MAX);
  float3 mx = -mn;
  if (i < num_samples) {
    const pcl_mi_sample s = samples[i];
    float3 f;
    f.x = pcl_mi_moved(pose.r[0], pose.r[1], pose.r[2], pose.t[0], s.px, s.py, s.pz);
    f.y = pcl_mi_moved(pose.r[3], pose.r[4], pose.r[5], pose.t[1], s.px, s.py, s.pz);
    f.z = pcl_mi_moved(pose.r[6], pose.r[7], pose.r[8], pose.t[2], s.px, s.py, s.pz);
    mn = f;
    mx = f;
    const float3 end = (float3)((float)dims.x, (float)dims.y, (float)dims.z);
    const int inside = f.x >= 0.0f && f.y >= 0.0f && f.z >= 0.0f && f.x < end.x &&
                       f.y < end.y && f.z < end.z;
    if (inside) {
      const int ix = (int)f.x, iy = (int)f.y, iz = (int)f.z;
      const uint cell = ((uint)iz * (uint)dims.y + (uint)iy) * (uint)dims.x + (uint)ix;
      const int q = pcl_mi_quantise_height(f.z, iz);
      uint n = 1u;
      ulong q2 = (ulong)q * (ulong)q;
      if (has_covariance) {
        const uint variance_q = pcl_mi_variance_levels(pose.rz[0], pose.rz[1], pose.rz[2], s.c,
                                                       pose.variance_scale);
        n = s.count;
        q2 = (ulong)n * (q2 + (ulong)variance_q);
      }
      volatile __global Moments* m = moments + cell;
      if (atomic_add(&m->count, n) == 0u)
        touched[atomic_inc(&counters[0])] = cell;
      atomic_add(&m->sum_q, n * (uint)q);
      add_u64(&m->sum_q2_lo, &m->sum_q2_hi, q2);
    }
  }
  /* Work-group bounding box. */
  store_box(box, lid, mn, mx);
  reduce_boxes(box, lid);
  if (lid == 0)
    for (int a = 0; a < 6; ++a)
      group_boxes[6 * get_group_id(0) + a] = box[a];
}

/* One work-group: the source's bounding box from the groups' boxes, then the overlap in
 * whole voxels, [lo, hi] inclusive; overlap[6] = 1 when it is not empty. */
__kernel void reduce_overlap(__global const float* group_boxes,
                             const uint num_groups,
                             const uint num_samples,
                             const int4 dims,
                             __global int* overlap,
                             __local float* box)
{
  const uint lid = get_local_id(0);
  const size_t b = get_global_id(1);
  group_boxes += b * 6 * num_groups;
  overlap += b * 8;
  float3 mn = (float3)(FLT_MAX, FLT_MAX, FLT_MAX);
  float3 mx = -mn;
  for (uint g = lid; g < num_groups; g += get_local_size(0)) {
    mn = fmin(mn, (float3)(group_boxes[6 * g], group_boxes[6 * g + 1], group_boxes[6 * g + 2]));
    mx = fmax(mx, (float3)(group_boxes[6 * g + 3], group_boxes[6 * g + 4], group_boxes[6 * g + 5]));
  }
  store_box(box, lid, mn, mx);
  reduce_boxes(box, lid);
  if (lid != 0)
    return;
  const int d[3] = {dims.x, dims.y, dims.z};
  int ok = num_samples > 0;
  for (int a = 0; a < 3; ++a) {
    /* Clamp both ends to [-1, d] before converting: a far-off pose must not overflow the
     * integer cast, whichever side of the grid it lies on. */
    const int lo = max(0, (int)floor(clamp(box[a], -1.0f, (float)d[a])));
    const int hi = min(d[a] - 1, (int)floor(clamp(box[3 + a], -1.0f, (float)d[a])));
    overlap[a] = lo;
    overlap[3 + a] = hi;
    ok = ok && lo <= hi;
  }
  overlap[6] = ok;
}

static int voxel_bin(const uint feature, const uint num_bins, const double max_value,
                     const Moments m)
{
  if (m.count == 0u)
    return 0;
  double value;
  if (feature == 1u) { /* PointCount */
    value = (double)m.count;
  }
  else { /* VarianceZ */
    const double s2 = (double)(((ulong)m.sum_q2_hi << 32) | (ulong)m.sum_q2_lo);
    value = pcl_mi_variance_z_value((double)m.count, (double)m.sum_q, s2);
  }
  return pcl_mi_bin_of_value((int)num_bins, max_value, value);
}

/* Source-occupied voxels: (target bin, source bin). */
__kernel void histogram_touched(__global const uint* touched,
                                const uint touched_stride,
                                __global const uint* counters,
                                __global const Moments* moments,
                                const uint moments_stride,
                                __global const uchar* target_bins,
                                const uint feature,
                                const uint num_bins,   /* occupied bins B */
                                const double max_value,
                                const uint spare_cell,
                                __global uint* joint,  /* (B + 1)^2 */
                                __local uint* local_joint)
{
  const uint side = num_bins + 1;
  const size_t b = get_global_id(1);
  touched += b * touched_stride;
  counters += b * PCL_MI_NUM_COUNTERS;
  moments += b * moments_stride;
  joint += b * side * side;
  for (uint k = get_local_id(0); k < side * side; k += get_local_size(0))
    local_joint[k] = 0;
  barrier(CLK_LOCAL_MEM_FENCE);
  const uint i = get_global_id(0);
  if (i < counters[0]) {
    const uint cell = touched[i];
    if (cell != spare_cell) {
      const int source_bin = voxel_bin(feature, num_bins, max_value, moments[cell]);
      atomic_inc(&local_joint[target_bins[cell] * side + source_bin]);
    }
  }
  barrier(CLK_LOCAL_MEM_FENCE);
  for (uint k = get_local_id(0); k < side * side; k += get_local_size(0))
    if (local_joint[k])
      atomic_add(&joint[k], local_joint[k]);
}

/* Target-occupied voxels in the overlap that the source left empty: (target bin, 0). */
__kernel void histogram_target_only(__global const pcl_mi_occupied_voxel* occupied,
                                    const uint num_occupied,
                                    __global const Moments* moments,
                                    const uint moments_stride,
                                    __global const int* overlap,
                                    const uint num_bins,
                                    __global uint* joint,
                                    __local uint* local_joint)
{
  const uint side = num_bins + 1;
  const size_t b = get_global_id(1);
  moments += b * moments_stride;
  overlap += b * 8;
  joint += b * side * side;
  for (uint k = get_local_id(0); k < side; k += get_local_size(0))
    local_joint[k] = 0;
  barrier(CLK_LOCAL_MEM_FENCE);
  const uint i = get_global_id(0);
  if (i < num_occupied && overlap[6]) {
    const pcl_mi_occupied_voxel v = occupied[i];
    if (v.ix >= overlap[0] && v.iy >= overlap[1] && v.iz >= overlap[2] && v.ix <= overlap[3] &&
        v.iy <= overlap[4] && v.iz <= overlap[5] && moments[v.cell].count == 0u)
      atomic_inc(&local_joint[v.bin]);
  }
  barrier(CLK_LOCAL_MEM_FENCE);
  for (uint k = get_local_id(0); k < side; k += get_local_size(0))
    if (local_joint[k])
      atomic_add(&joint[k * side], local_joint[k]);
}

/* Zero the voxels this evaluation touched, ready for the next one. */
__kernel void clear_touched(__global const uint* touched,
                            const uint touched_stride,
                            __global const uint* counters,
                            __global Moments* moments,
                            const uint moments_stride)
{
  const uint i = get_global_id(0);
  const size_t b = get_global_id(1);
  touched += b * touched_stride;
  counters += b * PCL_MI_NUM_COUNTERS;
  moments += b * moments_stride;
  if (i < counters[0]) {
    const Moments zero = {0u, 0u, 0u, 0u};
    moments[touched[i]] = zero;
  }
}

/* Zeroes the joint histogram and the counters for the next evaluation (num_counters is
 * PCL_MI_NUM_COUNTERS). A kernel of its own
 * (one work-group), queued after clear_touched, which still reads counters[0]. */
__kernel void reset_histogram(__global uint* joint,
                              const uint joint_size,
                              __global uint* counters,
                              const uint num_counters)
{
  const size_t b = get_global_id(1);
  joint += b * joint_size;
  counters += b * num_counters;
  for (uint k = get_local_id(0); k < joint_size; k += get_local_size(0))
    joint[k] = 0u;
  for (uint k = get_local_id(0); k < num_counters; k += get_local_size(0))
    counters[k] = 0u;
}
