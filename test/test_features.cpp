/*
 * Feature values and bins on hand-built voxels; the local cloud on hand-built and real
 * clouds; the target grid and the CPU backend's joint histogram on hand-built clouds.
 */
#include "backend/scoring_backend.h"
#include "features/feature_binning.h"
#include "features/local_cloud.h"
#include <pcl_mi/parameters.h>
#include "features/source_samples.h"
#include "features/up_direction.h"
#include "features/voxel_grid.h"
#include "util/bounding_box.h"

#include "test_data.h"

#include <pcl/common/io.h>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <optional>
#include <random>

using namespace pcl_mi;
using namespace pcl_mi::core;

namespace {

VoxelMoments
momentsOf(std::initializer_list<int> heights)
{
  VoxelMoments m;
  for (int q : heights)
    m.add(q);
  return m;
}

} // namespace

TEST(FeatureBinning, EmptyVoxelIsBinZero)
{
  const FeatureBinning b{16, 1.0 / 12.0};
  EXPECT_EQ(voxelBin(Feature::VarianceZ, b, VoxelMoments{}), 0);
  EXPECT_EQ(voxelBin(Feature::PointCount, FeatureBinning{16, 64}, VoxelMoments{}), 0);
}

TEST(FeatureBinning, VarianceZHandComputed)
{
  const FeatureBinning b{16, 1.0 / 12.0};
  // One point, or points at one height: zero variance, first occupied bin.
  EXPECT_DOUBLE_EQ(featureValue(Feature::VarianceZ, momentsOf({77})), 0.0);
  EXPECT_EQ(voxelBin(Feature::VarianceZ, b, momentsOf({77})), 1);
  EXPECT_EQ(voxelBin(Feature::VarianceZ, b, momentsOf({5, 5, 5})), 1);
  // Heights 0 and 128 (of 256 levels): var = 64^2 / 256^2 = 1/16 of R_v^2;
  // bin = 1 + floor(16 * (1/16) / (1/12)) = 1 + 12 = 13.
  EXPECT_DOUBLE_EQ(featureValue(Feature::VarianceZ, momentsOf({0, 128})), 1.0 / 16.0);
  EXPECT_EQ(voxelBin(Feature::VarianceZ, b, momentsOf({0, 128})), 13);
  // Heights 0 and 255: var just under 1/4 >= max: clamped into the last bin.
  EXPECT_EQ(voxelBin(Feature::VarianceZ, b, momentsOf({0, 255})), 16);
  // Heights 0, 0, 0, 64: mean 16, var = (3 * 16^2 + 48^2) / 4 = 768 -> 768 / 65536.
  EXPECT_DOUBLE_EQ(featureValue(Feature::VarianceZ, momentsOf({0, 0, 0, 64})),
                   768.0 / 65536.0);
  // 16 * (768 / 65536) * 12 = 2.25 -> bin 3.
  EXPECT_EQ(voxelBin(Feature::VarianceZ, b, momentsOf({0, 0, 0, 64})), 3);
}

TEST(FeatureBinning, PointCountHandComputed)
{
  const FeatureBinning b{16, 64.0};
  EXPECT_DOUBLE_EQ(featureValue(Feature::PointCount, momentsOf({1, 2, 3})), 3.0);
  EXPECT_EQ(voxelBin(Feature::PointCount, b, momentsOf({1, 2, 3})), 1);    // 0.75
  EXPECT_EQ(voxelBin(Feature::PointCount, b, momentsOf({1, 2, 3, 4})), 2); // 1.0
  VoxelMoments many;
  for (int i = 0; i < 1000; ++i)
    many.add(0);
  EXPECT_EQ(voxelBin(Feature::PointCount, b, many), 16);
}

TEST(FeatureBinning, QuantisedHeightStaysInVoxel)
{
  EXPECT_EQ(quantiseHeight(3.0f, 3), 0);
  EXPECT_EQ(quantiseHeight(3.5f, 3), 128);
  EXPECT_EQ(quantiseHeight(3.9999999f, 3), 255);
  EXPECT_EQ(quantiseHeight(4.0f, 3), 255); // rounding at the upper face
}

