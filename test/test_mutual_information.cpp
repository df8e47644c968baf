/*
 * Entropy and MI against hand-computed values.
 */
#include "features/mutual_information.h"

#include <gtest/gtest.h>

#include <cmath>

using pcl_mi::JointHistogram;

namespace {

JointHistogram
histogram2x2(std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d)
{
  JointHistogram h;
  h.num_bins = 2;
  h.counts = {a, b, c, d};
  h.overlap_voxels = a + b + c + d;
  return h;
}

} // namespace

TEST(Entropy, UniformAndDegenerate)
{
  EXPECT_NEAR(pcl_mi::core::entropy({5, 5}), std::log(2.0), 1e-12);
  EXPECT_NEAR(pcl_mi::core::entropy({1, 1, 1, 1}), std::log(4.0), 1e-12);
  EXPECT_DOUBLE_EQ(pcl_mi::core::entropy({7, 0, 0}), 0.0);
  EXPECT_DOUBLE_EQ(pcl_mi::core::entropy({0, 0}), 0.0);
  EXPECT_DOUBLE_EQ(pcl_mi::core::entropy({}), 0.0);
}

TEST(Entropy, HandComputedSkewed)
{
  // p = (1/4, 3/4): H = -(1/4 ln 1/4 + 3/4 ln 3/4)
  const double expected = -(0.25 * std::log(0.25) + 0.75 * std::log(0.75));
  EXPECT_NEAR(pcl_mi::core::entropy({1, 3}), expected, 1e-12);
  EXPECT_NEAR(pcl_mi::core::entropy({100, 300}), expected, 1e-12);
}

TEST(MutualInformation, PerfectDependenceIsMarginalEntropy)
{
  const auto h = histogram2x2(2, 0, 0, 2);
  const auto e = pcl_mi::core::entropies(h);
  EXPECT_NEAR(e.target, std::log(2.0), 1e-12);
  EXPECT_NEAR(e.source, std::log(2.0), 1e-12);
  EXPECT_NEAR(e.joint, std::log(2.0), 1e-12);
  EXPECT_NEAR(pcl_mi::core::mutualInformation(h), std::log(2.0), 1e-12);
}

TEST(MutualInformation, IndependenceIsZero)
{
  EXPECT_NEAR(pcl_mi::core::mutualInformation(histogram2x2(1, 1, 1, 1)), 0.0, 1e-12);
  EXPECT_NEAR(pcl_mi::core::mutualInformation(histogram2x2(2, 6, 1, 3)), 0.0, 1e-12);
}

TEST(MutualInformation, HandComputedAsymmetric)
{
  // counts [[3, 1], [0, 4]], N = 8: p(x) = (1/2, 1/2), p(y) = (3/8, 5/8),
  // p(x, y) = (3/8, 1/8, 0, 1/2).
  const auto h = histogram2x2(3, 1, 0, 4);
  const double hx = std::log(2.0);
  const double hy = -(3.0 / 8 * std::log(3.0 / 8) + 5.0 / 8 * std::log(5.0 / 8));
  const double hxy =
      -(3.0 / 8 * std::log(3.0 / 8) + 1.0 / 8 * std::log(1.0 / 8) + 0.5 * std::log(0.5));
  const auto e = pcl_mi::core::entropies(h);
  EXPECT_NEAR(e.target, hx, 1e-12);
  EXPECT_NEAR(e.source, hy, 1e-12);
  EXPECT_NEAR(e.joint, hxy, 1e-12);
  EXPECT_NEAR(pcl_mi::core::mutualInformation(h), hx + hy - hxy, 1e-12);
  EXPECT_GT(pcl_mi::core::mutualInformation(h), 0.0);
}

TEST(MutualInformation, EmptyHistogramIsZero)
{
  JointHistogram h;
  EXPECT_DOUBLE_EQ(pcl_mi::core::mutualInformation(h), 0.0);
  EXPECT_DOUBLE_EQ(pcl_mi::core::mutualInformation(histogram2x2(0, 0, 0, 0)), 0.0);
}

TEST(NormalizedMutualInformation, SpansOneToTwo)
{
  using pcl_mi::core::normalizedMutualInformation;
  EXPECT_NEAR(normalizedMutualInformation(histogram2x2(1, 1, 1, 1)), 1.0, 1e-12);
  EXPECT_NEAR(normalizedMutualInformation(histogram2x2(2, 6, 1, 3)), 1.0, 1e-12);
  EXPECT_NEAR(normalizedMutualInformation(histogram2x2(2, 0, 0, 2)), 2.0, 1e-12);
  const auto e = pcl_mi::core::entropies(histogram2x2(3, 1, 0, 4));
  EXPECT_NEAR(normalizedMutualInformation(histogram2x2(3, 1, 0, 4)),
              (e.target + e.source) / e.joint, 1e-12);
  // No joint spread (one value in both clouds) and no counts carry no evidence.
  EXPECT_DOUBLE_EQ(normalizedMutualInformation(histogram2x2(5, 0, 0, 0)), 0.0);
  EXPECT_DOUBLE_EQ(normalizedMutualInformation(histogram2x2(0, 0, 0, 0)), 0.0);
  EXPECT_DOUBLE_EQ(normalizedMutualInformation(JointHistogram()), 0.0);
}

// Why the coarsest level uses it: a pose whose larger overlap brings a third feature value
// scores more MI despite some disagreement, while normalised MI prefers the pose on which
// the features agree.
TEST(NormalizedMutualInformation, RanksAgreementAboveTheVarietyOfALargerOverlap)
{
  const JointHistogram agreeing = histogram2x2(50, 0, 0, 50);
  JointHistogram larger;
  larger.num_bins = 3;
  larger.counts = {100, 2, 2, 2, 100, 2, 2, 2, 100};
  larger.overlap_voxels = 312;
  EXPECT_GT(pcl_mi::core::mutualInformation(larger), pcl_mi::core::mutualInformation(agreeing));
  EXPECT_LT(pcl_mi::core::normalizedMutualInformation(larger),
            pcl_mi::core::normalizedMutualInformation(agreeing));
}
