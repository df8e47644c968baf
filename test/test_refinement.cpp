/*
 * The source-sample pyramid and the point-to-distribution refinement on a real scan.
 */
#include "refine/refinement.h"
#include "features/source_samples.h"
#include "features/up_direction.h"
#include "features/local_cloud.h"
#include "verify/confidence_model.h"
#include "verify/pose_evidence.h"
#include "verify/verification.h"

#include <pcl_mi/io.h>
#include <pcl_mi/kitti.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

using namespace pcl_mi;
using namespace pcl_mi::core;

namespace {

PointList
scanPoints(const std::string& sequence, int frame)
{
  pcl::PointCloud<pcl::PointXYZI> cloud;
  EXPECT_EQ(
      io::loadCloud(kitti::scanPath(std::string(PCL_MI_DATA_DIR) + "/kitti", sequence, frame),
                    cloud),
      "");
  PointList points;
  for (const auto& p : cloud)
    points.emplace_back(p.x, p.y, p.z);
  return points;
}

PointList
bundledScan()
{
  return makeLocalCloud(scanPoints("00", 0), 64.0).points;
}

} // namespace

TEST(SourceSamplePyramid, MergedLevelsMatchDirectSummaries)
{
  const PointList points = bundledScan();
  const auto pyramid = makeSourceSamplePyramid(points, 0.25, 2);
  ASSERT_EQ(pyramid.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    SCOPED_TRACE(k);
    const SourceSamples direct = makeSourceSamples(points, 0.25 * (1 << k));
    const SourceSamples& merged = pyramid[static_cast<std::size_t>(k)];
    EXPECT_DOUBLE_EQ(merged.cell_size, direct.cell_size);
    // Both are sorted by the same cell key; a centroid rounding across a cell border can
    // split or join a cell, which is rare.
    ASSERT_NEAR(static_cast<double>(merged.samples.size()),
                static_cast<double>(direct.samples.size()), 0.002 * direct.samples.size());
    std::size_t same = 0, total = 0;
    Eigen::Vector3d sum_merged = Eigen::Vector3d::Zero(), sum_direct = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < merged.samples.size(); ++i) {
      total += merged.samples[i].count;
      sum_merged += merged.samples[i].count * merged.samples[i].position.cast<double>();
    }
    for (const auto& s : direct.samples)
      sum_direct += s.count * s.position.cast<double>();
    EXPECT_EQ(total, points.size());
    EXPECT_LT((sum_merged - sum_direct).norm() / points.size(), 1e-5);
    for (std::size_t i = 0; i < std::min(merged.samples.size(), direct.samples.size()); ++i) {
      const SourceSample& a = merged.samples[i];
      const SourceSample& b = direct.samples[i];
      if (a.count != b.count || (a.position - b.position).norm() > 1e-4f)
        continue;
      ++same;
      for (int c = 0; c < 6; ++c)
        EXPECT_NEAR(a.covariance[c], b.covariance[c], 1e-4);
    }
    EXPECT_GT(same, direct.samples.size() * 95 / 100);
  }
}

TEST(Refinement, NormalEquationsByBlocksEqualTheDenseProducts)
{
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Vector3f q(20.0f * u(rng), 20.0f * u(rng), 3.0f * u(rng));
    const Eigen::Vector3f e(u(rng), u(rng), u(rng));
    Eigen::Matrix3f m;
    for (int i = 0; i < 9; ++i)
      m(i / 3, i % 3) = u(rng);
    const Eigen::Matrix3f information = m * m.transpose() + 0.1f * Eigen::Matrix3f::Identity();
    const float w = 0.5f + 0.5f * u(rng);
    // The residual's Jacobian for xi = [omega, delta]: [-[q]x, I].
    Eigen::Matrix<float, 3, 6> j;
    j << 0.0f, q.z(), -q.y(), 1.0f, 0.0f, 0.0f, //
        -q.z(), 0.0f, q.x(), 0.0f, 1.0f, 0.0f,  //
        q.y(), -q.x(), 0.0f, 0.0f, 0.0f, 1.0f;
    const Eigen::Matrix<float, 6, 6> dense_h = w * j.transpose() * information * j;
    const Eigen::Matrix<float, 6, 1> dense_g = w * j.transpose() * information * e;
    Eigen::Matrix<float, 6, 6> h = Eigen::Matrix<float, 6, 6>::Zero();
    Eigen::Matrix<float, 6, 1> g = Eigen::Matrix<float, 6, 1>::Zero();
    pcl_mi::core::addToNormalEquations(q, e, information, w, h, g);
    h.bottomLeftCorner<3, 3>() = h.topRightCorner<3, 3>().transpose();
    const float scale = dense_h.cwiseAbs().maxCoeff();
    EXPECT_LT((h - dense_h).cwiseAbs().maxCoeff(), 1e-5f * scale) << "trial " << trial;
    EXPECT_LT((g - dense_g).cwiseAbs().maxCoeff(), 1e-5f * dense_g.cwiseAbs().maxCoeff() + 1e-6f)
        << "trial " << trial;
  }
}