TEST(LocalCloud, DropsNonFiniteNoReturnAndFarOutliers)
{
  PointList points;
  for (int i = 1; i <= 100; ++i)
    points.emplace_back(0.1f * i, 0.05f * i, 0.0f);
  points.emplace_back(std::nanf(""), 0.0f, 0.0f);
  points.emplace_back(0.0f, std::numeric_limits<float>::infinity(), 0.0f);
  points.emplace_back(1e5f, 0.0f, 0.0f);
  // No-return markers; a point merely near the origin stays.
  points.insert(points.begin() + 10, 3, Eigen::Vector3f::Zero());
  points.emplace_back(-0.0f, 0.0f, -0.0f);
  points.emplace_back(0.0f, 0.0f, 1e-6f);
  const LocalCloud cloud = makeLocalCloud(points, 64.0);
  EXPECT_EQ(cloud.non_finite, 2u);
  EXPECT_EQ(cloud.no_return, 4u);
  EXPECT_EQ(cloud.outliers, 1u);
  ASSERT_EQ(cloud.points.size(), 101u);
  EXPECT_NEAR(cloud.centroid.x(), 0.1 * 5050 / 101, 1e-5);
  EXPECT_NEAR(cloud.centroid.y(), 0.05 * 5050 / 101, 1e-5);
}

namespace {

/** The same local cloud to the bit: points, sums and counts. */
void
expectTheSameLocalCloud(const LocalCloud& a, const LocalCloud& b)
{
  ASSERT_EQ(a.points.size(), b.points.size());
  EXPECT_TRUE(a.points == b.points);
  EXPECT_EQ(a.centroid, b.centroid);
  EXPECT_EQ(a.covariance, b.covariance);
  EXPECT_EQ(a.non_finite, b.non_finite);
  EXPECT_EQ(a.no_return, b.no_return);
  EXPECT_EQ(a.outliers, b.outliers);
  EXPECT_EQ(a.rms_radius, b.rms_radius);
  EXPECT_EQ(a.azimuth_coverage_deg, b.azimuth_coverage_deg);
  EXPECT_EQ(a.box.min, b.box.min);
  EXPECT_EQ(a.box.max, b.box.max);
}

} // namespace

TEST(LocalCloud, PointsReadInPlaceThroughAStrideAreTheListsToTheBit)
{
  // A real scan in a PCL cloud of 32-byte points, read through a view, against its copy.
  const auto scan = test_data::loadScan("00", 0);
  auto padded = pcl::make_shared<pcl::PointCloud<pcl::PointXYZI>>();
  pcl::copyPointCloud(*scan, *padded);
  const PointList copy = test_data::pointList(*scan);
  const pcl_mi::PointView view(&padded->front().x, sizeof(pcl::PointXYZI), padded->size(), padded);
  expectTheSameLocalCloud(makeLocalCloud(copy, 64.0), makeLocalCloud(view, 64.0));
}

TEST(LocalCloud, TheSameReadOnTwoThreads)
{
  // A real scan with no-returns and NaNs in both halves, so that the second half's points
  // move down behind the first's.
  PointList points = test_data::pointList(*test_data::loadScan("00", 0));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t i = 0; i < points.size(); i += 97)
    points[i] = i % 2 ? Eigen::Vector3f::Zero() : Eigen::Vector3f(nan, 1.0f, 2.0f);
  const LocalCloud two = makeLocalCloud(points, 64.0, 2);
  expectTheSameLocalCloud(makeLocalCloud(points, 64.0, 1), two);
  EXPECT_GT(two.non_finite, 500u);
  EXPECT_GT(two.no_return, 500u);
}

TEST(LocalCloud, BuiltIntoAUsedCloudIsTheFreshOneToTheBitOnItsStorage)
{
  // Scan 9 with NaNs, no-returns and a far outlier, built into the local cloud of scan 0
  // (a registration object given a new pair), then a handful of points into that.
  PointList next = test_data::pointList(*test_data::loadScan("00", 9));
  for (std::size_t i = 0; i < next.size(); i += 101)
    next[i] = i % 2 ? Eigen::Vector3f::Zero()
                    : Eigen::Vector3f(std::numeric_limits<float>::quiet_NaN(), 1.0f, 2.0f);
  next.emplace_back(1e5f, 0.0f, 0.0f);
  for (const int threads : {1, 2}) {
    LocalCloud used = makeLocalCloud(test_data::pointList(*test_data::loadScan("00", 0)), 64.0);
    used.points.reserve(next.size());
    const Eigen::Vector3f* storage = used.points.data();
    makeLocalCloud(next, 64.0, threads, used);
    expectTheSameLocalCloud(makeLocalCloud(next, 64.0, threads), used);
    EXPECT_EQ(used.points.data(), storage) << "the used cloud's storage was not reused";
    EXPECT_EQ(used.outliers, 1u);

    // Storage more than twice what a cloud needs goes, rather than being held on to.
    const PointList few(next.begin(), next.begin() + 50);
    makeLocalCloud(few, 64.0, threads, used);
    expectTheSameLocalCloud(makeLocalCloud(few, 64.0, threads), used);
    EXPECT_LE(used.points.capacity(), 2 * few.size());
  }
}

