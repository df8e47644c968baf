/*
 * The CPU backend's vectorised pass against the scalar arithmetic of kernels/voxel_math.h
 * (which the OpenCL kernels run): every output of every sample must be equal, bit for bit.
 */
#include "backend/moved_samples.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <random>

namespace {

using pcl_mi::backend::kMovedBlock;
using pcl_mi::backend::MovedBlock;
using pcl_mi::backend::moveSamples;
using pcl_mi::backend::SampleColumns;

/** Samples spread over and beyond a 40 x 30 x 8 grid of 0.5 m voxels, some exactly on its
 * faces, with covariances of cubes of a quarter voxel (or none). */
pcl_mi::core::SourceSamples
randomSamples(std::size_t n, bool with_covariance, std::mt19937& rng)
{
  std::uniform_real_distribution<float> position(-4.0f, 24.0f), spread(0.0f, 0.02f);
  pcl_mi::core::SourceSamples source;
  source.has_covariance = with_covariance;
  for (std::size_t i = 0; i < n; ++i) {
    pcl_mi::core::SourceSample s;
    s.position = Eigen::Vector3f(position(rng), position(rng), 0.2f * position(rng));
    if (i % 7 == 0)
      s.position.x() = 0.0f; // on the grid's lower face at the identity pose
    if (i % 11 == 0)
      s.position.y() = 15.0f; // on its upper face
    s.count = 1 + i % 5;
    if (with_covariance) {
      const float a = spread(rng), b = spread(rng), c = spread(rng);
      const float s6[6] = {a, 0.3f * (a - b), 0.1f * c, b, -0.2f * c, c};
      std::copy(s6, s6 + 6, s.covariance);
    }
    source.samples.push_back(s);
  }
  return source;
}

pcl_mi::core::GridGeometry
grid()
{
  pcl_mi::core::GridGeometry g;
  g.origin = Eigen::Vector3f(0.0f, 0.0f, -2.0f);
  g.resolution = 0.5f;
  g.dims = Eigen::Vector3i(40, 30, 8);
  return g;
}

void
expectScalarResults(const pcl_mi::core::SourceSamples& source,
                    const Eigen::Matrix3f& rotation,
                    const Eigen::Vector3f& translation)
{
  const pcl_mi::core::GridGeometry g = grid();
  const pcl_mi::core::GridPose pose = pcl_mi::core::gridPose(g, rotation, translation);
  const SampleColumns columns(source);
  const Eigen::Matrix3f& r = pose.rotation;
  const Eigen::Vector3f& t = pose.translation;
  const Eigen::Vector3f end = g.dims.cast<float>();
  const Eigen::Vector3f last(std::nextafter(end.x(), 0.0f), std::nextafter(end.y(), 0.0f),
                             std::nextafter(end.z(), 0.0f));
  namespace voxel = pcl_mi::voxel;
  MovedBlock block;
  for (std::size_t begin = 0; begin < source.samples.size(); begin += kMovedBlock) {
    const std::size_t stop = std::min(source.samples.size(), begin + kMovedBlock);
    Eigen::Vector3f min = Eigen::Vector3f::Constant(1e30f), max = -min;
    moveSamples(pose, g.dims, columns, begin, stop, block, min, max);
    Eigen::Vector3f expected_min = Eigen::Vector3f::Constant(1e30f), expected_max = -expected_min;
    for (std::size_t i = begin; i < stop; ++i) {
      const std::size_t k = i - begin;
      const pcl_mi::core::SourceSample& s = source.samples[i];
      const Eigen::Vector3f& p = s.position;
      Eigen::Vector3f f;
      for (int a = 0; a < 3; ++a)
        f[a] = voxel::pcl_mi_moved(r(a, 0), r(a, 1), r(a, 2), t[a], p.x(), p.y(), p.z());
      expected_min = expected_min.cwiseMin(f);
      expected_max = expected_max.cwiseMax(f);
      const bool inside = (f.array() >= 0.0f).all() && (f.array() < end.array()).all();
      const Eigen::Vector3f c = f.cwiseMax(0.0f).cwiseMin(last);
      ASSERT_EQ(block.inside[k] != 0, inside) << "sample " << i;
      ASSERT_EQ(block.ix[k], static_cast<int>(c.x())) << "sample " << i;
      ASSERT_EQ(block.iy[k], static_cast<int>(c.y())) << "sample " << i;
      ASSERT_EQ(block.iz[k], static_cast<int>(c.z())) << "sample " << i;
      ASSERT_EQ(block.height[k], voxel::pcl_mi_quantise_height(c.z(), static_cast<int>(c.z())))
          << "sample " << i;
      if (source.has_covariance)
        ASSERT_EQ(block.variance[k],
                  voxel::pcl_mi_variance_levels(pose.rotation_z.x(), pose.rotation_z.y(),
                                                pose.rotation_z.z(), s.covariance,
                                                pose.variance_scale))
            << "sample " << i;
    }
    EXPECT_EQ(min, expected_min);
    EXPECT_EQ(max, expected_max);
  }
}

} // namespace

TEST(MovedSamples, EqualTheScalarArithmeticBitForBit)
{
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> angle(-3.1f, 3.1f), shift(-5.0f, 5.0f);
  // Sizes below, at and past a block and a vector, so that every tail is taken.
  for (const std::size_t n : {1u, 3u, 4u, 5u, 255u, 256u, 257u, 1031u})
    for (const bool with_covariance : {false, true})
      for (int trial = 0; trial < 4; ++trial) {
        const pcl_mi::core::SourceSamples source = randomSamples(n, with_covariance, rng);
        const Eigen::Matrix3f rotation =
            trial == 0 ? Eigen::Matrix3f::Identity()
                       : (Eigen::AngleAxisf(angle(rng), Eigen::Vector3f::UnitZ()) *
                          Eigen::AngleAxisf(0.3f * angle(rng), Eigen::Vector3f::UnitY()) *
                          Eigen::AngleAxisf(0.3f * angle(rng), Eigen::Vector3f::UnitX()))
                             .toRotationMatrix();
        const Eigen::Vector3f translation =
            trial == 0 ? Eigen::Vector3f::Zero()
                       : Eigen::Vector3f(shift(rng), shift(rng), 0.2f * shift(rng));
        expectScalarResults(source, rotation, translation);
      }
}
