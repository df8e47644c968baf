/*
 * pcl_mi: 3D scan alignment by maximising the mutual information of voxel features.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_mi/types.h>

#include <Eigen/Core>

#include <string>

namespace pcl_mi {

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

/** \brief How the search hands poses to the OpenCL backend. The CPU backend always scores
 * one pose at a time, two searches at once; every mode gives the same result. */
enum class Batching {
  /** In batches on a GPU or accelerator, where a round trip costs more than the poses it
   * scores; one pose at a time on an OpenCL CPU device (PoCL). */
  Auto,
  /** Always in batches: a level's independent searches in lockstep, each simplex step's
   * reflection, expansion and both contractions together (speculatively), one round trip
   * per step of all of them. */
  On,
  Off ///< one pose per round trip, two searches at once
};

/** \brief Parses a batching name as command lines spell it: "auto", "on" or "off".
 * \return false (leaving \a batching unchanged) for any other name. */
bool
parseBatching(const std::string& name, Batching& batching);

/** \brief Local refinement applied to the optimum of the MI search. */
enum class Refinement {
  None,                ///< the MI optimum as found (the paper's method)
  PointToDistribution  ///< Gauss-Newton on the target's voxel distributions (see Parameters)
};

/** \brief The voxel grids: what each voxel's feature is and at which sizes. A change
 * rebuilds the target's grids and the source's samples. */
struct GridParameters {
  /** Voxel edge length R_v in the clouds' units; 0 (the default) = derived from the
   * target: the power of two nearest to its extent / 32 (in log scale), where the extent is
   * the geometric mean of its two largest 5-95 % ranges along x, y and z (1 or 2 m for a
   * street scan, 0.5 m for a courtyard, 0.125-0.25 m for a room; docs/method.md). The refinement's cube edge, the
   * translation tolerance and translation steps given in voxels follow it. */
  double resolution = 0.0;
  /** Feature used for the histograms. */
  Feature feature = Feature::VarianceZ;
  /** Binning of VarianceZ values (var(z) / resolution^2). */
  FeatureBinning variance_z_binning{16, 1.0 / 12.0};
  /** Binning of PointCount values (points per voxel). The range follows the target's
   * density: up to the upper quartile of its occupied voxels' counts on each pyramid level,
   * since sensors with fewer beams fill voxels far less densely. */
  FeatureBinning point_count_binning{16, 64.0, 0.75};
  /** Levels of the coarse-to-fine voxel pyramid. Level l uses resolution * 2^l; the search
   * starts on the coarsest level, whose smoother cost has a wider basin, and refines the
   * optimum on each finer level. With a refinement (and more than one level) the
   * refinement takes the place of the search on the finest level. 1 = the paper's single
   * resolution. */
  int pyramid_levels = 3;

  /** \brief The binning of the selected feature. */
  const FeatureBinning&
  binning() const
  {
    return feature == Feature::VarianceZ ? variance_z_binning : point_count_binning;
  }
  bool
  operator==(const GridParameters& o) const;
  bool
  operator!=(const GridParameters& o) const
  {
    return !(*this == o);
  }
};

/** \brief How the source enters each evaluation. A change rebuilds the source's samples. */
struct SamplingParameters {
  /** The source enters each evaluation as samples: the points of each cube of edge
   * (level resolution / source_subdivision) summarised by count, centroid and covariance.
   * 0 = every point on its own (the paper's exact evaluation). */
  int source_subdivision = 2;

  bool
  operator==(const SamplingParameters& o) const
  {
    return source_subdivision == o.source_subdivision;
  }
  bool
  operator!=(const SamplingParameters& o) const
  {
    return !(*this == o);
  }
};

/** \brief The Nelder-Mead search over [tx, ty, tz, roll, pitch, yaw]. A change rebuilds
 * nothing, except of leveling and of which steps are zero (the target's frame). The
 * iteration cap is the PCL base class's (setMaximumIterations()), or
 * RegistrationCore::align()'s argument. */