TEST(LocalCloud, FirstPointJustBelowTheMedianKeepsItsGroupsBounds)
{
  // The first point lies in the cell just below the median along x (cells of half the gap,
  // 32 m): its run must not take 0 as its minimum, which would join the far group at 5 m
  // (85 m below the bulk) to the bulk.
  PointList points;
  points.emplace_back(90.0f, 0.0f, 0.0f);
  for (int i = 0; i < 999; ++i)
    points.emplace_back(90.0f + 20.0f * i / 999.0f, 0.1f * (i % 10), 0.1f * (i % 7));
  for (int i = 0; i < 3; ++i)
    points.emplace_back(5.0f, 0.1f * i, 0.0f);
  const LocalCloud cloud = makeLocalCloud(points, 64.0);
  EXPECT_EQ(cloud.outliers, 3u);
  EXPECT_EQ(cloud.points.size(), 1000u);
}

TEST(LocalCloud, FarOutliersDoNotDependOnThePointsOrder)
{
  // A real scan with two far groups, in its sweep order (long runs of points in one cell,
  // taken four at a time) and shuffled (runs of one point): the same points are dropped.
  PointList points = test_data::pointList(*test_data::loadScan("00", 0));
  ASSERT_GT(points.size(), 100000u);
  const std::size_t bulk = points.size();
  for (int i = 0; i < 50; ++i) {
    points.emplace_back(300.0f + i, 0.5f * i, 1.0f);
    points.emplace_back(-20.0f, 0.1f * i, -200.0f);
  }
  const LocalCloud ordered = makeLocalCloud(points, 64.0);
  EXPECT_EQ(ordered.outliers, 100u);
  EXPECT_EQ(ordered.points.size(), bulk);
  std::mt19937 random(7);
  std::shuffle(points.begin(), points.end(), random);
  const LocalCloud shuffled = makeLocalCloud(points, 64.0);
  EXPECT_EQ(shuffled.outliers, ordered.outliers);
  EXPECT_EQ(shuffled.points.size(), ordered.points.size());
  EXPECT_NEAR((shuffled.centroid - ordered.centroid).norm(), 0.0, 1e-6);
}

TEST(LocalCloud, KeepsFarOffsetPrecision)
{
  // Coordinates near 1e6 m: the local frame keeps their relative layout exact in float.
  PointList points;
  for (int i = 0; i < 10; ++i)
    points.emplace_back(1e6f + 0.125f * i, 2e6f, 3.0f);
  const LocalCloud cloud = makeLocalCloud(points, 64.0);
  ASSERT_EQ(cloud.points.size(), 10u);
  EXPECT_FLOAT_EQ(cloud.points[9].x() - cloud.points[0].x(), 1.125f);
}

TEST(LocalCloud, AzimuthCoverageOfFullAndNarrowViews)
{
  // Rings of points about the origin, as a sensor at the origin sees them: a full turn,
  // a 70 deg wedge centred on +x, and the wedge with a few stray returns elsewhere.
  auto ring = [](double from_deg, double to_deg, int count, PointList& points) {
    for (int i = 0; i < count; ++i) {
      const double a = (from_deg + (to_deg - from_deg) * (i + 0.5) / count) * M_PI / 180.0;
      for (const double range : {5.0, 20.0})
        points.emplace_back(static_cast<float>(range * std::cos(a)),
                            static_cast<float>(range * std::sin(a)), -1.7f);
    }
  };
  PointList full, wedge;
  ring(-180.0, 180.0, 36000, full);
  ring(-35.0, 35.0, 7000, wedge);
  EXPECT_DOUBLE_EQ(makeLocalCloud(full, 64.0).azimuth_coverage_deg, 360.0);
  const double narrow = makeLocalCloud(wedge, 64.0).azimuth_coverage_deg;
  EXPECT_GE(narrow, 70.0);
  EXPECT_LE(narrow, 80.0); // the wedge's edges may reach into one more sector each
  PointList stray = wedge;
  ring(-180.0, 180.0, 36, stray);
  EXPECT_EQ(makeLocalCloud(stray, 64.0).azimuth_coverage_deg, narrow);
  // Measured about the input frame's origin, not the local frame's centroid: the same
  // wedge moved 1 km away along +y lies within a few degrees of +y.
  PointList far = wedge;
  for (auto& p : far)
    p.y() += 1000.0f;
  EXPECT_LE(makeLocalCloud(far, 64.0).azimuth_coverage_deg, 10.0);
}

