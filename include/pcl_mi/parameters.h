/*
 * pcl_mi: 3D scan alignment by maximising the mutual information of voxel features.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>

#include <ostream>
#include <string>
#include <vector>

namespace pcl_mi {

/** \brief Per-voxel feature whose distribution the mutual information is computed over. */
enum class Feature {
  VarianceZ,  ///< variance of the points' z in the voxel (the paper's MI-VARZ)
  PointCount  ///< number of points in the voxel (the paper's MI-N)
};

/** \brief Human-readable name of a feature ("VarianceZ", "PointCount"). */
const char*
featureName(Feature feature);

/** \brief Prints the feature's name (for logs and test output). */
inline std::ostream&
operator<<(std::ostream& os, Feature feature)
{
  return os << featureName(feature);
}

/** \brief Where the cost evaluations (joint histograms) run. */
enum class Backend {
  Cpu,    ///< plain C++ on the calling thread(s)
  OpenCL, ///< OpenCL kernels on a GPU or, through PoCL, on the CPU; an error if unavailable
  /** OpenCL where it is faster: on a GPU or accelerator when every source point enters
   * each evaluation (source_subdivision 0, e.g. Parameters::paper()); otherwise the CPU.
   * With no usable OpenCL device the CPU, with a warning. */
  Auto
};

/** \brief Parses a backend name as command lines spell it: "cpu", "opencl" or "auto".
 * \return false (leaving \a backend unchanged) for any other name. */
bool
parseBackend(const std::string& name, Backend& backend);

/** \brief Local refinement applied to the optimum of the MI search. */
enum class Refinement {
  None,                ///< the MI optimum as found (the paper's method)
  PointToDistribution  ///< Gauss-Newton on the target's voxel distributions (see Parameters)
};

/** \brief How the value of an occupied voxel maps to a histogram bin.
 *
 * Bin 0 is reserved for unoccupied voxels (the paper's "no feature" value). An occupied
 * voxel with feature value v falls into
 *
 *     bin = 1 + min(num_bins - 1, floor(num_bins * v / max_value))
 *
 * so bins 1..num_bins split [0, max_value) into equal intervals and values >= max_value
 * land in the last bin. The histograms therefore have num_bins + 1 bins.
 *
 * Feature values: VarianceZ uses var(z) / resolution^2 (dimensionless, in [0, 0.25];
 * a voxel filled uniformly top to bottom, such as a wall, gives 1/12), so the binning
 * does not have to change with the resolution. PointCount uses the plain point count.
 */
struct FeatureBinning {
  int num_bins = 0;       ///< number of bins for occupied voxels (>= 1)
  double max_value = 0.0; ///< upper end of the binned range (> 0)
  /** When > 0, each target grid takes max_value from its own occupied voxels instead: the
   * range_quantile quantile of their feature values (max_value stays the fallback when
   * that quantile is 0). Source voxels are binned with the same range, so X and Y stay
   * comparable. 0 = the fixed max_value. In [0, 1]. */
  double range_quantile = 0.0;
};

/** \brief All tuning parameters of the mutual-information registration, with their defaults.
 *
 * The cost is the paper's (Mehta, McBride, Pandey, "Robust and Fast 3D Scan Alignment using
 * Mutual Information"): 1 m voxels, variance of z, the anisotropic initial simplex
 * [8 m, 8 m, 1 m, 0.1, 0.1, 0.8 rad]. The defaults search it from a mirrored pair of starts
 * on a coarse-to-fine pyramid (4 m, 2 m) with a sampled source, and refine the optimum
 * against the target's local distributions (symmetric_start, pyramid_levels,
 * source_subdivision, refinement); Parameters::paper() turns all of that off.
 */