struct SearchParameters {
  /** Initial simplex step per parameter [tx, ty, tz, roll, pitch, yaw (rad)]. A positive
   * translation step is in the clouds' units; a negative one is in voxels (-8 = 8 times the
   * resolution in use), so that it scales with the scene. A zero step pins its parameter
   * (planar motion). The default is 16, 16 and 4 voxels and the paper's 0.1, 0.1, 0.8 rad:
   * twice the paper's 8 m, 8 m, 1 m at its 1 m voxels horizontally and four times
   * vertically, which a street scan does not need but a handheld scan's courtyard or room
   * does (docs/method.md gives the measurements). */
  Eigen::Matrix<double, 6, 1> simplex_steps =
      (Eigen::Matrix<double, 6, 1>() << -16.0, -16.0, -4.0, 0.1, 0.1, 0.8).finished();
  /** \brief Which of [tx, ty, tz, roll, pitch, yaw] the search moves: those with a non-zero
   * step. */
  Eigen::Matrix<bool, 6, 1>
  searched() const
  {
    return simplex_steps.array() != 0.0;
  }
  /** Also start a second simplex with all steps negated and keep the better result. The
   * paper's simplex explores mainly along its positive steps and misses large motion in
   * the opposite direction (e.g. aligning an earlier scan onto a later one). */
  bool symmetric_start = true;
  /** Headings the coarsest level starts from, spread evenly over 360 degrees of yaw from
   * the guess's (1 = the guess's only); the one with the highest mutual information goes
   * on with the best few distinct others. For an unknown heading (docs/method.md gives the
   * measured success per count). Ignored when yaw is pinned. */
  int heading_starts = 1;
  /** Further starts of the coarsest level at the guess's heading, spread evenly on the
   * ellipse of half the x and y steps around the guess (0 = none): for guesses whose
   * neighbourhood holds a better-looking coarse optimum than the true one, above all with
   * a narrow field of view. Ignored when x and y are pinned. */
  int position_starts = 0;
  /** Position starts used instead, when more, for clouds with a narrow field of view:
   * either cloud covers less than 180 degrees of azimuth about its own frame's z axis,
   * where a spinning LiDAR's scan covers 360 (0 = never). Clouds given in a frame whose
   * origin lies far from the sensor may look narrow and only cost the extra starts.
   * AlignmentResult::position_starts says what an alignment used. */
  int narrow_view_position_starts = 8;
  /** Roll and pitch simplex steps (rad) used instead, when larger, for clouds with a narrow
   * field of view (as for narrow_view_position_starts; 0 = never), whose search also turns
   * the source about its sensor, the origin of its frame, where that lies within four RMS
   * radii of its points: a handheld or solid-state sensor tilts by tens of degrees, and
   * turning its cloud about its centroid, several metres ahead, would move the sensor
   * sideways (docs/method.md, "Defaults derived from the data"). */
  double narrow_view_tilt_step = 0.35;
  /** For clouds with a narrow field of view (as for narrow_view_position_starts; 0 =
   * never): two more starts of the coarsest level, at the guess's position turned by plus
   * and minus this yaw (rad). A handheld sensor with a 70-degree view turns by tens of
   * degrees between scans, and a turn changes most of what it sees, so the simplex from the
   * guess alone often settles on the part of the scene the two views share least well
   * (docs/benchmarks.md, "Narrow views: starts turned in yaw"). */
  double narrow_view_yaw_start = 0.5;
  /** For clouds with a narrow field of view (as for narrow_view_position_starts): this
   * many more starts of the coarsest level at the guess's position, turned by the turns
   * that score best among a grid of yaw (every 10 degrees within 60), pitch (within 30) and
   * roll (within 30) about the sensor, at least 11 degrees from the guess and 17 from each
   * other (0 = none). A sensor turned on the spot changes what it sees with every turn; the
   * grid finds the turn that the simplex's steps miss (docs/benchmarks.md, "Narrow views:
   * scanned turns"). Roll is left out (91 turns instead of 637) where both clouds show an
   * up direction and the guess keeps them within 5 degrees, as on a car (docs/benchmarks.md,
   * "Scanned turns in roll"). AlignmentResult::scanned_starts says how many an alignment
   * used. */
  int narrow_view_scanned_starts = 2;
  /** For clouds without a narrow field of view, when the verification does not trust the
   * result: a second, wider search from this many headings spread over 360 degrees and from
   * two positions half the x step either way along x from the guess, with roll and pitch
   * steps of at least 0.35 rad (0 = none). Of its optima and the first
   * search's, the one that agrees best with the target on the finest grid is kept
   * (AlignmentResult::second_search). A guess off by more than about 60 degrees of heading,
   * or a handheld sensor tilted by tens of degrees, is where the first search fails; a
   * result that passes never pays for it (docs/method.md, "The verdict"). It runs on what
   * is left of the iteration cap. */
  int second_search_headings = 4;
  /** When the verification does not trust the result: the target is also searched onto
   * the source, from the inverse of the guess, and that search's best optimum and
   * runners-up, inverted, are refined and verified as candidates, one kept where it lies on
   * surface the clouds share and agrees better with the target on the finest grid
   * (AlignmentResult::reverse_kept). The cost samples the source and bins the target, so
   * the two directions are different problems: on sparse, narrow views one often finds the
   * pose where the other does not (docs/benchmarks.md, "The reverse search"). It runs on
   * what is left of the iteration cap. */
  bool reverse_search = true;
  /** For clouds without a narrow field of view: where the two clouds' up directions, read
   * from their horizontal surfaces (ground, floor, ceiling), disagree under the guess by
   * more than 5 degrees, both searches start from the guess turned about the source's
   * centroid so that they agree, and search along the target's up
   * (AlignmentResult::leveled), as they do where the two agree on an up more than
   * 5 degrees from the target's z; and a target tilted by more than 5 degrees is voxelised
   * in a frame turned level, so that its z-variance feature is taken along up. A sensor
   * carried or mounted tilted is where the simplex alone fails to find roll and pitch, or
   * moves across the ground along its own tilted axes;
   * scans taken level never meet the conditions (docs/method.md, "Leveling"). Unlike the
   * other search fields, a change rebuilds the target. Off when a parameter is pinned (a
   * zero simplex step), since pins are meant along the target's own axes. */
  bool leveling = true;
  /** The coarsest pyramid level, when finer ones follow it, maximises normalised MI
   * (H(X) + H(Y)) / H(X, Y) instead of MI: the search there travels far, and the overlap
   * it moves through changes how much MI a pose can score, which normalised MI does not
   * follow. The finer levels maximise MI (docs/method.md, "Normalised MI on the coarsest
   * level"). false = MI on every level, as the paper. */
  bool coarse_normalized_mi = true;
  /** Restarts around the best vertex on the finest searched level, each with that level's
   * steps, alternating in sign: they lift the search out of the local optima the voxel
   * quantisation scatters near the peak. 0..100; each costs at least one iteration. */
  int restarts = 0;
  /** Scale, relative to simplex_steps, of the simplex with which the second-coarsest level
   * refines the coarsest level's optimum; each finer level halves it. */
  double restart_scale = 0.25;
  /** The simplex on the finest level has converged once every vertex lies within this
   * distance of the best vertex in each translation parameter, in the clouds' units; 0 (the
   * default) = 0.005 * resolution (Parameters::effectiveTranslationTolerance()). Coarser
   * levels l use 30 * 2^l times the tolerances: they only have to land in the next
   * level's basin ... */
  double translation_tolerance = 0.0;
  /** ... and within this angle (rad) in each rotation parameter. */
  double rotation_tolerance = 0.0005;

