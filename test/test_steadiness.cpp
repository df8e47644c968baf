/*
 * A refused result is restarted (judgeSteadiness()): where the refinement does not come back
 * to it, its confidence is the share of such results that were right; where it does, the
 * result keeps the confidence of its evidence.
 */
#include "test_data.h"
#include "verify/verification.h"

#include <pcl_mi/registration_core.h>

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace {

/** \a n points spread uniformly over the box [lo, hi], with 1 cm of noise. */
void
addBox(pcl_mi::PointList& points,
       const Eigen::Vector3f& lo,
       const Eigen::Vector3f& hi,
       int n,
       std::mt19937& rng)
{
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> noise(0.0f, 0.01f);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3f p(lo.x() + u(rng) * (hi.x() - lo.x()),
                            lo.y() + u(rng) * (hi.y() - lo.y()),
                            lo.z() + u(rng) * (hi.z() - lo.z()));
    points.push_back(p + Eigen::Vector3f(noise(rng), noise(rng), noise(rng)));
  }
}

/** The confidence the evidence of \a v gives, judged again. */
double
evidenceConfidence(pcl_mi::Verification v)
{
  pcl_mi::core::judge(v);
  return v.confidence;
}

} // namespace

TEST(Steadiness, TwoUnrelatedPlacesAreUnsteadyAndTakeTheUnsteadyShare)
{
  pcl_mi::RegistrationCore core;
  core.setTarget(test_data::pointList(*test_data::loadScan("00", 0)));
  core.setSource(test_data::pointList(*test_data::loadScan("02", 0)));
  const pcl_mi::AlignmentResult result = core.align(Eigen::Matrix4d::Identity(), 2000);
  ASSERT_FALSE(result.converged);
  const pcl_mi::Verification& v = result.verification;
  ASSERT_FALSE(std::isnan(v.restart_turn_deg));
  EXPECT_TRUE(v.restart_turn_deg >= 1.0 || v.restart_shift >= 0.25)
      << v.restart_turn_deg << " deg, " << v.restart_shift;
  EXPECT_TRUE(v.unsteady);
  EXPECT_EQ(v.confidence, pcl_mi::core::kUnsteadyConfidence);
  EXPECT_NE(evidenceConfidence(v), pcl_mi::core::kUnsteadyConfidence);
}

// Steady, so it keeps more than the unsteady share; the clouds swapped, free along the same
// length, do not confirm it, so it takes the share of such results instead of the evidence's.
TEST(Steadiness, ACorridorFreeAlongItsLengthIsSteadyAndNotConfirmedByTheCloudsSwapped)
{
  std::mt19937 rng(2);
  pcl_mi::PointList corridor;
  addBox(corridor, {-30.0f, -2.0f, 0.0f}, {30.0f, 2.0f, 0.0f}, 20000, rng); // floor
  addBox(corridor, {-30.0f, -2.0f, 0.0f}, {30.0f, -2.0f, 3.0f}, 20000, rng); // walls
  addBox(corridor, {-30.0f, 2.0f, 0.0f}, {30.0f, 2.0f, 3.0f}, 20000, rng);
  pcl_mi::PointList moved = corridor;
  for (Eigen::Vector3f& p : moved)
    p.x() -= 1.5f;
  pcl_mi::RegistrationCore core;
  core.setTarget(corridor);
  core.setSource(moved);
  Eigen::Matrix4d truth = Eigen::Matrix4d::Identity();
  truth(0, 3) = 1.5;
  const pcl_mi::AlignmentResult result = core.align(truth, 2000);
  ASSERT_FALSE(result.converged);
  const pcl_mi::Verification& v = result.verification;
  EXPECT_EQ(v.refusal, pcl_mi::Refusal::Degenerate) << v.reason;
  EXPECT_LT(v.restart_turn_deg, 1.0);
  EXPECT_LT(v.restart_shift, 0.25);
  EXPECT_FALSE(v.unsteady);
  EXPECT_GE(evidenceConfidence(v), 0.8); // so worth the clouds swapped
  EXPECT_FALSE(v.reverse_confirmed);
  EXPECT_FALSE(std::isnan(v.reverse_shift));
  EXPECT_EQ(v.confidence, pcl_mi::core::kReverseUnconfirmedConfidence);
}