struct Parameters {
  /** Voxel edge length R_v in the clouds' units (metres for KITTI). The refinement's cube
   * edge and the translation tolerance follow it unless set (see their fields); the
   * simplex steps do not: they say how far off the guess may be. */
  double resolution = 1.0;
  /** Feature used for the histograms. */
  Feature feature = Feature::VarianceZ;
  /** Binning of VarianceZ values (var(z) / resolution^2). */
  FeatureBinning variance_z_binning{16, 1.0 / 12.0};
  /** Binning of PointCount values (points per voxel). The range follows the target's
   * density: up to the upper quartile of its occupied voxels' counts on each pyramid level
   * (a 16-beam scanner fills voxels far less densely than a 64-beam one; with the paper's
   * fixed 64 points most of its voxels share the lowest bins). */
  FeatureBinning point_count_binning{16, 64.0, 0.75};
  /** Initial simplex step per parameter [tx, ty, tz, roll, pitch, yaw (rad)], translations
   * in the clouds' units: the paper's metres. They describe how far the guess may be off,
   * not the scene, so they do not follow the resolution: give clouds in other units (e.g.
   * millimetres) steps in those units. */
  Eigen::Matrix<double, 6, 1> simplex_steps =
      (Eigen::Matrix<double, 6, 1>() << 8.0, 8.0, 1.0, 0.1, 0.1, 0.8).finished();
  /** Also start a second simplex with all steps negated and keep the better result. The
   * paper's simplex explores mainly along its positive steps and misses large motion in
   * the opposite direction (e.g. aligning an earlier scan onto a later one). */
  bool symmetric_start = true;
  /** Headings the coarsest level starts from, spread evenly over 360 degrees of yaw from
   * the guess's (1 = the guess's only). The paper's simplex, mirrored, reaches about +-60
   * degrees of heading error; where the heading is unknown, more starts search the other
   * headings too, each on the cheap coarsest grid, and the one with the highest mutual
   * information goes on with the best few distinct others (measured on KITTI with any
   * heading: 43.8 % of alignments succeed with 1 start, 98.1 % with 4, 100 % with 8).
   * Ignored when yaw is pinned (a zero yaw step). */
  int heading_starts = 1;
  /** Further starts of the coarsest level at the guess's heading, spread evenly on the
   * ellipse of half the x and y steps around the guess (0 = none). For guesses whose
   * neighbourhood holds a better-looking coarse optimum than the true one, above all scans
   * with a narrow field of view: the empty space outside both fields of view agrees best
   * where the two sensors stand alike, which holds the search near the guess (measured on
   * KITTI cut to a 70 deg field of view: 89.1 % of alignments succeed without, 97.0 % with
   * 4). With several starts (heading or position) the best few distinct coarse optima are
   * all refined on the next level, which decides. Ignored when x and y are pinned. */
  int position_starts = 0;
  /** Position starts used instead, when more, for clouds with a narrow field of view:
   * either cloud covers less than 180 degrees of azimuth about its own frame's z axis,
   * where a spinning LiDAR's scan covers 360 (0 = never). Measured on KITTI cut to
   * 70 / 120 deg fields of view (368 alignments each), success without / with 4 / with 8:
   * identity guess 89.1 / 97.0 / 97.0 % and 94.3 / 99.2 / 100 %; guess perturbed by
   * 1-10 m and +-20 deg 73.1 / 91.8 / 93.8 % and 85.3 / 95.9 / 97.3 %. Full scans are not
   * affected. Clouds given in a frame whose origin lies far from the sensor may look
   * narrow and only cost the extra starts; set 0 to rule that out.
   * AlignmentResult::position_starts says what an alignment used. */
  int narrow_view_position_starts = 8;
  /** Levels of the coarse-to-fine voxel pyramid. Level l uses resolution * 2^l; the search
   * starts on the coarsest level, whose smoother cost has a wider basin, and refines the
   * optimum on each finer level. With a refinement (and more than one level) the
   * refinement takes the place of the search on the finest level. 1 = the paper's single
   * resolution. */
  int pyramid_levels = 3;
  /** The source enters each evaluation as samples: the points of each cube of edge
   * (level resolution / source_subdivision) summarised by count, centroid and covariance.
   * 0 = every point on its own (the paper's exact evaluation). */
  int source_subdivision = 2;
  /** Threads one alignment may use: with 2 or more, the two starts of the symmetric search
   * run concurrently. The result is the same for any number of threads. */
  int num_threads = 2;
  /** Number of restarts around the best vertex on the finest searched level, each with
   * that level's steps, alternating in sign. Without a refinement, 2 restarts lift the
   * search out of the local optima the voxel quantisation scatters near the peak. */
  int restarts = 0; ///< 0..100; each costs at least one iteration of max_iterations
  /** Scale, relative to simplex_steps, of the simplex with which the second-coarsest level
   * refines the coarsest level's optimum; each finer level halves it. */
  double restart_scale = 0.25;
  /** Backend of the cost evaluations. Every backend gives the same joint histograms, bit
   * for bit, hence the same result. */
  Backend backend = Backend::Cpu;
  /** OpenCL platform and device index (as clinfo lists them); -1, -1 picks the first GPU,
   * else the first device. */
  int opencl_platform = -1;
  int opencl_device = -1;
  /** Time every OpenCL command with device events, for the "device:" stages of
   * RegistrationCore::backendProfile(). Off by default: event profiling cost about 50 us
   * per evaluation on an NVIDIA H100 (a third of an evaluation). Host-side stages and the
   * CPU backend are always timed. */
  bool profile_device = false;
  /** Refinement after the MI search. MI finds the basin from far away but its optimum is
   * quantised by the voxel grid; the refinement moves the source samples onto the
   * target's local surfaces (mean and covariance per cube of edge refinement_resolution),
   * a smooth cost that converges in a few Gauss-Newton steps from within the basin. A
   * refinement that moves the pose by more than resolution or 5 degrees is discarded. */
  Refinement refinement = Refinement::PointToDistribution;
  /** Cube edge of the refinement's target distributions, in the clouds' units; 0 (the
   * default) = 0.7 * resolution (effectiveRefinementResolution()). The refinement moves the
   * finest level's source samples (cubes of resolution / source_subdivision); a cube edge
   * that is not a multiple of theirs keeps the two grids from aliasing (measured on KITTI:
   * 0.7 m gives 0.025 m mean error with 0.5 m samples, 0.5 m gives 0.05 m). Following the
   * resolution keeps the method scale-free: the same scans in millimetres, or shrunk to a
   * room's size, align with the same relative accuracy. */
  double refinement_resolution = 0.0;
  /** Most Gauss-Newton iterations of the refinement. */
  int refinement_max_iterations = 20;
  /** Maximum number of Nelder-Mead iterations, summed over all starts and restarts. */
  int max_iterations = 1000;
  /** The simplex on the finest level has converged once every vertex lies within this
   * distance of the best vertex in each translation parameter, in the clouds' units; 0 (the
   * default) = 0.005 * resolution (effectiveTranslationTolerance()). Coarser levels l use
   * 30 * 2^l times the tolerances: they only have to land in the next level's basin ... */
  double translation_tolerance = 0.0;
  /** ... and within this angle (rad) in each rotation parameter. */
  double rotation_tolerance = 0.0005;

