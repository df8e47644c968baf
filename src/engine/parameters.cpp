/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_mi/parameters.h>

#include <cmath>
#include <sstream>

namespace pcl_mi {

namespace {

/** Most restarts: each costs at least one iteration of the budget, and more than this
 * many searches around one optimum find nothing new. */
constexpr int kMaxRestarts = 100;

std::string
validateBinning(const char* what, const FeatureBinning& b)
{
  std::ostringstream s;
  if (b.num_bins < 1 || b.num_bins > 255)
    s << what << " binning needs 1..255 bins, got " << b.num_bins;
  else if (!(b.max_value > 0.0) || !std::isfinite(b.max_value))
    s << what << " binning needs a positive finite maximum value, got " << b.max_value;
  else if (!(b.range_quantile >= 0.0 && b.range_quantile <= 1.0))
    s << what << " binning's range quantile must be in [0, 1], got " << b.range_quantile;
  return s.str();
}

bool
sameBinning(const FeatureBinning& a, const FeatureBinning& b)
{
  return a.num_bins == b.num_bins && a.max_value == b.max_value &&
         a.range_quantile == b.range_quantile;
}

} // namespace

const char*
featureName(Feature feature)
{
  switch (feature) {
  case Feature::VarianceZ:
    return "VarianceZ";
  case Feature::PointCount:
    return "PointCount";
  }
  return "unknown";
}

const char*
refusalName(Refusal refusal)
{
  switch (refusal) {
  case Refusal::None:
    return "none";
  case Refusal::LittleSharedSurface:
    return "too little shared surface";
  case Refusal::Degenerate:
    return "degenerate";
  case Refusal::SecondOptimum:
    return "a second optimum";
  case Refusal::WeakEvidence:
    return "weak evidence";
  }
  return "unknown";
}

bool
parseBackend(const std::string& name, Backend& backend)
{
  if (name == "cpu")
    backend = Backend::Cpu;
  else if (name == "opencl")
    backend = Backend::OpenCL;
  else if (name == "auto")
    backend = Backend::Auto;
  else
    return false;
  return true;
}

bool
parseBatching(const std::string& name, Batching& batching)
{
  if (name == "auto")
    batching = Batching::Auto;
  else if (name == "on")
    batching = Batching::On;
  else if (name == "off")
    batching = Batching::Off;
  else
    return false;
  return true;
}

bool
GridParameters::operator==(const GridParameters& o) const
{
  return resolution == o.resolution && feature == o.feature &&
         sameBinning(variance_z_binning, o.variance_z_binning) &&
         sameBinning(point_count_binning, o.point_count_binning) &&
         pyramid_levels == o.pyramid_levels;
}

bool
SearchParameters::operator==(const SearchParameters& o) const
{
  return simplex_steps == o.simplex_steps && symmetric_start == o.symmetric_start &&
         heading_starts == o.heading_starts && position_starts == o.position_starts &&
         narrow_view_position_starts == o.narrow_view_position_starts &&
         narrow_view_tilt_step == o.narrow_view_tilt_step &&
         narrow_view_yaw_start == o.narrow_view_yaw_start &&
         narrow_view_scanned_starts == o.narrow_view_scanned_starts &&
         second_search_headings == o.second_search_headings &&
         reverse_search == o.reverse_search && leveling == o.leveling &&
         coarse_normalized_mi == o.coarse_normalized_mi &&
         restarts == o.restarts && restart_scale == o.restart_scale &&
         translation_tolerance == o.translation_tolerance &&
         rotation_tolerance == o.rotation_tolerance;
}

Parameters
Parameters::paper()
{
  Parameters p;
  p.grid.resolution = 1.0;
  p.search.simplex_steps << 8.0, 8.0, 1.0, 0.1, 0.1, 0.8;
  p.search.symmetric_start = false;
  p.grid.pyramid_levels = 1;
  p.sampling.source_subdivision = 0;
  p.search.restarts = 0;
  p.refinement.method = Refinement::None;
  p.refinement.narrow_view_stages = 0;
  p.search.narrow_view_position_starts = 0;
  p.search.narrow_view_tilt_step = 0.0;
  p.search.narrow_view_yaw_start = 0.0;
  p.search.narrow_view_scanned_starts = 0;
  p.search.second_search_headings = 0;
  p.search.reverse_search = false;
  p.search.leveling = false;
  p.search.coarse_normalized_mi = false;
  p.grid.variance_z_binning.range_quantile = 0.0;
  p.grid.point_count_binning.range_quantile = 0.0;
  return p;
}

std::string
Parameters::validate() const
{
  std::ostringstream s;
  const GridParameters& g = grid;
  const SearchParameters& f = search;
  if (!(g.resolution >= 0.0) || !std::isfinite(g.resolution))
    s << "resolution must be finite and not negative (0 = derived from the target), got "
      << g.resolution;
  else if (g.feature != Feature::VarianceZ && g.feature != Feature::PointCount)
    s << "unknown feature " << static_cast<int>(g.feature);
  else if (!validateBinning("VarianceZ", g.variance_z_binning).empty())
    return validateBinning("VarianceZ", g.variance_z_binning);
  else if (!validateBinning("PointCount", g.point_count_binning).empty())
    return validateBinning("PointCount", g.point_count_binning);
  else if (!f.simplex_steps.allFinite())
    s << "simplex steps must be finite";
  else if (f.simplex_steps.isZero())
    s << "at least one simplex step must be non-zero";
  else if (!(f.translation_tolerance >= 0.0) || !std::isfinite(f.translation_tolerance))
    s << "translation tolerance must be finite and not negative (0 = follow the resolution), "
         "got "
      << f.translation_tolerance;
  else if (!(f.rotation_tolerance > 0.0) || !std::isfinite(f.rotation_tolerance))
    s << "rotation tolerance must be positive and finite, got " << f.rotation_tolerance;
  else if (sampling.source_subdivision < 0 || sampling.source_subdivision > 64)
    s << "source subdivision must be 0..64, got " << sampling.source_subdivision;
  else if (num_threads < 1)
    s << "number of threads must be at least 1, got " << num_threads;
  else if (!(units_per_metre > 0.0) || !std::isfinite(units_per_metre))
    s << "units per metre must be positive and finite, got " << units_per_metre;
  else if (f.heading_starts < 1 || f.heading_starts > 360)
    s << "heading starts must be 1..360, got " << f.heading_starts;
  else if (f.position_starts < 0 || f.position_starts > 360)
    s << "position starts must be 0..360, got " << f.position_starts;
  else if (f.narrow_view_position_starts < 0 || f.narrow_view_position_starts > 360)
    s << "narrow-view position starts must be 0..360, got " << f.narrow_view_position_starts;
  else if (!(f.narrow_view_tilt_step >= 0.0 && f.narrow_view_tilt_step <= M_PI))
    s << "the narrow-view tilt step must be 0..pi rad, got " << f.narrow_view_tilt_step;
  else if (!(f.narrow_view_yaw_start >= 0.0 && f.narrow_view_yaw_start <= M_PI))
    s << "the narrow-view yaw start must be 0..pi rad, got " << f.narrow_view_yaw_start;
  else if (f.narrow_view_scanned_starts < 0 || f.narrow_view_scanned_starts > 8)
    s << "narrow-view scanned starts must be 0..8, got " << f.narrow_view_scanned_starts;
  else if (f.second_search_headings < 0 || f.second_search_headings > 360)
    s << "second-search headings must be 0..360, got " << f.second_search_headings;
  else if (g.pyramid_levels < 1 || g.pyramid_levels > 8)
    s << "pyramid levels must be 1..8, got " << g.pyramid_levels;
  else if (f.restarts < 0 || f.restarts > kMaxRestarts)
    s << "restarts must be 0.." << kMaxRestarts << ", got " << f.restarts;
  else if (backend.type != Backend::Cpu && backend.type != Backend::OpenCL &&
           backend.type != Backend::Auto)
    s << "unknown backend " << static_cast<int>(backend.type);
  else if (refinement.method != Refinement::None &&
           refinement.method != Refinement::PointToDistribution)
    s << "unknown refinement " << static_cast<int>(refinement.method);
  else if (!(refinement.resolution >= 0.0) || !std::isfinite(refinement.resolution))
    s << "refinement resolution must be finite and not negative (0 = follow the resolution), "
         "got "
      << refinement.resolution;
  else if (refinement.max_iterations < 1)
    s << "refinement iterations must be at least 1, got " << refinement.max_iterations;
  else if (refinement.narrow_view_stages < 0 || refinement.narrow_view_stages > 4)
    s << "narrow-view refinement stages must be 0..4, got " << refinement.narrow_view_stages;
  else if (!(f.restart_scale > 0.0) || !std::isfinite(f.restart_scale))
    s << "restart scale must be positive and finite, got " << f.restart_scale;
  return s.str();
}

std::string
maxIterationsError(int max_iterations)
{
  if (max_iterations >= 1)
    return {};
  return "maximum iterations must be at least 1, got " + std::to_string(max_iterations);
}

} // namespace pcl_mi