TEST(Refinement, RecoversAKnownOffsetOfARealScan)
{
  const PointList points = bundledScan();
  const TargetDistributions target(points, 0.5, 4, 0.05);
  ASSERT_GT(target.size(), 1000u);
  const SourceSamples source = makeSourceSamples(points, 0.25);
  // Start 0.3 m and 1.5 degrees away from the truth (identity), roughly where the MI search
  // on the 2 m level ends.
  const Eigen::Matrix3d start_r =
      Eigen::AngleAxisd(1.5 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d start_t(0.25, -0.15, 0.05);
  RefinementOptions options;
  options.num_threads = 2;
  const RefinementResult r = refineToDistributions(target, source, start_r, start_t, options);
  EXPECT_GT(r.correspondences, source.samples.size() / 2);
  EXPECT_LT(r.translation.norm(), 0.02);
  EXPECT_LT(Eigen::AngleAxisd(r.rotation).angle() * 180.0 / M_PI, 0.1);
  EXPECT_TRUE(r.converged);

  // The same with one thread: bit-identical.
  options.num_threads = 1;
  const RefinementResult serial = refineToDistributions(target, source, start_r, start_t, options);
  EXPECT_EQ(serial.rotation, r.rotation);
  EXPECT_EQ(serial.translation, r.translation);
  EXPECT_EQ(serial.iterations, r.iterations);
}

TEST(Refinement, ExtrapolationConvergesSoonerToTheSamePose)
{
  // Two different scans, 9.1 m apart (sensor frames): plain Gauss-Newton steps land short
  // and shrink slowly here, which the extrapolation of the step series cures.
  const TargetDistributions target(scanPoints("02", 0), 0.7, 4, 0.05);
  const SourceSamples source = makeSourceSamples(scanPoints("02", 6), 0.5);
  Eigen::Matrix4d reference;
  ASSERT_EQ(io::loadTransform(std::string(PCL_MI_DATA_DIR) +
                                  "/kitti/reference_02_000006_to_000000.txt",
                              reference),
            "");
  const Eigen::Matrix3d start_r =
      Eigen::AngleAxisd(1.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
      reference.topLeftCorner<3, 3>();
  const Eigen::Vector3d start_t =
      reference.topRightCorner<3, 1>() + Eigen::Vector3d(0.3, -0.2, 0.05);
  RefinementOptions options;
  options.num_threads = 2;
  options.max_iterations = 100;
  const RefinementResult fast = refineToDistributions(target, source, start_r, start_t, options);
  options.extrapolate = false;
  const RefinementResult plain = refineToDistributions(target, source, start_r, start_t, options);
  ASSERT_TRUE(fast.converged);
  ASSERT_TRUE(plain.converged);
  EXPECT_LT(fast.iterations * 3, plain.iterations * 2)
      << fast.iterations << " vs " << plain.iterations;
  EXPECT_LT((fast.translation - plain.translation).norm(), 0.005);
  EXPECT_LT(Eigen::AngleAxisd(fast.rotation * plain.rotation.transpose()).angle() * 180.0 / M_PI,
            0.02);
  // Both near the reference.
  EXPECT_LT((fast.translation - reference.topRightCorner<3, 1>()).norm(), 0.1);
}

TEST(Refinement, KeepsPinnedParameters)
{
  const PointList points = bundledScan();
  const TargetDistributions target(points, 0.5, 4, 0.05);
  const SourceSamples source = makeSourceSamples(points, 0.25);
  RefinementOptions options;
  options.active << true, true, false, false, false, true; // x, y, yaw
  const Eigen::Vector3d start_t(0.2, 0.1, 0.3);
  const RefinementResult r =
      refineToDistributions(target, source, Eigen::Matrix3d::Identity(), start_t, options);
  EXPECT_DOUBLE_EQ(r.translation.z(), 0.3);
  EXPECT_NEAR(r.rotation(2, 2), 1.0, 1e-12);
  EXPECT_LT(r.translation.head<2>().norm(), 0.05);
}

TEST(Refinement, EmptyTargetLeavesThePoseAlone)
{
  const TargetDistributions target(PointList{}, 0.5, 4, 0.05);
  EXPECT_EQ(target.find(Eigen::Vector3f::Zero()), -1);
  SourceSamples source = makeSourceSamples(PointList{{0, 0, 0}, {1, 0, 0}}, 0.25);
  const Eigen::Vector3d t(1, 2, 3);
  const RefinementResult r =
      refineToDistributions(target, source, Eigen::Matrix3d::Identity(), t, {});
  EXPECT_EQ(r.translation, t);
  EXPECT_EQ(r.iterations, 0);
}

TEST(TargetDistributions, HoldAcrossSurfacesAndLetSamplesSlideAlongThem)
{
  // Two scan lines crossing a tilted plane inside one 0.7 m cube: the raw covariance is
  // narrow across the lines within the plane, which would pull samples onto the lines.
  const Eigen::Vector3f normal = Eigen::Vector3f(0.1f, -0.2f, 1.0f).normalized();
  const Eigen::Vector3f u = normal.unitOrthogonal(), v = normal.cross(u);
  const Eigen::Vector3f centre(0.35f, 0.35f, 0.35f);
  PointList points;
  for (int line = 0; line < 2; ++line)
    for (int i = 0; i < 40; ++i)
      points.push_back(centre + (0.008f * static_cast<float>(i) - 0.16f) * u +
                       (line ? 0.05f : -0.05f) * v);
  const double cube = 0.7, noise = 0.05;
  const TargetDistributions target(points, cube, 4, noise);
  ASSERT_EQ(target.size(), 1u);
  const Eigen::Matrix3f& info = target[0].information;
  // Across the surface: held as tightly as the noise allows.
  EXPECT_NEAR(normal.dot(info * normal), 1.0 / (noise * noise), 0.05 / (noise * noise));
  // Along it, in both directions (also across the two lines): no tighter than a variance of
  // (cube / 2)^2 plus the noise.
  const double loosest = 1.0 / (0.25 * cube * cube + noise * noise);
  EXPECT_NEAR(u.dot(info * u), loosest, 0.01 * loosest);
  EXPECT_NEAR(v.dot(info * v), loosest, 0.01 * loosest);
}

TEST(TargetDistributions, TakeTheSurfaceOfStripsFromTheirNeighbourhood)
{
  // Flat ground seen by four laser rings 2 deg apart (a 16-beam sensor 1.7 m above it): each
  // 0.7 m cube holds a piece of one ring, spread along it and, by the range noise, along the
  // beam. A plane fitted to that strip is the laser's cone, tilted by the beam's elevation
  // (13-19 deg) from the ground, and it moves with the sensor; the cube's 3x3x3 neighbourhood
  // spans two or three rings and gives the ground itself.
  const double height = 1.7;
  std::mt19937 random(7);
  std::normal_distribution<double> range_noise(0.0, 0.02);
  PointList points;
  for (const double elevation_deg : {-13.0, -15.0, -17.0, -19.0}) {
    const double elevation = elevation_deg * M_PI / 180.0;
    const double range = height / std::sin(-elevation);
    for (int step = 0; step < 1800; ++step) {
      const double azimuth = step * 2.0 * M_PI / 1800.0;
      const Eigen::Vector3d beam(std::cos(elevation) * std::cos(azimuth),
                                 std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
      points.push_back(((range + range_noise(random)) * beam).cast<float>());
    }
  }
  const TargetDistributions target(points, 0.7, 4, 0.05);
  ASSERT_GT(target.size(), 100u);

  // The direction each distribution holds most tightly, against the ground's normal (z).
  std::vector<double> tilt_deg;
  for (std::size_t i = 0; i < target.size(); ++i) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> solver(target[static_cast<int>(i)].information);
    const Eigen::Vector3f held = solver.eigenvectors().col(2);
    tilt_deg.push_back(std::acos(std::min(1.0f, std::abs(held.z()))) * 180.0 / M_PI);
  }
  std::sort(tilt_deg.begin(), tilt_deg.end());
  const double median = tilt_deg[tilt_deg.size() / 2];
  const double share_within_3deg =
      static_cast<double>(std::lower_bound(tilt_deg.begin(), tilt_deg.end(), 3.0) -
                          tilt_deg.begin()) /
      static_cast<double>(tilt_deg.size());
  EXPECT_LT(median, 2.0);
  EXPECT_GT(share_within_3deg, 0.8);

  // The premise: the cubes' own points alone give the cone, not the ground.
  const SourceSamples cubes = makeSourceSamples(points, 0.7);
  std::vector<double> own_tilt_deg;
  for (const SourceSample& s : cubes.samples) {
    if (s.count < 4)
      continue;
    Eigen::Matrix3f c;
    c << s.covariance[0], s.covariance[1], s.covariance[2], s.covariance[1], s.covariance[3],
        s.covariance[4], s.covariance[2], s.covariance[4], s.covariance[5];
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> solver(c);
    own_tilt_deg.push_back(
        std::acos(std::min(1.0f, std::abs(solver.eigenvectors().col(0).z()))) * 180.0 / M_PI);
  }
  std::sort(own_tilt_deg.begin(), own_tilt_deg.end());
  EXPECT_GT(own_tilt_deg[own_tilt_deg.size() / 2], 8.0);
}

// The verification works in the target local frame and reports in the input frame: the same
// local evidence under turned target axes gives the covariance and the observability
// directions turned alike ([t, omega] both turn), and the same confidence.
TEST(Verification, TargetAxesTurnTheReportedCovarianceAndDirections)
{
  const PointList points = bundledScan();
  const TargetDistributions target(points, 0.7, 4, 0.05);
  const SourceSamples source = makeSourceSamples(points, 0.5);
  const JointHistogram histogram;
  const Eigen::Matrix3d axes =
      (Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  const Eigen::Vector3d shift(0.2, -0.1, 0.05);
  const Verification level = verifyPose(target, source, Eigen::Matrix3d::Identity(), shift, 1.0,
                                        histogram, Eigen::Vector3d::Zero(),
                                        Eigen::Matrix3d::Identity(), SensorPlacement::kApart);
  const Verification turned = verifyPose(target, source, Eigen::Matrix3d::Identity(), shift, 1.0,
                                         histogram, Eigen::Vector3d::Zero(), axes,
                                         SensorPlacement::kApart);
  ASSERT_GT(level.covariance.norm(), 0.0);
  Eigen::Matrix<double, 6, 6> turn = Eigen::Matrix<double, 6, 6>::Zero();
  turn.topLeftCorner<3, 3>() = turn.bottomRightCorner<3, 3>() = axes;
  EXPECT_TRUE(turned.covariance.isApprox(turn * level.covariance * turn.transpose(), 1e-9));
  EXPECT_TRUE(turned.observability_directions.isApprox(turn * level.observability_directions, 1e-9));
  EXPECT_TRUE(turned.information.isApprox(turn * level.information * turn.transpose(), 1e-9));
  EXPECT_EQ(turned.confidence, level.confidence);
}

// The information is the inverse of the covariance but for the refinement's last step, whose
// outer product the covariance adds: their difference is one direction's, in any target frame.
// Its directions are reported about the target's centroid, turns at the stated radius.
TEST(Verification, TheInformationInvertsTheCovarianceButForTheLastStep)
{
  const PointList points = bundledScan();
  const TargetDistributions target(points, 0.7, 4, 0.05);
  const SourceSamples source = makeSourceSamples(points, 0.5);
  const Eigen::Matrix3d axes =
      (Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  const Eigen::Vector3d centroid(12.0, -7.0, 1.5);
  const Verification v = verifyPose(target, source, Eigen::Matrix3d::Identity(),
                                    Eigen::Vector3d(0.2, -0.1, 0.05), 1.0, JointHistogram(),
                                    centroid, axes, SensorPlacement::kApart);
  ASSERT_GT(v.covariance.norm(), 0.0);
  const Eigen::Matrix<double, 6, 6> difference =
      v.covariance - Eigen::Matrix<double, 6, 6>(v.information).inverse();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> solver(difference);
  const double largest = std::abs(solver.eigenvalues()[5]);
  EXPECT_GT(solver.eigenvalues()[0], -1e-9 * v.covariance.norm());
  EXPECT_LT(solver.eigenvalues()[4], 1e-9 * v.covariance.norm() + 1e-6 * largest);
  EXPECT_TRUE(v.observability_centre.isApprox(centroid));
  double sum = 0.0;
  for (const SourceSample& sample : source.samples)
    sum += sample.position.squaredNorm();
  EXPECT_NEAR(v.observability_radius, std::max(std::sqrt(sum / source.samples.size()), 1.0),
              1e-9);
}

// The calibration of the confidence only moves logits below the verdict's threshold, never
// across it, and keeps their order: every verdict stays as the model gives it.
TEST(Verification, CalibrationKeepsTheOrderAndTheThreshold)
{
  using pcl_mi::core::calibratedLogit;
  const double threshold =
      std::log(pcl_mi::core::kReliableConfidence / (1.0 - pcl_mi::core::kReliableConfidence));
  double previous = calibratedLogit(-20.0);
  EXPECT_EQ(previous, -20.0);
  for (int i = 1; i <= 4000; ++i) {
    const double z = -20.0 + 0.01 * i;
    const double mapped = calibratedLogit(z);
    EXPECT_GT(mapped, previous) << "at z = " << z;
    EXPECT_EQ(mapped < threshold, z < threshold) << "at z = " << z;
    if (z >= threshold)
      EXPECT_EQ(mapped, z);
    previous = mapped;
  }
  // Continuous where it meets the identity.
  EXPECT_NEAR(calibratedLogit(std::nextafter(threshold, 0.0)), threshold, 1e-9);
}

// Evidence that passes with a lead fails with a negative one, whatever the confidence: another
// optimum a few voxels across scores higher, so the result is not the one place where the
// clouds agree. A 360-degree view has no lead (NaN) and is judged without it.
TEST(Verification, ANegativeLeadIsASecondOptimum)
{
  pcl_mi::Verification v;
  v.inliers = 5000;
  v.inlier_fraction = 0.9;
  v.normalized_mi = 0.3;
  v.peak_contrast = 0.5;
  v.weakest_contrast = 0.3;
  v.free_direction_contrast[0] = v.free_direction_contrast[1] = 0.2;
  pcl_mi::core::judge(v);
  EXPECT_EQ(v.reason, "");
  EXPECT_GE(v.confidence, pcl_mi::core::kReliableConfidence);
  v.lead = 0.3;
  pcl_mi::core::judge(v);
  EXPECT_EQ(v.reason, "");
  v.lead = -0.02;
  pcl_mi::core::judge(v);
  EXPECT_NE(v.reason.find("a second optimum"), std::string::npos) << v.reason;
  EXPECT_NE(v.reason.find("-2 %"), std::string::npos) << v.reason;
}

TEST(TargetDistributions, HandTheUpDirectionTheAxesItWouldFind)
{
  // The target's up direction takes the principal axes the distributions compute for every
  // cube: the same up to the bit as decomposing the cubes again, at 0.7 m (every cube looked
  // at) and at 0.2 m (every few cubes).
  const PointList points = bundledScan();
  for (const double cell : {0.7, 0.2}) {
    const SourceSamples cubes = makeSourceSamples(points, cell);
    UpDirectionFromAxes shared(cubes);
    std::size_t handed = 0;
    const TargetDistributions target(cubes, 4, 0.05, [&](std::size_t i, const auto& axes) {
      handed += shared.wanted(i);
      shared.look(i, axes);
    });
    const std::optional<Eigen::Vector3d> own = estimateUpDirection(cubes);
    const std::optional<Eigen::Vector3d> from_axes = shared.estimate();
    ASSERT_TRUE(own.has_value());
    ASSERT_TRUE(from_axes.has_value());
    EXPECT_EQ(std::memcmp(own->data(), from_axes->data(), sizeof(double) * 3), 0) << cell;
    EXPECT_GT(handed, 1000u);
  }
}

TEST(TargetDistributions, FindBlockGivesFindsAnswers)
{
  // The lookups of a real scan's cubes, block by block, against one at a time: points on
  // the scan, near it, far outside the table's reach and not finite, in blocks of 1, 22,
  // 43 and 64 (the largest).
  const PointList points = bundledScan();
  const TargetDistributions target(points, 0.7, 4, 0.05);
  ASSERT_GT(target.size(), 1000u);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> jitter(-1.0f, 1.0f);
  std::vector<Eigen::Vector3f> queries;
  for (std::size_t i = 0; i < points.size(); i += 97)
    queries.push_back(points[i] + Eigen::Vector3f(jitter(rng), jitter(rng), jitter(rng)));
  queries.push_back(Eigen::Vector3f::Constant(1e9f));
  queries.push_back(Eigen::Vector3f::Constant(-1e9f));
  queries.push_back(Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  std::size_t found = 0, passes = 0;
  constexpr std::size_t kMost = TargetDistributions::kFindBlock;
  std::int32_t indices[kMost];
  for (std::size_t length = 1; length <= kMost; length += 21, ++passes)
    for (std::size_t begin = 0; begin < queries.size(); begin += length) {
      const std::size_t count = std::min(length, queries.size() - begin);
      target.findBlock(&queries[begin], count, indices);
      for (std::size_t k = 0; k < count; ++k) {
        ASSERT_EQ(indices[k], target.find(queries[begin + k])) << "query " << begin + k;
        found += indices[k] >= 0;
      }
    }
  // Jittered by up to a metre, a good share still falls into a cube: hits and misses are
  // both compared.
  EXPECT_GT(found, passes * queries.size() / 4);
  EXPECT_LT(found, passes * queries.size());
}

TEST(TargetDistributions, StripsFindTheSameNeighboursInAnyOrderOfTheCubes)
{
  // A real scan's cubes as makeSourceSamples() lists them (in the order of their cells, where
  // the strips' neighbourhoods are read in sequence) and shuffled (where they are looked up
  // by hash): every cube's distribution and normal are the same to the bit.
  const SourceSamples listed = makeSourceSamples(bundledScan(), 0.7);
  SourceSamples shuffled = listed;
  std::mt19937 random(11);
  std::shuffle(shuffled.samples.begin(), shuffled.samples.end(), random);
  const TargetDistributions in_order(listed, 4, 0.05), in_any_order(shuffled, 4, 0.05);
  ASSERT_GT(in_order.size(), 1000u);
  ASSERT_EQ(in_any_order.size(), in_order.size());
  std::size_t compared = 0;
  for (std::size_t i = 0; i < in_order.size(); ++i) {
    const auto& a = in_order[static_cast<int>(i)];
    const int k = in_any_order.find(a.mean);
    ASSERT_GE(k, 0);
    const auto& b = in_any_order[k];
    ASSERT_EQ(b.mean, a.mean);
    EXPECT_EQ(b.information, a.information) << "cube " << i;
    EXPECT_EQ(b.normal, a.normal) << "cube " << i;
    ++compared;
  }
  EXPECT_EQ(compared, in_order.size());
}

TEST(TargetDistributions, SparseCubesPullTheRefinementButAreNoEvidence)
{
  // A floor of 0.7 m cubes, dense but for the centre cube, which holds two points: it takes
  // the floor's surface from its neighbours and pulls samples onto it, but a sample there
  // is not counted as evidence, which asks for cubes of kEvidenceMinimumPoints.
  PointList points;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (i != 1 || j != 1)
        for (int k = 0; k < 6; ++k)
          for (int l = 0; l < 6; ++l)
            points.emplace_back(0.7f * i + 0.05f + 0.1f * k, 0.7f * j + 0.05f + 0.1f * l,
                                0.35f);
  const Eigen::Vector3f sparse_point(1.0f, 1.0f, 0.35f);
  points.push_back(sparse_point);
  points.emplace_back(1.2f, 1.1f, 0.35f);

  const TargetDistributions dense_only(points, 0.7, 4, 0.05);
  EXPECT_EQ(dense_only.size(), 8u);
  EXPECT_LT(dense_only.find(sparse_point), 0);

  const TargetDistributions target(points, 0.7, 2, 0.05);
  ASSERT_EQ(target.size(), 9u);
  const int centre = target.find(sparse_point);
  ASSERT_GE(centre, 0);
  EXPECT_EQ(target[centre].points, 2u);
  EXPECT_GT(std::abs(target[centre].normal.z()), 0.99f);

  const PointList samples{Eigen::Vector3f(1.1f, 1.1f, 0.36f), Eigen::Vector3f(0.3f, 0.3f, 0.36f)};
  const SourceSamples source = makeSourceSamples(samples, 0.05);
  ASSERT_EQ(source.samples.size(), 2u);
  const PoseEvidence evidence = gatherPoseEvidence(target, source, Eigen::Matrix3d::Identity(),
                                                   Eigen::Vector3d::Zero());
  EXPECT_EQ(evidence.samples, 2u);
  EXPECT_EQ(evidence.matched, 1u);
  EXPECT_EQ(evidence.inliers, 1u);
}