TEST(LocalCloud, AzimuthSectorsAtTheirEdges)
{
  // Points a hair (3e-6 rad) inside each of the 72 five-degree sectors' edges, on one side
  // of every edge at a time: each sector holds points only if each point lands where
  // atan2 puts it, though the azimuth is computed by a polynomial that errs by more.
  for (const double side : {-1.0, 1.0}) {
    PointList points;
    for (int k = 0; k < 72; ++k) {
      const double a = -M_PI + k * (2.0 * M_PI / 72.0) + side * 3e-6;
      for (const double range : {3.0, 11.0, 40.0})
        points.emplace_back(static_cast<float>(range * std::cos(a)),
                            static_cast<float>(range * std::sin(a)), 0.5f);
    }
    EXPECT_DOUBLE_EQ(makeLocalCloud(points, 64.0).azimuth_coverage_deg, 360.0) << side;
  }
}

TEST(TargetGrid, HandBuiltVoxels)
{
  // Three points in voxel (0,0,0), one in voxel (2,1,0): grid spans 3 x 2 x 1 voxels.
  PointList points{{0.1f, 0.1f, 0.0f}, {0.2f, 0.2f, 0.5f}, {0.3f, 0.3f, 0.25f},
                   {2.5f, 1.5f, 0.5f}};
  TargetGrid grid;
  std::string error;
  ASSERT_TRUE(buildTargetGrid(points, 1.0, Feature::PointCount, {16, 16.0}, grid, error))
      << error;
  EXPECT_EQ(grid.geometry.dims, Eigen::Vector3i(3, 2, 1));
  ASSERT_EQ(grid.occupied.size(), 2u);
  // PointCount 3 -> 1 + floor(16 * 3 / 16) = 4; 1 -> 2.
  EXPECT_EQ(grid.bins[grid.geometry.cellIndex(0, 0, 0)], 4);
  EXPECT_EQ(grid.bins[grid.geometry.cellIndex(2, 1, 0)], 2);
  EXPECT_EQ(grid.bins[grid.geometry.cellIndex(1, 0, 0)], 0);
  // Rows (iz * dims.y + iy) 0 and 1 hold one occupied voxel each.
  EXPECT_EQ(grid.row_starts, (std::vector<std::uint32_t>{0, 1, 2}));
}

// The row index finds exactly the occupied voxels of each row, empty rows included: a floor
// and two walls, 20 x 10 x 3 m, at 0.5 m voxels.
TEST(TargetGrid, RowStartsIndexTheOccupiedVoxelsRowByRow)
{
  PointList points;
  for (float a = 0.0f; a < 20.0f; a += 0.1f) {
    for (float b = 0.0f; b < 10.0f; b += 0.1f)
      points.emplace_back(a, b, 0.0f);
    for (float h = 0.0f; h < 3.0f; h += 0.1f) {
      points.emplace_back(a, 0.0f, h);
      points.emplace_back(a, 10.0f, h);
    }
  }
  TargetGrid grid;
  std::string error;
  ASSERT_TRUE(buildTargetGrid(points, 0.5, Feature::VarianceZ, {16, 0.25}, grid, error))
      << error;
  const Eigen::Vector3i& dims = grid.geometry.dims;
  const std::size_t rows = static_cast<std::size_t>(dims.y()) * dims.z();
  ASSERT_EQ(grid.row_starts.size(), rows + 1);
  EXPECT_EQ(grid.row_starts.front(), 0u);
  EXPECT_EQ(grid.row_starts.back(), grid.occupied.size());
  std::size_t seen = 0;
  for (std::size_t row = 0; row < rows; ++row)
    for (std::uint32_t k = grid.row_starts[row]; k < grid.row_starts[row + 1]; ++k, ++seen)
      ASSERT_EQ(static_cast<std::size_t>(grid.occupied[k].iz) * dims.y() + grid.occupied[k].iy,
                row);
  EXPECT_EQ(seen, grid.occupied.size());
}

/** Voxels (v, 0, 0) for v = 0..7 holding (v + 1) * density points each. */
static PointList
countRamp(int density)
{
  PointList points;
  for (int v = 0; v < 8; ++v)
    for (int k = 0; k < (v + 1) * density; ++k)
      points.emplace_back(v + 0.5f, 0.5f, 0.05f + 0.9f * k / ((v + 1) * density));
  return points;
}

