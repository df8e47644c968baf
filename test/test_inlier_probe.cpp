/*
 * The verdict's inlier probe on a real scan: how far a move carries the probed samples, and
 * how much of the evidence it costs.
 */
#include "test_data.h"

#include "features/local_cloud.h"
#include "features/source_samples.h"
#include "refine/refinement.h"
#include "verify/inlier_probe.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>

using namespace pcl_mi;
using namespace pcl_mi::core;

namespace {

/** The bundled KITTI scan 0 of sequence 00 in its local frame, as the engine holds it. */
PointList
bundledScan()
{
  return makeLocalCloud(test_data::pointList(*test_data::loadScan("00", 0)), 64.0).points;
}

} // namespace

// On 2 m samples (fewer than the probe's cap, so it looks at every one), the probe's
// measure of a move from its moments is the mean of the samples' own first-order moves,
// however the result and the move turn them.
TEST(InlierProbe, MeasuresAMoveByTheSamplesItCarries)
{
  const PointList points = bundledScan();
  const TargetDistributions target(points, 0.7, 4, 0.05);
  const SourceSamples source = makeSourceSamples(points, 2.0);
  ASSERT_GT(source.samples.size(), 100u);
  ASSERT_LT(source.samples.size(), 4096u);
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.1, -0.2, 1.0).normalized()).toRotationMatrix();
  const Eigen::Vector3d translation(4.0, -2.5, 0.3);
  const InlierProbe probe(target, source, rotation, translation);
  const Eigen::Vector3d omega_a(0.01, -0.02, 0.03), delta_a(0.2, 0.1, -0.05);
  const Eigen::Vector3d omega_b(-0.015, 0.005, 0.02), delta_b(-0.1, 0.3, 0.02);
  double product = 0.0, squared = 0.0;
  for (const SourceSample& s : source.samples) {
    const Eigen::Vector3d q = rotation * s.position.cast<double>() + translation;
    const Eigen::Vector3d move_a = omega_a.cross(q) + delta_a;
    product += move_a.dot(omega_b.cross(q) + delta_b);
    squared += move_a.squaredNorm();
  }
  const double n = static_cast<double>(source.samples.size());
  EXPECT_NEAR(probe.meanMoveProduct(omega_a, delta_a, omega_b, delta_b), product / n,
              1e-9 * squared / n);
  EXPECT_NEAR(probe.rmsShift(omega_a, delta_a), std::sqrt(squared / n), 1e-9);
}

// At the result nothing is lost; a move off the surfaces loses more the farther it goes,
// and a move along the ground keeps the ground's inliers that a move up loses.
TEST(InlierProbe, LosesTheInliersAMoveCarriesOffTheSurfaces)
{
  const PointList points = bundledScan();
  const TargetDistributions target(points, 0.7, 4, 0.05);
  const SourceSamples source = makeSourceSamples(points, 0.5);
  const InlierProbe probe(target, source, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  const Eigen::Vector3d none = Eigen::Vector3d::Zero();
  EXPECT_EQ(probe.lostEitherWay(none, none), 0.0);
  EXPECT_EQ(probe.lostTurningEitherWay(2, 0.0), 0.0);
  const double up_a_little = probe.lostEitherWay(none, Eigen::Vector3d(0, 0, 0.1));
  const double up_a_voxel = probe.lostEitherWay(none, Eigen::Vector3d(0, 0, 1.0));
  EXPECT_GT(up_a_little, 0.0);
  EXPECT_GT(up_a_voxel, up_a_little);
  EXPECT_GT(up_a_voxel, 0.5);
  EXPECT_LT(probe.lostTurningEitherWay(2, 0.001), probe.lostTurningEitherWay(2, 0.05));
  // Along the ground only the surfaces that the move crosses count: a move up crosses the
  // ground, which most samples lie on, a move along x mostly does not.
  const double across_up = probe.lostAcrossEitherWay(none, Eigen::Vector3d(0, 0, 1.0));
  const double across_x = probe.lostAcrossEitherWay(none, Eigen::Vector3d(1.0, 0, 0));
  EXPECT_LT(across_x, probe.lostEitherWay(none, Eigen::Vector3d(1.0, 0, 0)));
  EXPECT_GT(across_up, across_x);
}