  bool
  operator==(const SearchParameters& o) const;
  bool
  operator!=(const SearchParameters& o) const
  {
    return !(*this == o);
  }
};

/** \brief The local refinement of the MI optimum. A change rebuilds the target's
 * distributions. */
struct RefinementParameters {
  /** MI finds the basin from far away but its optimum is quantised by the voxel grid; the
   * refinement moves the source samples onto the target's local surfaces (mean and
   * covariance per cube), a smooth cost that converges in a few Gauss-Newton steps from
   * within the basin. A refinement that moves the pose by more than the searched voxel
   * size or 5 degrees (more with narrow_view_stages) is discarded. */
  Refinement method = Refinement::PointToDistribution;
  /** Cube edge of the target distributions, in the clouds' units; 0 (the default) =
   * 0.7 * resolution (Parameters::effectiveRefinementResolution()): not a multiple of the
   * source samples' cubes, so the two grids do not alias, and scale-free. */
  double resolution = 0.0;
  /** Most Gauss-Newton iterations (per stage). */
  int max_iterations = 20;
  /** For clouds with a narrow field of view (SearchParameters::narrow_view_position_starts
   * says when): this many coarser stages first, on cubes 2^k times the refinement's (k =
   * stages down to 1), each moving the samples of pyramid level k. A sparse scan's MI
   * optimum lies up to a searched voxel or more from the truth, beyond the reach of the
   * finest cubes; the coarser ones pull it in. The bound on how far the refinement may move
   * the pose grows to (1 + stages) searched voxels and 5 * (1 + stages) degrees (0 = one
   * stage; docs/method.md, "Refinement"). */
  int narrow_view_stages = 2;