TEST(TargetGrid, RangeQuantileTakesTheRangeFromTheTargetsOwnVoxels)
{
  // Counts 1..8: the upper quartile (index 0.75 * 7 -> 5 of the sorted counts) is 6.
  TargetGrid grid;
  std::string error;
  ASSERT_TRUE(
      buildTargetGrid(countRamp(1), 1.0, Feature::PointCount, {16, 64.0, 0.75}, grid, error))
      << error;
  EXPECT_DOUBLE_EQ(grid.binning.max_value, 6.0);
  EXPECT_EQ(grid.bins[grid.geometry.cellIndex(0, 0, 0)], 1 + 16 * 1 / 6); // 1 point
  EXPECT_EQ(grid.bins[grid.geometry.cellIndex(7, 0, 0)], 16);             // beyond the range
  // The fixed range ignores the data.
  ASSERT_TRUE(
      buildTargetGrid(countRamp(1), 1.0, Feature::PointCount, {16, 64.0, 0.0}, grid, error));
  EXPECT_DOUBLE_EQ(grid.binning.max_value, 64.0);
}

TEST(TargetGrid, RangeQuantileMakesPointCountBinsIndependentOfSensorDensity)
{
  // The same scene seen by a scanner 4x as dense: with the adaptive range every voxel
  // keeps its bin; with the paper's fixed range the sparse scan crowds into the low bins.
  auto bins = [](int density, double quantile) {
    TargetGrid grid;
    std::string error;
    EXPECT_TRUE(buildTargetGrid(countRamp(density), 1.0, Feature::PointCount,
                                {16, 64.0, quantile}, grid, error));
    std::vector<int> out;
    for (const auto& v : grid.occupied)
      out.push_back(v.bin);
    return out;
  };
  EXPECT_EQ(bins(1, 0.75), bins(4, 0.75));
  EXPECT_NE(bins(1, 0.0), bins(4, 0.0));
}

TEST(Parameters, PointCountRangeAdaptsByDefaultAndIsFixedInThePaperPreset)
{
  EXPECT_DOUBLE_EQ(Parameters().grid.point_count_binning.range_quantile, 0.75);
  EXPECT_DOUBLE_EQ(Parameters().grid.variance_z_binning.range_quantile, 0.0);
  EXPECT_DOUBLE_EQ(Parameters::paper().grid.point_count_binning.range_quantile, 0.0);
  EXPECT_EQ(Parameters().search.narrow_view_position_starts, 8);
  EXPECT_EQ(Parameters::paper().search.narrow_view_position_starts, 0);
  Parameters p;
  p.grid.point_count_binning.range_quantile = 1.5;
  EXPECT_NE(p.validate().find("quantile"), std::string::npos);
  p.grid.point_count_binning.range_quantile = std::nan("");
  EXPECT_NE(p.validate().find("quantile"), std::string::npos);
}

TEST(TargetGrid, RefusesGridsBeyondTheCap)
{
  PointList points{{0.0f, 0.0f, 0.0f}, {4000.0f, 4000.0f, 2000.0f}};
  TargetGrid grid;
  std::string error;
  EXPECT_FALSE(buildTargetGrid(points, 1.0, Feature::VarianceZ, {16, 1.0 / 12}, grid, error));
  EXPECT_NE(error.find("voxels"), std::string::npos);
}

TEST(CpuBackend, JointHistogramOfIdenticalAndShiftedClouds)
{
  // Target: a 4 x 1 x 1 row of voxels holding 1, 2, 3 and 4 points.
  PointList target;
  for (int v = 0; v < 4; ++v)
    for (int k = 0; k <= v; ++k)
      target.emplace_back(v + 0.5f, 0.5f, 0.1f + 0.2f * k);
  auto grid = std::make_shared<TargetGrid>();
  std::string error;
  ASSERT_TRUE(buildTargetGrid(target, 1.0, Feature::PointCount, {4, 5.0}, *grid, error));
  auto backend = backend::makeCpuBackend();
  backend->setTarget(grid);
  backend->setSource(std::make_shared<const SourceSamples>(makeSourceSamples(target, 0.0)));

  // Identity: every voxel agrees, histogram is diagonal with one count per bin 1..4.
  JointHistogram h;
  backend->jointHistogram(Eigen::Matrix3f::Identity(), Eigen::Vector3f::Zero(), h);
  EXPECT_EQ(h.num_bins, 5);
  EXPECT_EQ(h.overlap_voxels, 4u);
  for (int b = 1; b <= 4; ++b)
    EXPECT_EQ(h.at(b, b), 1u) << b;
  EXPECT_EQ(h.at(0, 0), 0u);

  // Shift the source by +1 voxel in x: overlap is voxels 1..3 (the source box starts at 1),
  // target bins 2, 3, 4 meet source bins 1, 2, 3.
  backend->jointHistogram(Eigen::Matrix3f::Identity(), Eigen::Vector3f(1, 0, 0), h);
  EXPECT_EQ(h.overlap_voxels, 3u);
  EXPECT_EQ(h.at(2, 1), 1u);
  EXPECT_EQ(h.at(3, 2), 1u);
  EXPECT_EQ(h.at(4, 3), 1u);

  // Far away: no overlap.
  backend->jointHistogram(Eigen::Matrix3f::Identity(), Eigen::Vector3f(100, 0, 0), h);
  EXPECT_EQ(h.overlap_voxels, 0u);
}