  /** \brief The paper's exact method: one simplex from the guess, one grid, every source
   * point in every evaluation, fixed binning ranges; no mirrored start, pyramid, restarts
   * or refinement, and no automatic position starts for a narrow field of view. */
  static Parameters
  paper();

  /** \brief Cube edge the refinement uses: refinement_resolution, or 0.7 * resolution
   * when that is 0. */
  double
  effectiveRefinementResolution() const
  {
    return refinement_resolution > 0.0 ? refinement_resolution : 0.7 * resolution;
  }

  /** \brief Translation tolerance the search uses: translation_tolerance, or
   * 0.005 * resolution when that is 0. */
  double
  effectiveTranslationTolerance() const
  {
    return translation_tolerance > 0.0 ? translation_tolerance : 0.005 * resolution;
  }

  /** \brief The binning of the selected feature. */
  const FeatureBinning&
  binning() const
  {
    return feature == Feature::VarianceZ ? variance_z_binning : point_count_binning;
  }

  /** \brief Checks every value; returns an empty string when valid, else the reason. */
  std::string
  validate() const;
};

/** \brief Wall-clock time spent in one stage of an alignment. */
struct StageTiming {
  std::string name;      ///< e.g. "prepare", "search 4 m", "refinement"
  int calls = 0;         ///< times the stage ran (cost evaluations for a search stage)
  double total_ms = 0.0; ///< wall-clock milliseconds, summed over calls
};

/** \brief Outcome of one alignment. */
struct AlignmentResult {
  /** Source-to-target transformation (maps source points into the target frame). */
  Eigen::Matrix4d transformation = Eigen::Matrix4d::Identity();
  /** True only when the simplex shrank below the tolerances; false when the iteration
   * cap was hit or the alignment failed. */
  bool converged = false;
  /** Nelder-Mead iterations performed. */
  int iterations = 0;
  /** Cost (mutual information) evaluations performed. */
  int evaluations = 0;
  /** Gauss-Newton iterations of the refinement (0 when off or discarded). */
  int refinement_iterations = 0;
  /** Further starts around the guess the coarsest level used: position_starts, or
   * narrow_view_position_starts for a narrow field of view (0 when x and y are pinned). */
  int position_starts = 0;
  /** Mutual information (nats) at the final transformation. */
  double mutual_information = 0.0;
  /** Empty on success, otherwise why the alignment failed. */
  std::string error;
  /** What the caller should know that did not stop the alignment (e.g. a large share of a
   * cloud dropped as far outliers); the PCL adapter prints each with PCL_WARN. */
  std::vector<std::string> warnings;
  /** Where the time went, stage by stage in the order they ran. Concurrent searches are
   * one stage; its time is wall-clock. */
  std::vector<StageTiming> stages;
};

} // namespace pcl_mi
