/*
 * pcl_mi: the per-voxel arithmetic of a cost evaluation, written once for both backends:
 * the CPU backend includes it as C++, and the build prepends it to the OpenCL kernels
 * (cmake/EmbedKernels.cmake). Both therefore compute every bin with the same operations in
 * the same order (with contraction into fused multiply-adds off on both sides), which makes
 * their joint histograms equal bit for bit. Common subset of C++17 and OpenCL C 1.2: no
 * references, templates or overloads; fixed-width types through the aliases below.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#ifndef PCL_MI_VOXEL_MATH_H
#define PCL_MI_VOXEL_MATH_H

#ifdef __OPENCL_VERSION__
/* Doubles for the feature values, and no fused multiply-adds: the CPU backend is built with
 * -ffp-contract=off for the same reason. */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL FP_CONTRACT OFF
#define PCL_MI_VOXEL_BEGIN
#define PCL_MI_VOXEL_END
#define PCL_MI_FN static inline
typedef uint pcl_mi_u32;
#else
#include <cstdint>
#define PCL_MI_VOXEL_BEGIN                                                                  \
  namespace pcl_mi {                                                                       \
  namespace voxel {
#define PCL_MI_VOXEL_END                                                                    \
  }                                                                                        \
  }
#define PCL_MI_FN inline
#endif

PCL_MI_VOXEL_BEGIN

#ifndef __OPENCL_VERSION__
typedef std::uint32_t pcl_mi_u32;
#endif

/* Levels a point's height inside its voxel is quantised to. Integer moments make the voxel
 * features independent of summation order (threads, work-items). */
#define PCL_MI_HEIGHT_LEVELS 256

/* One source sample as the devices store it: position, point count and the 6 covariance
 * terms (xx xy xz yy yz zz); 48 bytes. */
typedef struct {
  float px, py, pz;
  pcl_mi_u32 count;
  float c[6];
  float pad[2];
} pcl_mi_sample;

/* An occupied target voxel: cell index, coordinates and histogram bin; 20 bytes. */
typedef struct {
  pcl_mi_u32 cell;
  int ix, iy, iz;
  pcl_mi_u32 bin;
} pcl_mi_occupied_voxel;

/* A pose in grid units, f = R p + t; 64 bytes. */
typedef struct {
  float r[9];           /* row-major, already divided by the resolution */
  float t[3];           /* (translation - grid origin) / resolution */
  float rz[3];          /* third row of the unscaled rotation */
  float variance_scale; /* from a z variance in m^2 to quantisation levels squared */
} pcl_mi_grid_pose;

/* One coordinate of a moved sample: ((r0 x + r1 y) + r2 z) + t. */
PCL_MI_FN float
pcl_mi_moved(float r0, float r1, float r2, float t, float x, float y, float z)
{
  return ((r0 * x + r1 * y) + r2 * z) + t;
}

/* Quantised height of a point inside its voxel: z_cells is its z in voxel units from the
 * grid origin, iz its voxel index (floor(z_cells)). */
PCL_MI_FN int
pcl_mi_quantise_height(float z_cells, int iz)
{
  const int q = (int)((z_cells - (float)iz) * PCL_MI_HEIGHT_LEVELS);
  return q < 0 ? 0 : (q > PCL_MI_HEIGHT_LEVELS - 1 ? PCL_MI_HEIGHT_LEVELS - 1 : q);
}

/* z variance of a sample with covariance c (xx xy xz yy yz zz) after a rotation whose z
 * row is (rx, ry, rz), in quantisation levels squared (scale: see pcl_mi_grid_pose). */
PCL_MI_FN pcl_mi_u32
pcl_mi_variance_levels(float rx, float ry, float rz, const float* c, float variance_scale)
{
  const float variance_z = rx * (rx * c[0] + 2.0f * (ry * c[1] + rz * c[2])) +
                           ry * (ry * c[3] + 2.0f * rz * c[4]) + rz * rz * c[5];
  return (pcl_mi_u32)((variance_z > 0.0f ? variance_z : 0.0f) * variance_scale + 0.5f);
}

/* VarianceZ feature of a voxel with n points whose quantised heights sum to s1 and whose
 * squares sum to s2: var(z) / R_v^2 = (n s2 - s1^2) / (n^2 L^2). */
PCL_MI_FN double
pcl_mi_variance_z_value(double n, double s1, double s2)
{
  const double numerator = n * s2 - s1 * s1;
  return (numerator > 0.0 ? numerator : 0.0) /
         (n * n * (double)PCL_MI_HEIGHT_LEVELS * PCL_MI_HEIGHT_LEVELS);
}

/* Histogram bin of an occupied voxel's feature value: 1 + min(B - 1, floor(B v / max)). */
PCL_MI_FN int
pcl_mi_bin_of_value(int num_bins, double max_value, double value)
{
  const double scaled = num_bins * value / max_value;
  if (!(scaled > 0.0))
    return 1;
  if (scaled >= num_bins)
    return num_bins;
  return 1 + (int)scaled;
}

PCL_MI_VOXEL_END

#endif /* PCL_MI_VOXEL_MATH_H */