TEST(CpuBackend, EmptyVoxelsInsideTheOverlapAreCounted)
{
  // Target occupies voxels (0,0,0) and (3,0,0); the overlap spans 4 voxels, two of which
  // are empty in both clouds and must land in bin (0, 0).
  PointList target{{0.5f, 0.5f, 0.5f}, {3.5f, 0.5f, 0.5f}};
  auto grid = std::make_shared<TargetGrid>();
  std::string error;
  ASSERT_TRUE(buildTargetGrid(target, 1.0, Feature::PointCount, {1, 1.0}, *grid, error));
  auto backend = backend::makeCpuBackend();
  backend->setTarget(grid);
  PointList source{{0.5f, 0.5f, 0.5f}, {2.5f, 0.5f, 0.5f}, {3.5f, 0.5f, 0.5f}};
  backend->setSource(std::make_shared<const SourceSamples>(makeSourceSamples(source, 0.0)));
  JointHistogram h;
  backend->jointHistogram(Eigen::Matrix3f::Identity(), Eigen::Vector3f::Zero(), h);
  EXPECT_EQ(h.overlap_voxels, 4u);
  EXPECT_EQ(h.at(1, 1), 2u); // voxels 0 and 3
  EXPECT_EQ(h.at(0, 1), 1u); // voxel 2: source only
  EXPECT_EQ(h.at(0, 0), 1u); // voxel 1: empty in both
}

TEST(SourceSamples, SummariseCellsByCountCentroidAndCovariance)
{
  // Two cells of edge 1: three points in the first, one in the second.
  PointList points{{0.2f, 0.2f, 0.2f}, {0.4f, 0.2f, 0.6f}, {0.6f, 0.2f, 0.4f}, {1.5f, 0.5f, 0.5f}};
  const SourceSamples s = makeSourceSamples(points, 1.0);
  ASSERT_EQ(s.samples.size(), 2u);
  EXPECT_EQ(s.point_count, 4u);
  EXPECT_TRUE(s.has_covariance);
  const SourceSample& a = s.samples[0];
  EXPECT_EQ(a.count, 3u);
  EXPECT_TRUE(a.position.isApprox(Eigen::Vector3f(0.4f, 0.2f, 0.4f), 1e-6f));
  // x: 0.2, 0.4, 0.6 -> var 0.08/3; z: 0.2, 0.6, 0.4 -> var 0.08/3; cov(x, z) = 0.04/3.
  EXPECT_NEAR(a.covariance[0], 0.08 / 3, 1e-6);
  EXPECT_NEAR(a.covariance[5], 0.08 / 3, 1e-6);
  EXPECT_NEAR(a.covariance[2], 0.04 / 3, 1e-6);
  EXPECT_NEAR(a.covariance[3], 0.0, 1e-6); // y is constant
  EXPECT_EQ(s.samples[1].count, 1u);

  const SourceSamples exact = makeSourceSamples(points, 0.0);
  EXPECT_EQ(exact.samples.size(), 4u);
  EXPECT_FALSE(exact.has_covariance);
}

TEST(SourceSamples, EachSummaryHoldsTheSamePointsAsItsCell)
{
  // A real scan (its local cloud) in cubes of 0.35 m, counted point by point with floor()
  // of cellCoordinates() against the summaries, which compute the cells four points at a
  // time: the same cells, the same counts, listed in the order of z, then y, then x.
  const PointList points = makeLocalCloud(test_data::pointList(*test_data::loadScan("00", 0)),
                                          64.0)
                               .points;
  const double cell = 0.35;
  const SourceSamples s = makeSourceSamples(points, cell);
  const auto cellOf = [&](const Eigen::Vector3f& p) {
    const Eigen::Vector3f c =
        cellCoordinates(p, s.grid_origin, static_cast<float>(1.0 / cell)).array().floor();
    return std::array<long, 3>{static_cast<long>(c.z()), static_cast<long>(c.y()),
                               static_cast<long>(c.x())};
  };
  std::map<std::array<long, 3>, std::uint32_t> counted;
  for (const auto& p : points)
    ++counted[cellOf(p)];
  ASSERT_EQ(s.samples.size(), counted.size());
  auto expected = counted.begin();
  for (const SourceSample& sample : s.samples) {
    EXPECT_EQ(cellOf(sample.position), expected->first);
    EXPECT_EQ(sample.count, expected->second);
    ++expected;
  }
}