  bool
  operator==(const RefinementParameters& o) const
  {
    return method == o.method && resolution == o.resolution &&
           max_iterations == o.max_iterations && narrow_view_stages == o.narrow_view_stages;
  }
  bool
  operator!=(const RefinementParameters& o) const
  {
    return !(*this == o);
  }
};

/** \brief Where the cost evaluations run. A change remakes the backends. */
struct BackendParameters {
  /** Every backend gives the same joint histograms, bit for bit, hence the same result. */
  Backend type = Backend::Cpu;
  /** OpenCL platform and device index (as clinfo lists them); -1, -1 picks the first GPU,
   * else the first device. */
  int opencl_platform = -1;
  int opencl_device = -1;
  /** Time every OpenCL command with device events, for the "device:" stages of
   * RegistrationCore::backendProfile(). Off by default: it slows evaluations down
   * (docs/opencl.md). Host-side stages and the CPU backend are always timed. */
  bool profile_device = false;
  /** How the search hands poses to an OpenCL backend (docs/opencl.md, "Batches"). */
  Batching batching = Batching::Auto;

  bool
  operator==(const BackendParameters& o) const
  {
    return type == o.type && opencl_platform == o.opencl_platform &&
           opencl_device == o.opencl_device && profile_device == o.profile_device &&
           batching == o.batching;
  }
  bool
  operator!=(const BackendParameters& o) const
  {
    return !(*this == o);
  }
};

/** \brief All tuning parameters of the mutual-information registration, with their
 * defaults, in groups by what a change rebuilds.
 *
 * The cost is the paper's (Mehta, McBride, Pandey, "Robust and Fast 3D Scan Alignment using
 * Mutual Information"): 1 m voxels, variance of z, the anisotropic initial simplex
 * [8 m, 8 m, 1 m, 0.1, 0.1, 0.8 rad]. The defaults scale its voxels and translation steps
 * with the target's extent (1 m voxels on a street scan), search it from a mirrored pair of
 * starts on a coarse-to-fine pyramid (4 and 2 voxels) with a sampled source, and refine the optimum
 * against the target's local distributions; Parameters::paper() turns all of that off.
 */
struct Parameters {
  GridParameters grid;
  SamplingParameters sampling;
  SearchParameters search;
  RefinementParameters refinement;
  BackendParameters backend;
  /** Threads one alignment may use: with 2 or more, the preparation, the searches, the
   * refinement and the verification split their work over two. The result is the same for
   * any number of threads. */
  int num_threads = 2;
  /** How many of the clouds' units make a metre (1000 for millimetres). Everything follows
   * the resolution but a few lengths kept in metres, which follow this: the verdict's (the
   * confidence is fitted to results within 0.5 m of the true pose, and the tests of a
   * held-back result ask for half of that; docs/method.md, "The verdict") and the
   * refinement's smallest step and lever arm. Set, clouds in other units give the result in
   * metres, scaled. */
  double units_per_metre = 1.0;

  /** \brief The paper's exact method: 1 m voxels and the [8 m, 8 m, 1 m, 0.1, 0.1, 0.8 rad]
   * simplex (nothing derived from the data), one simplex from the guess, one grid, every source
   * point in every evaluation, fixed binning ranges; no mirrored start, pyramid, restarts
   * or refinement, and no automatic position starts for a narrow field of view. */
  static Parameters
  paper();

  /** \brief Cube edge the refinement uses: refinement.resolution, or 0.7 * resolution
   * when that is 0. */
  double
  effectiveRefinementResolution() const
  {
    return refinement.resolution > 0.0 ? refinement.resolution : 0.7 * grid.resolution;
  }

  /** \brief Translation tolerance the search uses: search.translation_tolerance, or
   * 0.005 * resolution when that is 0. */
  double
  effectiveTranslationTolerance() const
  {
    return search.translation_tolerance > 0.0 ? search.translation_tolerance
                                              : 0.005 * grid.resolution;
  }

  /** \brief Checks every value; returns an empty string when valid, else the reason. */
  std::string
  validate() const;
};

/** \brief Default Nelder-Mead iteration cap, summed over all starts and restarts. */
constexpr int kDefaultMaxIterations = 2000;

/** \brief Empty when \a max_iterations is a usable iteration cap (at least 1), else why. */
std::string
maxIterationsError(int max_iterations);

} // namespace pcl_mi