namespace {

/** True where \a a and \a b hold the same samples, to the bit. */
bool
sameSamples(const SourceSamples& a, const SourceSamples& b)
{
  if (a.samples.size() != b.samples.size() || a.has_covariance != b.has_covariance ||
      a.cell_size != b.cell_size || a.grid_origin != b.grid_origin)
    return false;
  for (std::size_t i = 0; i < a.samples.size(); ++i) {
    const SourceSample &x = a.samples[i], &y = b.samples[i];
    if (x.count != y.count || std::memcmp(x.position.data(), y.position.data(), 12) != 0 ||
        std::memcmp(x.covariance, y.covariance, sizeof x.covariance) != 0)
      return false;
  }
  return true;
}

} // namespace

TEST(SourceSamples, APyramidOnTwoThreadsIsTheSameToTheBit)
{
  // Two threads split the finest cells at a key near the median: a real scan, and a cloud
  // whose points all lie in one cell (the split's first side then holds nothing).
  const PointList scan = makeLocalCloud(test_data::pointList(*test_data::loadScan("00", 0)),
                                        64.0)
                             .points;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> within(0.01f, 0.09f);
  const PointList one_cell = [&] {
    PointList points(20000);
    for (auto& p : points)
      p = Eigen::Vector3f(within(rng), within(rng), within(rng));
    return points;
  }();
  for (const PointList* points : {&scan, &one_cell}) {
    const auto one = makeSourceSamplePyramid(*points, 0.5, 2, 1);
    const auto two = makeSourceSamplePyramid(*points, 0.5, 2, 2);
    ASSERT_EQ(one.size(), two.size());
    for (std::size_t level = 0; level < one.size(); ++level)
      EXPECT_TRUE(sameSamples(one[level], two[level])) << "level " << level;
  }
  EXPECT_GT(makeSourceSamplePyramid(scan, 0.5, 2, 2).front().samples.size(), 1000u);
}

TEST(SourceSamples, MatchPerPointEvaluationWhenCellsSitInsideVoxels)
{
  // Points on a 0.1 m lattice inside 2 m voxels, summarised into 0.5 m cells that nest in
  // the voxels: the point counts agree exactly, the z variances to the quantisation.
  PointList points;
  for (int i = 0; i < 40; ++i)
    for (int k = 0; k < 20; ++k)
      if ((i * 7 + k * 3) % 5)
        points.emplace_back(0.05f + 0.1f * i, 0.3f, 0.05f + 0.1f * k);
  auto grid = std::make_shared<TargetGrid>();
  std::string error;
  ASSERT_TRUE(buildTargetGrid(points, 2.0, Feature::PointCount, {64, 400.0}, *grid, error));
  JointHistogram per_point, sampled;
  auto backend = backend::makeCpuBackend();
  backend->setTarget(grid);
  backend->setSource(std::make_shared<const SourceSamples>(makeSourceSamples(points, 0.0)));
  backend->jointHistogram(Eigen::Matrix3f::Identity(), Eigen::Vector3f::Zero(), per_point);
  backend->setSource(std::make_shared<const SourceSamples>(makeSourceSamples(points, 0.5)));
  backend->jointHistogram(Eigen::Matrix3f::Identity(), Eigen::Vector3f::Zero(), sampled);
  EXPECT_EQ(per_point.counts, sampled.counts);

  // VarianceZ of one voxel: from points and from their cell summaries.
  VoxelMoments from_points, from_cells;
  for (const auto& p : points)
    if (p.x() < 2.0f && p.z() < 2.0f)
      from_points.add(quantiseHeight(p.z() / 2.0f, 0));
  for (const auto& s : makeSourceSamples(points, 0.5).samples)
    if (s.position.x() < 2.0f && s.position.z() < 2.0f)
      from_cells.add(quantiseHeight(s.position.z() / 2.0f, 0), s.count,
                     static_cast<std::uint32_t>(s.covariance[5] / 4.0f * 65536.0f + 0.5f));
  EXPECT_EQ(from_points.count, from_cells.count);
  EXPECT_NEAR(featureValue(Feature::VarianceZ, from_points),
              featureValue(Feature::VarianceZ, from_cells), 2e-3);
}

namespace {

/** A box-shaped room (10 x 6 x 3 m: floor, ceiling, four walls) sampled every 5 cm, or only
 * its walls, turned by \a turn. */
PointList
turnedRoom(const Eigen::Matrix3f& turn, bool floor_and_ceiling)
{
  PointList points;
  const float step = 0.05f;
  for (float a = 0.0f; a <= 10.0f; a += step)
    for (float b = 0.0f; b <= 6.0f; b += step)
      if (floor_and_ceiling) {
        points.push_back(turn * Eigen::Vector3f(a, b, 0.0f));
        points.push_back(turn * Eigen::Vector3f(a, b, 3.0f));
      }
  for (float h = 0.0f; h <= 3.0f; h += step) {
    for (float a = 0.0f; a <= 10.0f; a += step) {
      points.push_back(turn * Eigen::Vector3f(a, 0.0f, h));
      points.push_back(turn * Eigen::Vector3f(a, 6.0f, h));
    }
    for (float b = 0.0f; b <= 6.0f; b += step) {
      points.push_back(turn * Eigen::Vector3f(0.0f, b, h));
      points.push_back(turn * Eigen::Vector3f(10.0f, b, h));
    }
  }
  return points;
}

} // namespace

TEST(UpDirection, FindsTheFloorOfATiltedRoomAndNotItsWalls)
{
  // Up to 65 deg of tilt: a sensor mounted pitched steeply sees its ground 65 deg off its z,
  // and walls that its tilt brings nearer its z than the floor.
  for (const auto& [roll, pitch] :
       {std::make_pair(0.0f, 0.0f), std::make_pair(30.0f, -20.0f), std::make_pair(-40.0f, 25.0f),
        std::make_pair(0.0f, 65.0f), std::make_pair(-45.0f, 40.0f)}) {
    SCOPED_TRACE(testing::Message() << "roll " << roll << ", pitch " << pitch);
    const Eigen::Matrix3f turn =
        (Eigen::AngleAxisf(pitch * static_cast<float>(M_PI) / 180.0f, Eigen::Vector3f::UnitY()) *
         Eigen::AngleAxisf(roll * static_cast<float>(M_PI) / 180.0f, Eigen::Vector3f::UnitX()))
            .toRotationMatrix();
    const std::optional<Eigen::Vector3d> up =
        estimateUpDirection(makeSourceSamples(turnedRoom(turn, true), 0.25));
    ASSERT_TRUE(up.has_value());
    const Eigen::Vector3d expected = (turn * Eigen::Vector3f::UnitZ()).cast<double>();
    EXPECT_LT(std::acos(std::min(1.0, up->dot(expected))) * 180.0 / M_PI, 1.0);
  }
  // Walls alone, level: their normals lie 90 deg from up, outside the cone looked in.
  EXPECT_FALSE(
      estimateUpDirection(makeSourceSamples(turnedRoom(Eigen::Matrix3f::Identity(), false), 0.25))
          .has_value());
  // Single points carry no normal.
  EXPECT_FALSE(estimateUpDirection(makeSourceSamples(turnedRoom(Eigen::Matrix3f::Identity(), true),
                                                     0.0))
                   .has_value());
}

TEST(UpDirection, TheSameOnTwoThreads)
{
  // The cells' normals split over two threads and joined in the cells' order: a real scan's
  // up direction is the same to the bit.
  const PointList scan = makeLocalCloud(test_data::pointList(*test_data::loadScan("00", 0)),
                                        64.0)
                             .points;
  const SourceSamples cells = makeSourceSamples(scan, 0.5);
  const std::optional<Eigen::Vector3d> one = estimateUpDirection(cells, 1);
  const std::optional<Eigen::Vector3d> two = estimateUpDirection(cells, 2);
  ASSERT_TRUE(one.has_value());
  ASSERT_TRUE(two.has_value());
  EXPECT_EQ(std::memcmp(one->data(), two->data(), sizeof(double) * 3), 0);
  EXPECT_GT(one->z(), 0.99);
}

TEST(BoundingBox, PackedPointsGiveTheScalarLoopsBox)
{
  // Every count up to a few vectors (each tail of the vector loop), with the extremes at
  // the first point, the last point and in between.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> value(-50.0f, 50.0f);
  for (std::size_t count = 1; count <= 19; ++count)
    for (std::size_t extreme = 0; extreme < count; ++extreme) {
      PointList points(count);
      for (auto& p : points)
        p = Eigen::Vector3f(value(rng), value(rng), value(rng));
      points[extreme] = Eigen::Vector3f(-100.0f, 100.0f, -100.0f - extreme);
      Eigen::Vector3f min, max;
      boundingBox(points, min, max);
      Eigen::Vector3f expected_min = points[0], expected_max = points[0];
      for (const Eigen::Vector3f& p : points) {
        expected_min = expected_min.cwiseMin(p);
        expected_max = expected_max.cwiseMax(p);
      }
      EXPECT_EQ(min, expected_min) << count << " points, extreme at " << extreme;
      EXPECT_EQ(max, expected_max) << count << " points, extreme at " << extreme;
      EXPECT_EQ(min.x(), -100.0f);
      EXPECT_EQ(max.y(), 100.0f);
    }
}
