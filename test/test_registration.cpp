/*
 * Alignment of real KITTI pairs (bundled sample) through the pcl::Registration contract:
 * the paper's protocol (identity guess, several metres of true motion) in both directions,
 * the reference perturbed by 5 m and 10 deg, and the same pair 1e6 m from the origin.
 */
#include "test_data.h"

#include <pcl_mi/mutual_information_registration.h>
#include <pcl_mi/registration_core.h>

#include <pcl/common/transforms.h>
#include <pcl/kdtree/kdtree_flann.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <limits>
#include <thread>
#include <tuple>
#include <type_traits>

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using pcl_mi::Feature;

namespace {

struct PairCase {
  const char* sequence;
  int earlier, later;
};

void
PrintTo(const PairCase& pair, std::ostream* os)
{
  *os << "seq " << pair.sequence << " frames " << pair.earlier << "/" << pair.later;
}

// (pair, backward, feature): backward = source is the earlier scan, so the motion to
// recover points backwards.
using Case = std::tuple<PairCase, bool, Feature>;

class BundledPair : public ::testing::TestWithParam<Case> {
protected:
  void
  SetUp() override
  {
    const auto& [pair, backward, feature] = GetParam();
    const int target_frame = backward ? pair.later : pair.earlier;
    const int source_frame = backward ? pair.earlier : pair.later;
    source_ = test_data::loadScan(pair.sequence, source_frame);
    target_ = test_data::loadScan(pair.sequence, target_frame);
    reference_ = test_data::referenceTransform(pair.sequence, target_frame, source_frame);
    reg_.setFeature(feature);
    // The same acceptance cases on another backend (ctest registration_on_opencl).
    if (const char* backend = std::getenv("PCL_MI_TEST_BACKEND")) {
      const bool opencl = std::string(backend) == "opencl";
      std::string why;
      if (opencl && !std::getenv("PCL_MI_REQUIRE_OPENCL") && !pcl_mi::openClAvailable(&why))
        GTEST_SKIP() << "no OpenCL device: " << why;
      reg_.setBackend(opencl ? pcl_mi::Backend::OpenCL : pcl_mi::Backend::Cpu);
    }
    reg_.setInputSource(source_);
    reg_.setInputTarget(target_);
  }

  Eigen::Matrix4d
  align(const Eigen::Matrix4d& guess)
  {
    Cloud aligned;
    // Used through the base class, as code written for GICP or NDT would.
    pcl::Registration<pcl::PointXYZ, pcl::PointXYZ>& base = reg_;
    base.align(aligned, guess.cast<float>());
    EXPECT_TRUE(base.hasConverged()) << reg_.getLastError();
    const Eigen::Matrix4d result = base.getFinalTransformation().cast<double>();
    // The output is the source under the final transformation.
    EXPECT_EQ(aligned.size(), source_->size());
    const Eigen::Vector3d expected =
        (result * (*source_)[100].getVector3fMap().cast<double>().homogeneous()).head<3>();
    EXPECT_LT((aligned[100].getVector3fMap().cast<double>() - expected).norm(), 1e-3);
    EXPECT_GT(reg_.getFinalMutualInformation(), 0.0);
    EXPECT_GT(reg_.getNumberOfEvaluations(), reg_.getFinalNumIteration());
    return result;
  }

  pcl::MutualInformationRegistration<pcl::PointXYZ> reg_;
  Cloud::Ptr source_, target_;
  Eigen::Matrix4d reference_;
};

TEST_P(BundledPair, FromIdentityGuess)
{
  // The paper's protocol: the initial error is the whole true motion.
  ASSERT_GT((reference_.topRightCorner<3, 1>().norm()), 6.0);
  EXPECT_POSE_NEAR(align(Eigen::Matrix4d::Identity()), reference_);
}

TEST_P(BundledPair, FromPerturbedReference)
{
  for (const auto& [x, y, yaw] : {std::make_tuple(4.33, 2.5, 10.0),   // 5 m, +10 deg
                                  std::make_tuple(-2.5, -4.33, -10.0)}) { // 5 m, -10 deg
    SCOPED_TRACE(testing::Message() << "perturbation " << x << ", " << y << ", " << yaw);
    const Eigen::Matrix4d guess = test_data::planarMotion(x, y, yaw) * reference_;
    EXPECT_POSE_NEAR(align(guess), reference_);
  }
}

TEST_P(BundledPair, FromNearlyCorrectGuess)
{
  // A good guess must survive the coarse grid's pull (the search from the guess on the 2 m
  // level is what keeps it).
  for (const auto& [x, y, yaw] : {std::make_tuple(0.3, -0.2, 2.0),
                                  std::make_tuple(-0.1, 0.25, -1.0)}) {
    SCOPED_TRACE(testing::Message() << "perturbation " << x << ", " << y << ", " << yaw);
    const Eigen::Matrix4d guess = test_data::planarMotion(x, y, yaw) * reference_;
    EXPECT_POSE_NEAR(align(guess), reference_);
  }
}

const PairCase kPairs[] = {{"00", 0, 9}, {"02", 0, 6}};

std::string
caseName(const testing::TestParamInfo<Case>& info)
{
  const auto& [pair, backward, feature] = info.param;
  return std::string("seq") + pair.sequence + "_" + std::to_string(pair.earlier) + "_" +
         std::to_string(pair.later) + (backward ? "_backward_" : "_forward_") +
         pcl_mi::featureName(feature);
}

INSTANTIATE_TEST_SUITE_P(Kitti,
                         BundledPair,
                         testing::Combine(testing::ValuesIn(kPairs),
                                          testing::Bool(),
                                          testing::Values(Feature::VarianceZ,
                                                          Feature::PointCount)),
                         caseName);

TEST(Registration, FarFromOriginLikeUtm)
{
  // The same pair, both scans moved 1e6 m in x and y (float32 keeps only ~6 cm there).
  // Scalar = double: a float 4x4 cannot hold a rotation precisely enough to move points
  // 1e6 m from the origin to centimetres.
  auto source = test_data::loadScan("00", 9);
  auto target = test_data::loadScan("00", 0);
  const Eigen::Matrix4d offset = test_data::planarMotion(1e6, 1e6, 0.0);
  pcl::transformPointCloud(*source, *source, offset.cast<float>());
  pcl::transformPointCloud(*target, *target, offset.cast<float>());
  const Eigen::Matrix4d reference = test_data::referenceTransform("00", 0, 9);

  for (const Feature feature : {Feature::VarianceZ, Feature::PointCount}) {
    SCOPED_TRACE(pcl_mi::featureName(feature));
    pcl::MutualInformationRegistration<pcl::PointXYZ, pcl::PointXYZ, double> reg;
    reg.setFeature(feature);
    reg.setInputSource(source);
    reg.setInputTarget(target);
    Cloud aligned;
    reg.align(aligned); // identity guess
    EXPECT_TRUE(reg.hasConverged());
    // Compare where the data is: in the frame of the un-shifted scans.
    const Eigen::Matrix4d local = offset.inverse() * reg.getFinalTransformation() * offset;
    EXPECT_POSE_NEAR(local, reference);
  }
}

TEST(Registration, SameRelativeAccuracyAtOtherScales)
{
  // The pair shrunk to a room's size and in millimetres-like units, either with the
  // resolution and the simplex steps set to the scale or with the defaults, which derive
  // both from the target's extent: everything else tied to the grid follows the resolution,
  // so the alignment is the same up to the scale. Powers of two keep the derived resolution
  // an exact multiple. (With a fixed 0.7 m refinement cube the x0.1 pair ended 0.059 m =
  // 0.59 scaled metres off.)
  auto source = test_data::loadScan("00", 9);
  auto target = test_data::loadScan("00", 0);
  const Eigen::Matrix4d reference = test_data::referenceTransform("00", 0, 9);
  auto alignAtScale = [&](double scale, bool derived) {
    Cloud::Ptr scaled_source(new Cloud), scaled_target(new Cloud);
    const Eigen::Matrix4f s = (Eigen::Vector4f() << Eigen::Vector3f::Constant(
                                   static_cast<float>(scale)), 1.0f).finished().asDiagonal();
    pcl::transformPointCloud(*source, *scaled_source, s);
    pcl::transformPointCloud(*target, *scaled_target, s);
    pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
    if (!derived) {
      reg.setResolution(scale);
      Eigen::Matrix<double, 6, 1> steps;
      steps << 8.0 * scale, 8.0 * scale, 1.0 * scale, 0.1, 0.1, 0.8;
      reg.setSimplexSteps(steps);
    }
    reg.setInputSource(scaled_source);
    reg.setInputTarget(scaled_target);
    Cloud aligned;
    reg.align(aligned);
    EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
    Eigen::Matrix4d t = reg.getFinalTransformation().cast<double>();
    t.topRightCorner<3, 1>() /= scale; // back to metres
    return std::make_pair(t, reg.getResolution() / scale);
  };
  for (const bool derived : {false, true}) {
    SCOPED_TRACE(derived ? "derived" : "set");
    const auto [metres, resolution] = alignAtScale(1.0, derived);
    EXPECT_POSE_NEAR(metres, reference);
    for (const double scale : {0.125, 1024.0}) {
      SCOPED_TRACE(testing::Message() << "scale " << scale);
      const auto [t, scaled_resolution] = alignAtScale(scale, derived);
      EXPECT_DOUBLE_EQ(scaled_resolution, resolution);
      EXPECT_POSE_NEAR(t, reference);
      const auto from_metres = pcl_mi::io::poseError(t, metres);
      EXPECT_LT(from_metres.translation, 0.01);
      EXPECT_LT(from_metres.rotation_deg, 0.05);
    }
  }
}

TEST(Registration, HeadingStartsFindAGuessFacingTheWrongWay)
{
  // The source's position roughly known (3.6 m off) but its heading not: turned by 135 and
  // -150 deg about its own origin, out of the reach of the paper's simplex about the guess,
  // and found by the coarsest level's extra heading starts.
  auto source = test_data::loadScan("02", 6);
  auto target = test_data::loadScan("02", 0);
  const Eigen::Matrix4d reference = test_data::referenceTransform("02", 0, 6);
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setNumberOfHeadingStarts(8);
  reg.setInputSource(source);
  reg.setInputTarget(target);
  for (const auto& [x, y, yaw] : {std::make_tuple(3.0, -2.0, 135.0),
                                  std::make_tuple(-2.0, -3.0, -150.0)}) {
    SCOPED_TRACE(testing::Message() << "offset " << x << ", " << y << ", turn " << yaw);
    const Eigen::Matrix4d guess = test_data::planarMotion(x, y, 0.0) * reference *
                                  test_data::planarMotion(0.0, 0.0, yaw);
    Cloud aligned;
    reg.align(aligned, guess.cast<float>());
    EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
    EXPECT_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
  }
}

TEST(Registration, AnUntrustedResultGetsAWiderSecondSearch)
{
  // The same guesses facing the wrong way, with the defaults' single heading: the first
  // search ends in a wrong optimum the verification does not trust, and the second search's
  // four headings find the pose. Without it the result stays wrong and says so.
  auto source = test_data::loadScan("02", 6);
  auto target = test_data::loadScan("02", 0);
  const Eigen::Matrix4d reference = test_data::referenceTransform("02", 0, 6);
  for (const auto& [x, y, yaw] : {std::make_tuple(3.0, -2.0, 135.0),
                                  std::make_tuple(-2.0, -3.0, -150.0)}) {
    SCOPED_TRACE(testing::Message() << "offset " << x << ", " << y << ", turn " << yaw);
    const Eigen::Matrix4d guess = test_data::planarMotion(x, y, 0.0) * reference *
                                  test_data::planarMotion(0.0, 0.0, yaw);
    for (const int headings : {4, 0}) {
      SCOPED_TRACE(testing::Message() << headings << " second-search headings");
      pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
      reg.setSecondSearchHeadings(headings);
      EXPECT_EQ(reg.getSecondSearchHeadings(), headings);
      reg.setInputSource(source);
      reg.setInputTarget(target);
      Cloud aligned;
      reg.align(aligned, guess.cast<float>());
      const pcl_mi::AlignmentResult& r = reg.getLastResult();
      EXPECT_EQ(r.second_search, headings > 0);
      if (headings > 0) {
        EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
        EXPECT_TRUE(r.runner_up_kept);
        EXPECT_LE(r.iterations, reg.getMaximumIterations());
        EXPECT_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
      }
      else {
        EXPECT_FALSE(reg.hasConverged());
      }
    }
  }
  // A pair the verification trusts never runs it.
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setInputSource(source);
  reg.setInputTarget(target);
  Cloud aligned;
  reg.align(aligned);
  EXPECT_TRUE(reg.hasConverged());
  EXPECT_FALSE(reg.getLastResult().second_search);
  EXPECT_FALSE(reg.setParameters([] {
    pcl_mi::Parameters p;
    p.search.second_search_headings = -1;
    return p;
  }()));
  EXPECT_EQ(pcl_mi::Parameters::paper().search.second_search_headings, 0);
  EXPECT_FALSE(pcl_mi::Parameters::paper().search.reverse_search);
}

namespace {

/** The points of \a cloud a forward-looking sensor with a 70 deg field of view at its
 * origin would see, moved by \a offset along x. */
Cloud::Ptr
cutToView(const Cloud::Ptr& cloud, float offset = 0.0f)
{
  Cloud::Ptr cut = test_data::forwardView(*cloud, 35.0);
  for (auto& point : *cut)
    point.x += offset;
  return cut;
}

} // namespace

TEST(Registration, PositionStartsAlignANarrowFieldOfView)
{
  // The bundled pair as a forward-looking sensor with a 70 deg field of view would see it.
  // From the guess alone the search stays where the two fields of view coincide (about 6 m
  // and 5 m off in the two directions); starts around the guess find the scene's optimum.
  // The defaults add them by themselves for such clouds; asked for explicitly, they work
  // the same with the automatic ones off.
  const Cloud::Ptr later = cutToView(test_data::loadScan("00", 9));
  const Cloud::Ptr earlier = cutToView(test_data::loadScan("00", 0));
  ASSERT_LT(later->size(), 30000u);
  const Eigen::Matrix4d reference = test_data::referenceTransform("00", 0, 9);
  for (const bool explicit_starts : {false, true})
    for (const bool backward : {false, true}) {
      SCOPED_TRACE(testing::Message() << (backward ? "backward" : "forward")
                                      << (explicit_starts ? ", explicit starts" : ", defaults"));
      pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
      if (explicit_starts) {
        reg.setNarrowViewPositionStarts(0);
        reg.setNumberOfPositionStarts(4);
      }
      reg.setInputSource(backward ? earlier : later);
      reg.setInputTarget(backward ? later : earlier);
      Cloud aligned;
      reg.align(aligned);
      EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
      EXPECT_EQ(reg.getLastResult().position_starts, explicit_starts ? 4 : 8);
      EXPECT_TRUE(reg.getLastResult().turned_about_sensor);
      EXPECT_POSE_NEAR(reg.getFinalTransformation().cast<double>(),
                       backward ? reference.inverse().eval() : reference);
    }
  // Full scans of a spinning LiDAR get no extra starts: the defaults' cost is unchanged.
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setInputSource(test_data::loadScan("00", 9));
  reg.setInputTarget(test_data::loadScan("00", 0));
  Cloud aligned;
  reg.align(aligned);
  EXPECT_EQ(reg.getLastResult().position_starts, 0);
  EXPECT_FALSE(reg.getLastResult().turned_about_sensor);
  EXPECT_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
}

TEST(Registration, NarrowViewTurnsAboutTheSensorOnlyWhereItIsNear)
{
  // The same 70 deg view: turned about its sensor with wider tilt steps by default, about
  // its centroid with the tilt step off, and about its centroid where the clouds lie far
  // from their frame's origin (a map frame), which cannot be the sensor.
  const Eigen::Matrix4d reference = test_data::referenceTransform("00", 0, 9);
  for (const float offset : {0.0f, 2000.0f})
    for (const double tilt : {0.35, 0.0}) {
      SCOPED_TRACE(testing::Message() << "offset " << offset << ", tilt step " << tilt);
      pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
      reg.setNarrowViewTiltStep(tilt);
      EXPECT_EQ(reg.getNarrowViewTiltStep(), tilt);
      reg.setInputSource(cutToView(test_data::loadScan("00", 9), offset));
      reg.setInputTarget(cutToView(test_data::loadScan("00", 0), offset));
      Cloud aligned;
      reg.align(aligned);
      EXPECT_EQ(reg.getLastResult().turned_about_sensor, offset == 0.0f && tilt > 0.0);
      if (offset == 0.0f) // the shifted pair's reference is another transform
        EXPECT_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
    }
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  EXPECT_FALSE(reg.setParameters([] {
    pcl_mi::Parameters p;
    p.search.narrow_view_tilt_step = -0.1;
    return p;
  }()));
  pcl_mi::Parameters invalid;
  invalid.search.narrow_view_tilt_step = 4.0;
  EXPECT_NE(invalid.validate().find("narrow-view tilt step"), std::string::npos);
}

// The yaw starts and the scanned turns are a narrow view's: the cut pair searches from two
// more starts, the full 360-degree scans do not, and the settings are validated like the
// tilt step.
TEST(Registration, ANarrowViewAlsoStartsTurnedInYaw)
{
  const Eigen::Matrix4d reference = test_data::referenceTransform("00", 0, 9);
  const Cloud::Ptr later = test_data::loadScan("00", 9);
  const Cloud::Ptr earlier = test_data::loadScan("00", 0);
  const Cloud::Ptr later_cut = cutToView(later);
  const Cloud::Ptr earlier_cut = cutToView(earlier);
  for (const double yaw : {0.5, 0.0}) {
    SCOPED_TRACE(yaw);
    pcl::MutualInformationRegistration<pcl::PointXYZ> narrow, full;
    narrow.setNarrowViewYawStart(yaw);
    full.setNarrowViewYawStart(yaw);
    EXPECT_EQ(narrow.getNarrowViewYawStart(), yaw);
    narrow.setInputSource(later_cut);
    narrow.setInputTarget(earlier_cut);
    full.setInputSource(later);
    full.setInputTarget(earlier);
    Cloud aligned;
    narrow.align(aligned);
    full.align(aligned);
    EXPECT_POSE_NEAR(narrow.getFinalTransformation().cast<double>(), reference);
    EXPECT_POSE_NEAR(full.getFinalTransformation().cast<double>(), reference);
    EXPECT_EQ(narrow.getLastResult().yaw_starts, yaw > 0.0 ? 2 : 0);
    EXPECT_EQ(full.getLastResult().yaw_starts, 0);
    // At the identity guess, no turn of the scan grid scores better than the guess itself.
    EXPECT_EQ(narrow.getNarrowViewScannedStarts(), 2);
    EXPECT_EQ(narrow.getLastResult().scanned_starts, 0);
    EXPECT_EQ(full.getLastResult().scanned_starts, 0);
  }
  // A guess turned by 70 deg of yaw from the truth (the fixed yaw starts off): turns of the
  // grid score better than the guess and start searches of their own, which find the pose;
  // without them the search ends about 12 m off.
  const Eigen::Matrix4d turned =
      reference *
      Eigen::Affine3d(Eigen::AngleAxisd(70.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ())).matrix();
  for (const int scans : {2, 0}) {
    SCOPED_TRACE(scans);
    pcl::MutualInformationRegistration<pcl::PointXYZ> narrow;
    narrow.setNarrowViewScannedStarts(scans);
    narrow.setNarrowViewYawStart(0.0);
    narrow.setInputSource(later_cut);
    narrow.setInputTarget(earlier_cut);
    Cloud aligned;
    narrow.align(aligned, turned.cast<float>());
    EXPECT_EQ(narrow.getLastResult().scanned_starts, scans);
    if (scans > 0) {
      EXPECT_TRUE(narrow.hasConverged()) << narrow.getLastError();
      EXPECT_POSE_NEAR(narrow.getFinalTransformation().cast<double>(), reference);
    }
    else {
      EXPECT_GT(pcl_mi::io::poseError(narrow.getFinalTransformation().cast<double>(), reference)
                    .translation,
                1.0);
    }
  }
  EXPECT_EQ(pcl_mi::Parameters::paper().search.narrow_view_yaw_start, 0.0);
  EXPECT_EQ(pcl_mi::Parameters::paper().search.narrow_view_scanned_starts, 0);
  pcl_mi::Parameters invalid;
  invalid.search.narrow_view_yaw_start = 4.0;
  EXPECT_NE(invalid.validate().find("narrow-view yaw start"), std::string::npos);
  invalid = pcl_mi::Parameters();
  invalid.search.narrow_view_scanned_starts = -1;
  EXPECT_NE(invalid.validate().find("narrow-view scanned starts"), std::string::npos);
}

TEST(Registration, NoReturnMarkersDoNotMakeAnOptimum)
{
  // fast_gicp's sample pair (another sensor and scene: a cluttered site next to buildings,
  // 0.5 m apart) writes beams without a return as (0, 0, 0): about 5000 per scan. Kept, they
  // made a scan turned by 180 deg score three times the MI of the true alignment, which the
  // wider search (heading and position starts) then found: 2.5 m and 180 deg off.
  const std::string dir = std::string(PCL_MI_DATA_DIR) + "/fast_gicp/";
  pcl::PointCloud<pcl::PointXYZI> source_xyzi, target_xyzi;
  ASSERT_EQ(pcl_mi::io::loadCloud(dir + "251371071.pcd", source_xyzi), "");
  ASSERT_EQ(pcl_mi::io::loadCloud(dir + "251370668.pcd", target_xyzi), "");
  Cloud::Ptr source(new Cloud), target(new Cloud);
  pcl::copyPointCloud(source_xyzi, *source);
  pcl::copyPointCloud(target_xyzi, *target);
  std::size_t markers = 0;
  for (const auto& p : *source)
    markers += p.x == 0.0f && p.y == 0.0f && p.z == 0.0f;
  ASSERT_GT(markers, 4000u);
  Eigen::Matrix4d reference;
  ASSERT_EQ(pcl_mi::io::loadTransform(dir + "relative.txt", reference), "");
  for (const int starts : {1, 8}) {
    SCOPED_TRACE(testing::Message() << starts << " heading starts, 4 position starts");
    pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
    reg.setNumberOfHeadingStarts(starts);
    reg.setNumberOfPositionStarts(starts > 1 ? 4 : 0);
    reg.setInputSource(source);
    reg.setInputTarget(target);
    Cloud aligned;
    reg.align(aligned);
    EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
    // The reference is the maintainers' own registration result, 0.34 deg of roll
    // included, hence the wider rotation bound.
    const auto e = pcl_mi::io::poseError(reg.getFinalTransformation().cast<double>(), reference);
    EXPECT_LT(e.translation, 0.08);
    EXPECT_LT(e.rotation_deg, 0.5);
  }
}

TEST(Registration, CostPeaksAtTheReference)
{
  auto source = test_data::loadScan("02", 6);
  auto target = test_data::loadScan("02", 0);
  const Eigen::Matrix4d reference = test_data::referenceTransform("02", 0, 6);
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setInputSource(source);
  reg.setInputTarget(target);
  const double at_reference = reg.evaluate(reference.cast<float>());
  EXPECT_GT(at_reference, 0.0);
  for (const auto& delta : {test_data::planarMotion(1.0, 0, 0), test_data::planarMotion(0, -1.0, 0),
                            test_data::planarMotion(0, 0, 3.0), Eigen::Matrix4d::Identity().eval()})
    if (!delta.isIdentity())
      EXPECT_GT(at_reference, reg.evaluate((delta * reference).cast<float>()));
  // Far away: no overlap, MI 0.
  EXPECT_EQ(reg.evaluate((test_data::planarMotion(1000, 0, 0) * reference).cast<float>()), 0.0);
}

TEST(Registration, PaperPresetRunsOneSimplex)
{
  auto source = test_data::loadScan("00", 9);
  auto target = test_data::loadScan("00", 0);
  pcl::MutualInformationRegistration<pcl::PointXYZI> reg_default; // the XYZI instantiation
  EXPECT_TRUE(reg_default.getSymmetricStart());
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  ASSERT_TRUE(reg.setParameters(pcl_mi::Parameters::paper()));
  EXPECT_FALSE(reg.getSymmetricStart());
  EXPECT_EQ(reg.getNumberOfRestarts(), 0);
  reg.setInputSource(source);
  reg.setInputTarget(target);
  Cloud aligned;
  reg.align(aligned);
  // The forward pair is within the paper's reach from the identity guess.
  const auto e = pcl_mi::io::poseError(reg.getFinalTransformation().cast<double>(),
                                       test_data::referenceTransform("00", 0, 9));
  EXPECT_LT(e.translation, 0.5);
  EXPECT_LT(e.rotation_deg, 2.0);
}

TEST(Registration, PlanarSearchKeepsPinnedParameters)
{
  auto source = test_data::loadScan("00", 9);
  auto target = test_data::loadScan("00", 0);
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  Eigen::Matrix<double, 6, 1> steps;
  steps << 8, 8, 0, 0, 0, 0.8; // x, y, yaw only
  reg.setSimplexSteps(steps);
  reg.setInputSource(source);
  reg.setInputTarget(target);
  Cloud aligned;
  reg.align(aligned);
  const Eigen::Matrix4f t = reg.getFinalTransformation();
  EXPECT_FLOAT_EQ(t(2, 2), 1.0f); // no roll or pitch
  EXPECT_NEAR(t(2, 3), 0.0f, 1e-4f);
  const auto e = pcl_mi::io::poseError(t.cast<double>(), test_data::referenceTransform("00", 0, 9));
  EXPECT_LT(e.translation, 0.3);
}

} // namespace

namespace {

TEST(Registration, OtherPointTypesCompileFromTheHeader)
{
  // pcl::PointXYZRGB is not precompiled into the library: the header's template bodies
  // instantiate it here.
  using ColourCloud = pcl::PointCloud<pcl::PointXYZRGB>;
  auto source = pcl::make_shared<ColourCloud>();
  auto target = pcl::make_shared<ColourCloud>();
  pcl::copyPointCloud(*test_data::loadScan("02", 6), *source);
  pcl::copyPointCloud(*test_data::loadScan("02", 0), *target);
  pcl::MutualInformationRegistration<pcl::PointXYZRGB> reg;
  reg.setInputSource(source);
  reg.setInputTarget(target);
  ColourCloud aligned;
  reg.align(aligned);
  EXPECT_TRUE(reg.hasConverged());
  EXPECT_POSE_NEAR(reg.getFinalTransformation().cast<double>(),
                   test_data::referenceTransform("02", 0, 6));
}

TEST(Registration, CloudsReadInPlaceGiveTheEnginesResultForCopies)
{
  // The adapter reads PCL clouds in place (32-byte points here); the engine gets copies.
  using IntensityCloud = pcl::PointCloud<pcl::PointXYZI>;
  auto source = pcl::make_shared<IntensityCloud>();
  auto target = pcl::make_shared<IntensityCloud>();
  pcl::copyPointCloud(*test_data::loadScan("00", 9), *source);
  pcl::copyPointCloud(*test_data::loadScan("00", 0), *target);
  pcl::MutualInformationRegistration<pcl::PointXYZI> reg;
  reg.setInputSource(source);
  reg.setInputTarget(target);
  IntensityCloud aligned;
  reg.align(aligned);
  pcl_mi::RegistrationCore core;
  core.setSource(test_data::pointList(*test_data::loadScan("00", 9)));
  core.setTarget(test_data::pointList(*test_data::loadScan("00", 0)));
  const pcl_mi::AlignmentResult copied = core.align(Eigen::Matrix4d::Identity());
  EXPECT_EQ(reg.getFinalTransformation(), copied.transformation.cast<float>());
  // Indices select a copy: the same as the engine given those points.
  auto every_other = pcl::make_shared<pcl::Indices>();
  pcl_mi::PointList selected;
  for (std::size_t i = 0; i < source->size(); i += 2) {
    every_other->push_back(static_cast<pcl::index_t>(i));
    selected.push_back((*source)[i].getVector3fMap());
  }
  reg.setIndices(every_other);
  reg.align(aligned);
  core.setSource(selected);
  const pcl_mi::AlignmentResult selected_copy = core.align(Eigen::Matrix4d::Identity());
  EXPECT_EQ(reg.getFinalTransformation(), selected_copy.transformation.cast<float>());
}

/** The source under \a transform as pcl::Registration::align() and pcl::transformPointCloud()
 * give it: copied through \a indices, the fourth coordinate 1, moved where finite. */
template <typename Point, typename Matrix>
pcl::PointCloud<Point>
movedAsPcl(const pcl::PointCloud<Point>& source, const pcl::Indices& indices, const Matrix& transform)
{
  pcl::PointCloud<Point> moved;
  for (const pcl::index_t i : indices)
    moved.push_back(source[static_cast<std::size_t>(i)]);
  moved.is_dense = source.is_dense;
  for (Point& p : moved)
    p.data[3] = 1.0f;
  pcl::transformPointCloud(moved, moved, transform);
  return moved;
}

/** Whether every point of \a a has the bits of \a b's in x, y, z, the fourth coordinate
 * and (for PointXYZI) the intensity: NaNs included. */
template <typename Point>
bool
sameBits(const pcl::PointCloud<Point>& a, const pcl::PointCloud<Point>& b)
{
  constexpr std::size_t floats = std::is_same<Point, pcl::PointXYZI>::value ? 5 : 4;
  if (a.size() != b.size())
    return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::memcmp(a[i].data, b[i].data, floats * sizeof(float)) != 0)
      return false;
  return true;
}

TEST(Registration, TheOutputIsTheSourceMovedAsPclMovesIt)
{
  // Every 8th point of a scan, some of them NaN, each with its own intensity.
  using IntensityCloud = pcl::PointCloud<pcl::PointXYZI>;
  auto source = pcl::make_shared<IntensityCloud>();
  auto target = pcl::make_shared<IntensityCloud>();
  const Cloud::Ptr scan_9 = test_data::loadScan("00", 9), scan_0 = test_data::loadScan("00", 0);
  for (std::size_t i = 0; i < scan_9->size(); i += 8) {
    pcl::PointXYZI p;
    p.getVector3fMap() = (*scan_9)[i].getVector3fMap();
    p.intensity = static_cast<float>(i);
    if (i % 800 == 0)
      p.x = std::numeric_limits<float>::quiet_NaN();
    source->push_back(p);
  }
  source->is_dense = false;
  source->header.frame_id = "velodyne";
  pcl::copyPointCloud(*scan_0, *target);
  pcl::Indices all(source->size()), every_third;
  for (std::size_t i = 0; i < all.size(); ++i) {
    all[i] = static_cast<pcl::index_t>(i);
    if (i % 3 == 0)
      every_third.push_back(all[i]);
  }

  pcl::MutualInformationRegistration<pcl::PointXYZI> reg;
  reg.setInputSource(source);
  reg.setInputTarget(target);
  const Eigen::Matrix4f guess = test_data::planarMotion(1.0, 0.5, 0.05).cast<float>();
  IntensityCloud aligned;
  reg.align(aligned, guess);
  EXPECT_TRUE(sameBits(aligned, movedAsPcl(*source, all, reg.getFinalTransformation())));
  EXPECT_EQ(aligned.width, source->width);
  EXPECT_EQ(aligned.height, source->height);
  EXPECT_FALSE(aligned.is_dense);
  EXPECT_EQ(aligned.header.frame_id, "velodyne");

  // Through the base class, whose align() copies the source first: the same points.
  pcl::Registration<pcl::PointXYZI, pcl::PointXYZI>& base = reg;
  IntensityCloud through_base;
  base.align(through_base, guess);
  EXPECT_TRUE(sameBits(through_base, aligned));

  // Indices: the selected points, in their order, as one row.
  reg.setIndices(pcl::make_shared<pcl::Indices>(every_third));
  IntensityCloud selected;
  reg.align(selected, guess);
  EXPECT_TRUE(sameBits(selected, movedAsPcl(*source, every_third, reg.getFinalTransformation())));
  EXPECT_EQ(selected.width, every_third.size());
  EXPECT_EQ(selected.height, 1u);

  // The source itself as the output: moved in place.
  auto in_place = pcl::make_shared<IntensityCloud>(*source);
  reg.setIndices(pcl::IndicesPtr());
  reg.setInputSource(in_place);
  reg.align(*in_place, guess);
  EXPECT_TRUE(sameBits(*in_place, movedAsPcl(*source, all, reg.getFinalTransformation())));

  // Scalar = double moves with a double matrix.
  Cloud::Ptr xyz = pcl::make_shared<Cloud>();
  pcl::copyPointCloud(*source, *xyz);
  pcl::MutualInformationRegistration<pcl::PointXYZ, pcl::PointXYZ, double> precise;
  precise.setInputSource(xyz);
  precise.setInputTarget(scan_0);
  Cloud precise_aligned;
  precise.align(precise_aligned, guess.cast<double>());
  EXPECT_TRUE(sameBits(precise_aligned, movedAsPcl(*xyz, all, precise.getFinalTransformation())));
}

TEST(Registration, ACloudGrownInPlaceAfterItWasSetIsReadAgain)
{
  // The adapter reads the clouds in place: a target that grows (and so moves in memory)
  // after setInputTarget(), and a source after align(), are read again, not where they were.
  auto target = pcl::make_shared<Cloud>(*test_data::loadScan("00", 0));
  auto source = pcl::make_shared<Cloud>(*test_data::loadScan("00", 9));
  const Cloud full_target = *target, full_source = *source;
  target->resize(target->size() / 2);
  target->points.shrink_to_fit();
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setInputTarget(target);
  reg.setInputSource(source);
  target->insert(target->end(), full_target.begin() + static_cast<std::ptrdiff_t>(target->size()),
                 full_target.end());
  Cloud aligned;
  reg.align(aligned);
  pcl::MutualInformationRegistration<pcl::PointXYZ> fresh;
  fresh.setInputTarget(pcl::make_shared<Cloud>(full_target));
  fresh.setInputSource(pcl::make_shared<Cloud>(full_source));
  fresh.align(aligned);
  EXPECT_EQ(reg.getFinalTransformation(), fresh.getFinalTransformation());
  // The source halved and grown back between align() and evaluate().
  const Eigen::Matrix4f pose = fresh.getFinalTransformation();
  const double expected = fresh.evaluate(pose);
  source->resize(source->size() / 2);
  source->points.shrink_to_fit();
  source->insert(source->end(), full_source.begin() + static_cast<std::ptrdiff_t>(source->size()),
                 full_source.end());
  EXPECT_EQ(reg.evaluate(pose), expected);
}

TEST(Registration, ATargetGrownBeforeAResolutionIsDerivedIsReadAgain)
{
  // Found by fuzz_api under ASan: a target that grew (and moved in memory) after
  // setInputTarget(), then a switch from a set resolution to a derived one, derived it from
  // the target's old storage, freed by then. The grown target must be the one read.
  auto full = test_data::loadScan("00", 0);
  auto target = pcl::make_shared<Cloud>();
  for (const auto& p : *full) // a room-sized corner of a street scan
    if (std::abs(p.x) < 4.0f && std::abs(p.y) < 4.0f)
      target->push_back(p);
  target->points.shrink_to_fit();
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setResolution(1.0);
  reg.setInputTarget(target);
  target->insert(target->end(), full->begin(), full->end());
  reg.setResolution(0.0);
  pcl::MutualInformationRegistration<pcl::PointXYZ> fresh;
  fresh.setInputTarget(pcl::make_shared<Cloud>(*target));
  EXPECT_EQ(reg.getResolution(), fresh.getResolution());
  EXPECT_GE(reg.getResolution(), 1.0); // a street scan's, not the corner's
}

} // namespace

namespace {

TEST(Registration, SameResultForAnyNumberOfThreadsAndRuns)
{
  auto source = test_data::loadScan("02", 0);
  auto target = test_data::loadScan("02", 6);
  Eigen::Matrix4f first;
  for (const int threads : {1, 2, 2, 4}) {
    pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
    pcl_mi::Parameters p;
    p.num_threads = threads;
    ASSERT_TRUE(reg.setParameters(p));
    reg.setInputSource(source);
    reg.setInputTarget(target);
    Cloud aligned;
    reg.align(aligned);
    if (threads == 1)
      first = reg.getFinalTransformation();
    else
      EXPECT_EQ(first, reg.getFinalTransformation()) << "threads " << threads; // bit-identical
  }
}

TEST(Registration, IndependentObjectsInParallelThreadsMatchSerialRuns)
{
  // What may be shared: input clouds (read only; every object reads them in place). What
  // may not: one registration object between threads.
  const auto source_a = test_data::loadScan("00", 9), target_a = test_data::loadScan("00", 0);
  const auto source_b = test_data::loadScan("02", 6), target_b = test_data::loadScan("02", 0);
  struct Job {
    Cloud::ConstPtr source, target;
    Eigen::Matrix4f guess;
  };
  std::vector<Job> jobs;
  for (int k = 0; k < 6; ++k)
    jobs.push_back({k % 2 ? source_a : source_b, k % 2 ? target_a : target_b,
                    test_data::planarMotion(0.5 * k, -0.3 * k, 2.0 * k).cast<float>()});
  auto run = [](const Job& job) {
    pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
    reg.setInputSource(job.source);
    reg.setInputTarget(job.target);
    Cloud aligned;
    reg.align(aligned, job.guess);
    return Eigen::Matrix4f(reg.getFinalTransformation());
  };
  std::vector<Eigen::Matrix4f> serial, parallel(jobs.size());
  for (const Job& job : jobs)
    serial.push_back(run(job));
  std::vector<std::thread> threads;
  for (std::size_t k = 0; k < jobs.size(); ++k)
    threads.emplace_back([&, k] { parallel[k] = run(jobs[k]); });
  for (auto& t : threads)
    t.join();
  for (std::size_t k = 0; k < jobs.size(); ++k)
    EXPECT_EQ(serial[k], parallel[k]) << "job " << k; // bit-identical
}

} // namespace

TEST(Registration, MeanErrorOverTheBundledPairsMeetsTheAccuracyTarget)
{
  // Issue #5's accuracy targets (mean <= 0.05 m / 0.15 deg per initial-error bin over all
  // shared pairs), here as a regression bound on the bundled pairs, the two largest motions
  // of the sample (6.7 m and 9.1 m), both directions, identity guess. Measured: 0.051 m /
  // 0.086 deg; the MI optimum alone gives about 0.10 m.
  double sum_t = 0.0, sum_r = 0.0;
  int n = 0;
  for (const PairCase& pair : kPairs)
    for (const bool backward : {false, true}) {
      const int target_frame = backward ? pair.later : pair.earlier;
      const int source_frame = backward ? pair.earlier : pair.later;
      pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
      reg.setInputSource(test_data::loadScan(pair.sequence, source_frame));
      reg.setInputTarget(test_data::loadScan(pair.sequence, target_frame));
      Cloud aligned;
      reg.align(aligned);
      const auto e = pcl_mi::io::poseError(
          reg.getFinalTransformation().cast<double>(),
          test_data::referenceTransform(pair.sequence, target_frame, source_frame));
      sum_t += e.translation;
      sum_r += e.rotation_deg;
      ++n;
    }
  EXPECT_LT(sum_t / n, 0.06);
  EXPECT_LT(sum_r / n, 0.15);
}

TEST(Registration, FitnessScoreStillSearchesTheTarget)
{
  // The k-d tree over the target is built lazily (MI never searches it); getFitnessScore()
  // must still see the current target, also after the target changes.
  auto source = test_data::loadScan("00", 9);
  auto target = test_data::loadScan("00", 0);
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setInputSource(source);
  reg.setInputTarget(target);
  Cloud aligned;
  reg.align(aligned);
  ASSERT_TRUE(reg.hasConverged());

  auto expectedScore = [&](const Cloud::ConstPtr& tgt) {
    pcl::KdTreeFLANN<pcl::PointXYZ> tree;
    tree.setInputCloud(tgt);
    pcl::Indices index(1);
    std::vector<float> distance(1);
    double sum = 0.0;
    for (const auto& p : aligned) {
      tree.nearestKSearch(p, 1, index, distance);
      sum += distance[0];
    }
    return sum / aligned.size();
  };
  EXPECT_NEAR(reg.getFitnessScore(), expectedScore(target), 1e-6);
  EXPECT_LT(reg.getFitnessScore(), 0.5);

  auto other = test_data::loadScan("00", 9);
  reg.setInputTarget(other);
  reg.align(aligned, reg.getFinalTransformation());
  EXPECT_NEAR(reg.getFitnessScore(), expectedScore(other), 1e-6);
}

TEST(Registration, RefinementSharpensTheMutualInformationOptimum)
{
  auto source = test_data::loadScan("02", 6);
  auto target = test_data::loadScan("02", 0);
  const Eigen::Matrix4d reference = test_data::referenceTransform("02", 0, 6);
  double error[2];
  for (const bool refine : {false, true}) {
    pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
    pcl_mi::Parameters p;
    p.refinement.method = refine ? pcl_mi::Refinement::PointToDistribution : pcl_mi::Refinement::None;
    ASSERT_TRUE(reg.setParameters(p));
    reg.setInputSource(source);
    reg.setInputTarget(target);
    Cloud aligned;
    reg.align(aligned);
    error[refine] = pcl_mi::io::poseError(reg.getFinalTransformation().cast<double>(), reference)
                        .translation;
    EXPECT_EQ(reg.getNumberOfRefinementIterations() > 0, refine);
  }
  EXPECT_LT(error[1], 0.08);
  EXPECT_LT(error[1], error[0]);
}

namespace {

/** The pair in data/foreign_lidar/SET/list.txt's row \a row (0 = first): source, target
 * and the reference source-to-target transform. */
void
loadBundledPair(const std::string& set,
                Cloud::Ptr& source,
                Cloud::Ptr& target,
                Eigen::Matrix4d& reference,
                int row = 0)
{
  const std::string dir = std::string(PCL_MI_DATA_DIR) + "/foreign_lidar/" + set + "/";
  std::ifstream list(dir + "list.txt");
  std::string skipped;
  for (int i = 0; i < row; ++i)
    ASSERT_TRUE(std::getline(list, skipped)) << dir;
  std::string source_name, target_name;
  ASSERT_TRUE(list >> source_name >> target_name) << dir;
  reference.setIdentity();
  for (int i = 0; i < 12; ++i)
    ASSERT_TRUE(list >> reference(i / 4, i % 4));
  pcl::PointCloud<pcl::PointXYZI> source_xyzi, target_xyzi;
  ASSERT_EQ(pcl_mi::io::loadKittiBin(dir + source_name, source_xyzi), "");
  ASSERT_EQ(pcl_mi::io::loadKittiBin(dir + target_name, target_xyzi), "");
  source = pcl::make_shared<Cloud>();
  target = pcl::make_shared<Cloud>();
  pcl::copyPointCloud(source_xyzi, *source);
  pcl::copyPointCloud(target_xyzi, *target);
}

/** Aligns row \a row of the bundled \a set's list with \a reg as configured, from the
 * identity, and gives the row's reference; \a reg keeps the clouds. With \a swapped, the
 * row's target is aligned onto its source, and the reference is inverted to match. */
void
alignBundledPair(const std::string& set,
                 int row,
                 pcl::MutualInformationRegistration<pcl::PointXYZ>& reg,
                 Eigen::Matrix4d& reference,
                 bool swapped = false)
{
  Cloud::Ptr source, target;
  ASSERT_NO_FATAL_FAILURE(loadBundledPair(set, source, target, reference, row));
  if (swapped) {
    std::swap(source, target);
    reference = reference.inverse().eval();
  }
  reg.setInputSource(source);
  reg.setInputTarget(target);
  Cloud aligned;
  reg.align(aligned);
}

} // namespace

// A Livox (70 deg field of view) carried on a walk, 3.4 m and 38 deg between the scans:
// with MI on every level, the coarser grids rank a wrong optimum first, which the
// verification does not trust, and of the search's runners-up the finest grid picks the
// right one. (With the defaults' normalised MI on the coarsest level, no optimum of this
// flat pair is trusted. One coarser refinement stage instead of two: two pull the wrong
// optimum in as well, which masks the mechanism; without one the finest cubes alone leave
// this pair about 0.3 m off. The reverse search, which would run next on this untrusted
// result, is off for the same reason.)
TEST(Registration, AnUntrustedOptimumGivesWayToTheRunnerUpTheFinestGridPrefers)
{
  Cloud::Ptr source, target;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(loadBundledPair("livox_avia_hku1", source, target, reference));
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setCoarseNormalizedMI(false);
  reg.setNarrowViewRefinementStages(1);
  reg.setReverseSearch(false);
  reg.setInputSource(source);
  reg.setInputTarget(target);
  Cloud aligned;
  reg.align(aligned);
  const pcl_mi::AlignmentResult& r = reg.getLastResult();
  EXPECT_GT(r.runners_up_checked, 0);
  EXPECT_TRUE(r.runner_up_kept);
  bool timed = false;
  for (const auto& stage : r.stages)
    timed = timed || (stage.name == "runners-up" && stage.calls == r.runners_up_checked);
  EXPECT_TRUE(timed);
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);

  // A result the verification trusts is final: no runner-up is looked at.
  reg.setInputSource(test_data::loadScan("00", 9));
  reg.setInputTarget(test_data::loadScan("00", 0));
  reg.align(aligned);
  EXPECT_TRUE(reg.hasConverged());
  EXPECT_EQ(reg.getLastResult().runners_up_checked, 0);
  EXPECT_FALSE(reg.getLastResult().runner_up_kept);
}

// A narrow view's verdict also weighs how far its optimum leads the others a few voxels
// across: the Livox walk's second bundled pair leads by a sixth and converges; a 360-degree
// scan skips the searches across and has no lead.
TEST(Registration, ANarrowViewsVerdictWeighsTheLeadOfItsOptimum)
{
  Cloud::Ptr source, target;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(loadBundledPair("livox_avia_hku1", source, target, reference, 1));
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setInputSource(source);
  reg.setInputTarget(target);
  Cloud aligned;
  reg.align(aligned);
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_GT(reg.getVerification().lead, 0.1);
  EXPECT_LE(reg.getVerification().lead, 1.0);
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);

  reg.setInputSource(test_data::loadScan("00", 9));
  reg.setInputTarget(test_data::loadScan("00", 0));
  reg.align(aligned);
  EXPECT_TRUE(reg.hasConverged());
  EXPECT_TRUE(std::isnan(reg.getVerification().lead));
}

// The Livox turned on the spot, its second bundled pair 39 deg apart: every search of this
// direction ends on wrong optima the verification refuses, while the target searched onto
// the source finds the pose, which the verification then trusts. Without the reverse
// search the result is metres off and not converged.
TEST(Registration, AReverseSearchFindsThePoseThisDirectionsSearchMisses)
{
  Cloud::Ptr source, target;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(loadBundledPair("livox_avia_quickshack", source, target, reference, 1));
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  EXPECT_TRUE(reg.getReverseSearch());
  reg.setInputSource(source);
  reg.setInputTarget(target);
  Cloud aligned;
  reg.align(aligned);
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_GE(reg.getConfidence(), 0.95);
  EXPECT_TRUE(reg.getLastResult().reverse_search);
  EXPECT_TRUE(reg.getLastResult().reverse_kept);
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);

  reg.setReverseSearch(false);
  reg.align(aligned);
  EXPECT_FALSE(reg.hasConverged());
  EXPECT_FALSE(reg.getLastResult().reverse_search);
  const Eigen::Matrix4d estimate = reg.getFinalTransformation().cast<double>();
  EXPECT_GT((estimate.topRightCorner<3, 1>() - reference.topRightCorner<3, 1>()).norm(), 1.0);
}

// The reverse search keeps its prepared clouds between alignments and takes only the ones
// that changed: after an alignment against another place (which the verdict does not trust,
// so the reverse search runs), the object aligns the source set next exactly as a new
// object does.
TEST(Registration, TheReverseSearchTakesTheSourceSetSinceItsLastRun)
{
  Cloud::Ptr source, target, elsewhere, unused;
  Eigen::Matrix4d reference, unused_reference;
  ASSERT_NO_FATAL_FAILURE(loadBundledPair("livox_avia_quickshack", source, target, reference, 1));
  ASSERT_NO_FATAL_FAILURE(
      loadBundledPair("livox_avia_hku1", elsewhere, unused, unused_reference, 1));
  pcl::MutualInformationRegistration<pcl::PointXYZ> reused;
  reused.setInputTarget(target);
  reused.setInputSource(elsewhere);
  Cloud aligned;
  reused.align(aligned);
  EXPECT_FALSE(reused.hasConverged());
  ASSERT_TRUE(reused.getLastResult().reverse_search);
  reused.setInputSource(source);
  reused.align(aligned);

  pcl::MutualInformationRegistration<pcl::PointXYZ> fresh;
  fresh.setInputTarget(target);
  fresh.setInputSource(source);
  fresh.align(aligned);
  ASSERT_TRUE(fresh.getLastResult().reverse_search);
  EXPECT_TRUE(fresh.hasConverged()) << fresh.getLastError();
  EXPECT_SAMPLE_POSE_NEAR(fresh.getFinalTransformation().cast<double>(), reference);
  EXPECT_EQ(reused.hasConverged(), fresh.hasConverged());
  EXPECT_EQ(reused.getNumberOfEvaluations(), fresh.getNumberOfEvaluations());
  EXPECT_TRUE(reused.getFinalTransformation() == fresh.getFinalTransformation())
      << reused.getFinalTransformation() << "\n" << fresh.getFinalTransformation();
}

// A Livox turned on the spot, 35 deg between the scans (scan 84 onto 87): surfaces at
// either side of the view hold the turn about the axis of view. Probed at the RMS radius,
// that turn moved the samples a fraction of a voxel, lost 0.2 % of the inliers and the verdict
// said "degenerate along roll"; moved a voxel, the samples lose about 15 %.
TEST(Registration, ANarrowViewsTurnAboutItsAxisOfViewIsProbedAVoxelFar)
{
  Cloud::Ptr source, target;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(loadBundledPair("livox_avia_quickshack", target, source, reference, 2));
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setInputSource(source);
  reg.setInputTarget(target);
  Cloud aligned;
  reg.align(aligned);
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_GE(reg.getConfidence(), 0.95);
  const pcl_mi::Verification& v = reg.getVerification();
  EXPECT_GE(std::min(v.free_direction_contrast[0], v.free_direction_contrast[1]), 0.05);
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(),
                          Eigen::Matrix4d(reference.inverse()));
}

// A Livox turned on the spot, 13 deg between the scans (scan 174 onto 162): its surfaces hold
// a tilt of the view only weakly (turned a voxel, the samples lose under 5 % of their
// inliers), and the verdict said "degenerate". The MI on the finest grid loses more than a
// tenth either way: it holds the turn, and the result converges.
TEST(Registration, AWeaklyHeldTurnTheMutualInformationHoldsConverges)
{
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(alignBundledPair("livox_avia_quickshack", 3, reg, reference));
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_GE(reg.getConfidence(), 0.95);
  const pcl_mi::Verification& v = reg.getVerification();
  bool held = false;
  for (int k = 0; k < 2; ++k)
    held = held || (v.free_direction_contrast[k] < 0.05 && v.free_turn_mi_loss[k] >= 0.1);
  EXPECT_TRUE(held) << v.free_direction_contrast[0] << " " << v.free_turn_mi_loss[0] << ", "
                    << v.free_direction_contrast[1] << " " << v.free_turn_mi_loss[1];
  EXPECT_FALSE(reg.getCovariance().isZero());
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
}

// The Livox turned on the spot, scan 39 onto 24, both cut to every 4th point (about 1.3k
// points each) as a front end's decimation would leave them: the search finds the right
// optimum's neighbourhood, but on 30 inliers the pose stays 2.9 deg off, and the model's
// confidence, which weighs the optimum, said 0.97. Its covariance spreads the turns (roll and
// pitch most) over the bound, and the verdict holds it back for sparse evidence.
TEST(Registration, ASparseResultSpreadOverTheBoundIsHeldBack)
{
  Cloud::Ptr source, target;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(loadBundledPair("livox_avia_quickshack", source, target, reference, 5));
  const auto everyFourth = [](const Cloud& cloud) {
    auto thinned = pcl::make_shared<Cloud>();
    for (std::size_t i = 0; i < cloud.size(); i += 4)
      thinned->push_back(cloud[i]);
    return thinned;
  };
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setInputSource(everyFourth(*source));
  reg.setInputTarget(everyFourth(*target));
  Cloud aligned;
  reg.align(aligned);
  const auto e = pcl_mi::io::poseError(reg.getFinalTransformation().cast<double>(), reference);
  ASSERT_GT(e.rotation_deg, 2.0) << "the premise: this result lies outside the success bound";
  EXPECT_FALSE(reg.hasConverged());
  const pcl_mi::Verification& v = reg.getVerification();
  EXPECT_LT(v.inliers, 60u);
  EXPECT_EQ(v.refusal, pcl_mi::Refusal::WeakEvidence);
  EXPECT_NE(reg.getLastError().find("the evidence is sparse"), std::string::npos)
      << reg.getLastError();
  EXPECT_LT(reg.getConfidence(), 0.95);
  EXPECT_FALSE(reg.getCovariance().isZero());
  // Held back, it is asked of the clouds swapped, which end elsewhere.
  EXPECT_FALSE(v.reverse_confirmed);
  EXPECT_FALSE(v.reverse_reason.empty());
}

// The Livox walk, scan 228 onto 204 (2.2 m and 19 deg apart), from the identity: the result
// passes its own tests on 39 inliers, 0.04 m and 0.2 deg off, but its covariance spreads it
// over the bound and step 7 of the verdict holds it back. The clouds swapped end within the
// agreement tolerance of it, which measures that spread, and it converges.
TEST(Registration, ASparseResultHeldBackForItsSpreadIsConfirmedByTheCloudsSwapped)
{
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(alignBundledPair("livox_avia_hku1", 6, reg, reference));
  const pcl_mi::Verification& v = reg.getVerification();
  ASSERT_LT(v.inliers, 60u) << "the premise: the evidence is sparse";
  bool asked = false;
  for (const pcl_mi::StageTiming& stage : reg.getLastResult().stages)
    asked = asked || stage.name == "sparse spread";
  EXPECT_TRUE(asked) << "the premise: the result passed its own tests";
  EXPECT_TRUE(v.reverse_confirmed) << reg.getLastError();
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_GE(reg.getConfidence(), 0.95);
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
}

// The Livox walk, scan 276 onto 244 (8.5 m and 12.6 deg apart), from the identity: the
// result is held back and the clouds swapped confirm it, on 55 inliers. Their agreement
// measures the spread that the covariance's chance (step 7 of the verdict) would estimate,
// so the result converges; before, that chance held it back for sparse evidence.
TEST(Registration, ASparseResultTheCloudsSwappedConfirmConverges)
{
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(alignBundledPair("livox_avia_hku1", 5, reg, reference));
  const pcl_mi::Verification& v = reg.getVerification();
  ASSERT_LT(v.inliers, 60u) << "the premise: the evidence is sparse";
  EXPECT_TRUE(v.reverse_confirmed) << reg.getLastError();
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_GE(reg.getConfidence(), 0.95);
  EXPECT_FALSE(reg.getCovariance().isZero());
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
}

// The Livox walk, scan 88 onto 72 (0.9 m and 32 deg apart), from the identity: the result is
// held back and asked of the clouds swapped, whose search meets its tolerances in another
// optimum, 2.8 m from it. Weighed by that side as a runner-up, the result, refined there,
// scores the higher normalised MI on its finest grid, so the swapped side ends at it and
// confirms it. Before, that side kept its own optimum, and the result stayed held back.
TEST(Registration, TheCloudsSwappedWeighTheResultTheirSearchMissed)
{
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(alignBundledPair("livox_avia_hku1", 7, reg, reference));
  const pcl_mi::Verification& v = reg.getVerification();
  ASSERT_FALSE(std::isnan(v.reverse_shift)) << "the premise: the clouds swapped were asked";
  EXPECT_TRUE(v.reverse_confirmed) << reg.getLastError();
  EXPECT_LT(v.reverse_shift, 0.25);
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_GE(reg.getConfidence(), 0.95);
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
}

// The Livox walk, scan 168 onto 172: the search's best is not trusted and a runner-up whose
// search was capped is kept. Finished, that runner-up refines to the same optimum (within
// half a finest voxel), passes the verdict, and is taken although the finest grid's
// normalised MI puts it a hair lower; before, the capped one stood and did not converge.
TEST(Registration, AFinishedRunnerUpThatIsTheSameOptimumIsTaken)
{
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(alignBundledPair("livox_avia_hku1", 2, reg, reference, true));
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_TRUE(reg.getLastResult().runner_up_kept || reg.getLastResult().reverse_kept);
  EXPECT_GE(reg.getConfidence(), 0.95);
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
}

// The same Livox walk, 6.0 m and 32 deg between the scans, in both directions: searched on
// MI alone, the coarsest grid (2 m voxels over 4-5 thousand points) scores a wrong pose with
// more overlap above the right one, which the verification does not trust (before runners-up
// were finished, both directions ended 0.6-1.9 m off). Normalised MI, which the overlap does
// not lift, finds it as the search's best, and the verification trusts it. (The search is
// the subject: the refinement's coarser stages, which pull in the MI-only optima too, are
// off.)
TEST(Registration, ALivoxPairIsFoundOnTheCoarsestLevelsNormalisedMI)
{
  Cloud::Ptr source, target;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(loadBundledPair("livox_avia_hku1", source, target, reference, 1));
  for (const bool forward : {true, false}) {
    SCOPED_TRACE(forward ? "forward" : "backward");
    const Eigen::Matrix4d truth = forward ? reference : Eigen::Matrix4d(reference.inverse());
    pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
    EXPECT_TRUE(reg.getCoarseNormalizedMI());
    reg.setNarrowViewRefinementStages(0);
    reg.setInputSource(forward ? source : target);
    reg.setInputTarget(forward ? target : source);
    Cloud aligned;
    reg.align(aligned);
    EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
    EXPECT_EQ(reg.getLastResult().runners_up_checked, 0);
    EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), truth);

    reg.setCoarseNormalizedMI(false);
    reg.align(aligned);
    EXPECT_GT(reg.getLastResult().runners_up_checked, 0);
  }
  EXPECT_FALSE(pcl_mi::Parameters::paper().search.coarse_normalized_mi);
}

// An Ouster on a car on a straight road, 9.8 m between the scans: the first search stays
// at the guess, a whole motion short, and the verification does not trust it. The second
// search also starts half the x step either way along x from the guess, and finds the true
// pose.
TEST(Registration, TheSecondSearchAlsoStartsAlongTheRoad)
{
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(alignBundledPair("mulran_riverside02_os1", 1, reg, reference));
  EXPECT_TRUE(reg.getLastResult().second_search);
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
}

// A Livox turned on the spot in a small room, 33 deg between the scans: the search's best
// optimum drifts 10 m off, where a few voxels at the edge of the overlap score a high
// normalised MI but no source sample lies on a target surface. Of the runners-up, one on
// the shared surfaces beats it whatever its MI, and that one is right.
TEST(Registration, ARunnerUpOnSharedSurfacesBeatsAPoseThatSharesNone)
{
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(alignBundledPair("livox_avia_quickshack", 0, reg, reference));
  const pcl_mi::AlignmentResult& r = reg.getLastResult();
  EXPECT_TRUE(r.runner_up_kept);
  EXPECT_GE(r.verification.inliers, 30u);
  EXPECT_GT(reg.getConfidence(), 0.95);
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
}

// The first bundled Livox pair (3.4 m, 38 deg), source the later scan. The resolution is
// derived as 0.5 m, so the search ends on 1 m voxels and its optimum lies about 0.3 m off:
// beyond the reach of the refinement's 0.35 m cubes alone, within that of the defaults'
// two coarser stages (0.7 and 1.4 m cubes). A 360-degree scan keeps the single stage.
TEST(Registration, ANarrowViewsRefinementReachesFurtherInCoarserStages)
{
  Cloud::Ptr source, target;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(loadBundledPair("livox_avia_hku1", source, target, reference));
  for (const int stages : {2, 0}) {
    SCOPED_TRACE(stages);
    pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
    reg.setNarrowViewRefinementStages(stages);
    EXPECT_EQ(reg.getNarrowViewRefinementStages(), stages);
    reg.setInputSource(source);
    reg.setInputTarget(target);
    Cloud aligned;
    reg.align(aligned);
    const auto error =
        pcl_mi::io::poseError(reg.getFinalTransformation().cast<double>(), reference);
    if (stages > 0) {
      EXPECT_EQ(reg.getLastResult().refinement_stages, 3);
      EXPECT_LT(error.translation, test_data::kSampleTranslationError);
      EXPECT_LT(error.rotation_deg, test_data::kSampleRotationErrorDeg);
    }
    else {
      EXPECT_LE(reg.getLastResult().refinement_stages, 1);
      EXPECT_GT(error.translation, 0.2);
    }
  }

  pcl::MutualInformationRegistration<pcl::PointXYZ> full;
  full.setInputSource(test_data::loadScan("00", 9));
  full.setInputTarget(test_data::loadScan("00", 0));
  Cloud aligned;
  full.align(aligned);
  EXPECT_EQ(full.getLastResult().refinement_stages, 1);
  EXPECT_EQ(pcl_mi::Parameters::paper().refinement.narrow_view_stages, 0);
  pcl_mi::Parameters invalid;
  invalid.refinement.narrow_view_stages = -1;
  EXPECT_NE(invalid.validate().find("narrow-view refinement stages"), std::string::npos);
}

// Two other sensors with the defaults: a 128-beam Ouster-class LiDAR and an OS1-64 mounted
// backwards (later scans at -x), in both directions. The resolution is derived from each
// target; the bounds are the 0.1 m and 0.5 deg.
TEST(Registration, OtherSensorsAlignWithTheDefaults)
{
  for (const char* set : {"seosan01_ouster128", "mulran_riverside02_os1"}) {
    Cloud::Ptr source, target;
    Eigen::Matrix4d reference;
    ASSERT_NO_FATAL_FAILURE(loadBundledPair(set, source, target, reference));
    for (const bool forward : {true, false}) {
      SCOPED_TRACE(testing::Message() << set << (forward ? " forward" : " backward"));
      pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
      reg.setInputSource(forward ? source : target);
      reg.setInputTarget(forward ? target : source);
      Cloud aligned;
      reg.align(aligned);
      EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
      const Eigen::Matrix4d expected = forward ? reference : Eigen::Matrix4d(reference.inverse());
      EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), expected);
    }
  }
}

namespace {

/** The halves of a scan (even and odd points), the odd one moved by the inverse of
 * \a truth, so that \a truth aligns it onto the even one. */
void
splitAndMove(const Cloud& scan, const Eigen::Matrix4d& truth, Cloud::Ptr& target, Cloud::Ptr& source)
{
  target = pcl::make_shared<Cloud>();
  Cloud odd;
  for (std::size_t i = 0; i < scan.size(); ++i)
    (i % 2 ? odd : *target).push_back(scan[i]);
  source = pcl::make_shared<Cloud>();
  pcl::transformPointCloud(odd, *source, Eigen::Matrix4d(truth.inverse()));
}

/** e^T inv(covariance) e for the left increment e [t, rotation vector] that carries
 * \a estimate onto \a truth. */
double
normalisedSquaredError(const Eigen::Matrix4d& estimate,
                       const Eigen::Matrix4d& truth,
                       const Eigen::Matrix<double, 6, 6>& covariance)
{
  const Eigen::Matrix4d d = truth * estimate.inverse();
  const Eigen::AngleAxisd turn(Eigen::Matrix3d(d.topLeftCorner<3, 3>()));
  Eigen::Matrix<double, 6, 1> e;
  e << d.topRightCorner<3, 1>(), turn.angle() * turn.axis();
  return e.dot(covariance.ldlt().solve(e));
}

} // namespace

// The covariance where the result follows the cells: the bundled Ouster OS1-64 scans
// (Riverside, 13k points, few surfaces across the road) split into halves, one moved by a
// known transform. There the covariance from the residuals alone was two to three times
// too small in x and yaw: moving the cells half a cell moves the result by about its error
// (docs/benchmarks.md). getCovariance() widens it by core().covarianceScale(), and the
// mean normalised squared error of the converged results lies within #20's [3, 12].
TEST(Registration, TheCovarianceHoldsTheErrorsOfASparseRingScannersSplitHalves)
{
  const std::string dir =
      std::string(PCL_MI_DATA_DIR) + "/foreign_lidar/mulran_riverside02_os1/scans/";
  double scaled = 0.0, residual_only = 0.0;
  int converged = 0, widened = 0;
  for (const char* name : {"000002.bin", "000004.bin", "000088.bin"}) {
    pcl::PointCloud<pcl::PointXYZI> xyzi;
    ASSERT_EQ(pcl_mi::io::loadKittiBin(dir + name, xyzi), "");
    Cloud scan;
    pcl::copyPointCloud(xyzi, scan);
    for (const Eigen::Vector4d motion : {Eigen::Vector4d(0.6, 0.0, 0.0, 2.0),
                                         Eigen::Vector4d(0.0, -0.5, 0.0, -3.0),
                                         Eigen::Vector4d(-0.4, 0.4, 3.0, 0.0),
                                         Eigen::Vector4d(0.3, 0.8, -2.0, 4.0),
                                         Eigen::Vector4d(-0.9, -0.2, 1.0, -1.0),
                                         Eigen::Vector4d(0.2, -0.7, -4.0, 2.5)}) {
      // x, y (m), then a tilt about x and a turn about z (deg).
      const Eigen::Matrix4d truth =
          test_data::planarMotion(motion[0], motion[1], motion[3]) *
          (Eigen::Affine3d(Eigen::AngleAxisd(motion[2] * M_PI / 180.0, Eigen::Vector3d::UnitX())))
              .matrix();
      Cloud::Ptr target, source;
      splitAndMove(scan, truth, target, source);
      pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
      reg.setInputSource(source);
      reg.setInputTarget(target);
      Cloud aligned;
      reg.align(aligned);
      if (!reg.hasConverged())
        continue;
      ++converged;
      const Eigen::Matrix4d estimate = reg.getFinalTransformation().cast<double>();
      const double scale = reg.core().covarianceScale();
      EXPECT_GE(scale, 1.0);
      widened += scale > 1.0;
      EXPECT_TRUE(reg.getCovariance().isApprox(scale * reg.getVerification().covariance));
      scaled += normalisedSquaredError(estimate, truth, reg.getCovariance());
      residual_only += normalisedSquaredError(estimate, truth, reg.getVerification().covariance);
    }
  }
  ASSERT_GE(converged, 12);
  std::cout << converged << " of 18 converged, " << widened << " widened; mean NEES "
            << scaled / converged << " (residuals alone " << residual_only / converged << ")\n";
  EXPECT_GE(scaled / converged, 3.0);
  EXPECT_LE(scaled / converged, 12.0);
}

// covarianceScale() belongs to the last alignment: computed once, kept until the next
// align(), and 1 once new clouds were prepared before it was asked (evaluate() after
// setInputSource()) or the resolution changed, since the result's cells are gone then.
TEST(Registration, TheCovarianceScaleBelongsToTheLastAlignment)
{
  // Halves of a Riverside scan, which the scale widens (see the test above).
  pcl::PointCloud<pcl::PointXYZI> xyzi;
  ASSERT_EQ(pcl_mi::io::loadKittiBin(std::string(PCL_MI_DATA_DIR) +
                                         "/foreign_lidar/mulran_riverside02_os1/scans/000002.bin",
                                     xyzi),
            "");
  Cloud scan;
  pcl::copyPointCloud(xyzi, scan);
  Cloud::Ptr target, source;
  splitAndMove(scan, test_data::planarMotion(0.6, 0.0, 2.0), target, source);
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setInputTarget(target);
  reg.setInputSource(source);
  Cloud aligned;
  reg.align(aligned);
  ASSERT_TRUE(reg.hasConverged()) << reg.getLastError();
  const double scale = reg.core().covarianceScale();
  EXPECT_GT(scale, 1.0);
  EXPECT_EQ(reg.core().covarianceScale(), scale);
  EXPECT_TRUE(reg.getCovariance().isApprox(scale * reg.getVerification().covariance));

  // The same alignment again gives the same scale, computed anew.
  reg.align(aligned);
  EXPECT_EQ(reg.core().covarianceScale(), scale);

  // New clouds prepared before it is asked: nothing left to refine the result on.
  reg.align(aligned);
  reg.setInputSource(target);
  reg.evaluate(Eigen::Matrix4f::Identity());
  EXPECT_EQ(reg.core().covarianceScale(), 1.0);
  EXPECT_TRUE(reg.getCovariance().isApprox(reg.getVerification().covariance));

  // Nor after a new resolution: the cells it was found on are not the problem's now.
  reg.setInputSource(source);
  reg.align(aligned);
  reg.setResolution(2.0);
  EXPECT_EQ(reg.core().covarianceScale(), 1.0);
}

namespace {

/** The turn R = Rz(yaw) Ry(pitch) Rx(roll), angles in degrees, as a 4x4 transform. */
Eigen::Matrix4d
turnDegrees(double roll, double pitch, double yaw)
{
  Eigen::Matrix4d turn = Eigen::Matrix4d::Identity();
  turn.topLeftCorner<3, 3>() = (Eigen::AngleAxisd(yaw * M_PI / 180.0, Eigen::Vector3d::UnitZ()) *
                                Eigen::AngleAxisd(pitch * M_PI / 180.0, Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(roll * M_PI / 180.0, Eigen::Vector3d::UnitX()))
                                   .toRotationMatrix();
  return turn;
}

/** Aligns \a source onto \a target (\a forward) or \a target onto \a source with the
 * defaults, and expects a leveled search, a converged result and \a reference (source to
 * target) or its inverse. */
void
expectLeveledAlignment(const Cloud::Ptr& source,
                       const Cloud::Ptr& target,
                       const Eigen::Matrix4d& reference,
                       bool forward)
{
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setInputSource(forward ? source : target);
  reg.setInputTarget(forward ? target : source);
  Cloud aligned;
  reg.align(aligned);
  EXPECT_TRUE(reg.getLastResult().leveled);
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_POSE_NEAR(reg.getFinalTransformation().cast<double>(),
                   forward ? reference : Eigen::Matrix4d(reference.inverse()));
}

} // namespace

// A sensor carried tilted: the bundled Ouster pair with its source turned about the sensor
// by tens of degrees of roll and pitch (and some yaw), in both directions. The clouds' up
// directions disagree, the search starts leveled and finds the pose; the same pair taken
// level is not leveled.
TEST(Registration, ATiltedSensorIsSearchedFromTheLeveledGuess)
{
  Cloud::Ptr source, target;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(loadBundledPair("seosan01_ouster128", source, target, reference));
  for (const auto& [roll, pitch, yaw] :
       {std::make_tuple(25.0, -20.0, 30.0), std::make_tuple(-15.0, 35.0, -60.0)}) {
    const Eigen::Matrix4d turned = turnDegrees(roll, pitch, yaw);
    auto tilted = pcl::make_shared<Cloud>();
    pcl::transformPointCloud(*source, *tilted, turned.cast<float>());
    for (const bool forward : {true, false}) {
      SCOPED_TRACE(testing::Message() << "roll " << roll << ", pitch " << pitch << ", yaw "
                                      << yaw << (forward ? ", forward" : ", backward"));
      expectLeveledAlignment(tilted, target, reference * turned.inverse(), forward);
    }
  }
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setInputSource(source);
  reg.setInputTarget(target);
  Cloud aligned;
  reg.align(aligned);
  EXPECT_FALSE(reg.getLastResult().leveled);
  reg.setLeveling(false);
  EXPECT_FALSE(reg.getLeveling());
  EXPECT_FALSE(pcl_mi::Parameters::paper().search.leveling);
}

// A sensor mounted tilted on its vehicle: both scans of the bundled KITTI pair of sequence 02
// (8.5 m apart) turned by one roll and pitch. Their up directions agree, so the guess needs
// no turn, but the car still moves along the ground and turns about up: the search is
// leveled all the same. Searched along the sensor's own axes instead, this pair ended
// metres off in both directions at 30 deg of pitch.
TEST(Registration, ASensorMountedTiltedIsSearchedAlongTheGround)
{
  const auto source = test_data::loadScan("02", 6);
  const auto target = test_data::loadScan("02", 0);
  const Eigen::Matrix4d reference = test_data::referenceTransform("02", 0, 6);
  for (const auto& [roll, pitch] : {std::make_pair(0.0, 30.0), std::make_pair(-15.0, -40.0)}) {
    const Eigen::Matrix4d mount = turnDegrees(roll, pitch, 0.0);
    auto tilted_source = pcl::make_shared<Cloud>();
    auto tilted_target = pcl::make_shared<Cloud>();
    pcl::transformPointCloud(*source, *tilted_source, mount.cast<float>());
    pcl::transformPointCloud(*target, *tilted_target, mount.cast<float>());
    for (const bool forward : {true, false}) {
      SCOPED_TRACE(testing::Message() << "roll " << roll << ", pitch " << pitch
                                      << (forward ? ", forward" : ", backward"));
      expectLeveledAlignment(tilted_source, tilted_target, mount * reference * mount.inverse(),
                             forward);
    }
  }
}

// The fourth bundled Livox pair (1.4 m and 9 deg apart on a walk), source the later scan:
// the surfaces leave only the yaw free, so the verdict first refuses it as degenerate;
// restarts of the refinement from 2 deg turns all come back to it, the sensors stand more
// than a voxel apart, and judged again with the turn held it converges, within the bound.
TEST(Registration, AFreeTurnThatTheRefinementHoldsConverges)
{
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(alignBundledPair("livox_avia_hku1", 3, reg, reference));
  const pcl_mi::Verification& v = reg.getVerification();
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_TRUE(v.free_turns_held);
  EXPECT_LT(v.restart_turn_deg, 1.0);
  EXPECT_LT(v.restart_shift, 0.25);
  EXPECT_GE(reg.getConfidence(), 0.95);
  EXPECT_GT(reg.getCovariance().diagonal().minCoeff(), 0.0);
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
}

// The same pair with the search capped at 300 iterations: the refinement's hold does not
// depend on whether the simplex met its tolerance, so the turn is held all the same, and the
// result passes as a capped one does, for the clouds swapped to confirm.
TEST(Registration, AFreeTurnThatTheRefinementHoldsIsHeldWhereTheSearchWasCapped)
{
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setMaximumIterations(300);
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(alignBundledPair("livox_avia_hku1", 3, reg, reference));
  const pcl_mi::Verification& v = reg.getVerification();
  EXPECT_FALSE(reg.getLastResult().search_converged);
  EXPECT_TRUE(v.free_turns_held);
  EXPECT_TRUE(v.reverse_confirmed);
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
}

// The first bundled Livox pair (2.9 m and 38 deg apart on a walk) the other way, source the
// earlier scan: the verdict holds the result back, and the alignment of the clouds swapped,
// from the inverse of the guess, ends within 0.25 m and 0.5 deg of it and confirms it.
TEST(Registration, TheCloudsSwappedConfirmAResultTheVerdictHeldBack)
{
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(alignBundledPair("livox_avia_hku1", 0, reg, reference, true));
  const pcl_mi::Verification& v = reg.getVerification();
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_TRUE(v.reverse_confirmed);
  EXPECT_LT(v.reverse_shift, 0.25);
  EXPECT_LT(v.reverse_turn_deg, 0.5);
  EXPECT_GE(reg.getConfidence(), 0.95);
  EXPECT_GT(reg.getCovariance().diagonal().minCoeff(), 0.0);
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
  const bool swapped_counted = std::any_of(
      reg.getLastResult().stages.begin(), reg.getLastResult().stages.end(),
      [](const pcl_mi::StageTiming& t) { return t.name == "reverse confirmation"; });
  EXPECT_TRUE(swapped_counted);
}

// The fifth bundled Livox pair (5.9 m and 34 deg apart on a walk): the verdict holds every
// direction but finds the evidence weak, and the alignment of the clouds swapped ends 0.06 m
// and 0.1 deg away but leaves a direction free itself. A free side says nothing along its
// free direction; the result's own evidence holds it, so the two together confirm it, and the
// result keeps its own covariance. (Before, a free other side confirmed nothing, and this
// result was held back.)
TEST(Registration, ASideThatLeavesADirectionFreeConfirmsAResultThatHoldsEveryDirection)
{
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(alignBundledPair("livox_avia_hku1", 4, reg, reference));
  const pcl_mi::Verification& v = reg.getVerification();
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_TRUE(v.reverse_confirmed);
  EXPECT_LT(v.reverse_shift, 0.25);
  EXPECT_LT(v.reverse_turn_deg, 0.5);
  EXPECT_GT(reg.getCovariance().diagonal().minCoeff(), 0.0);
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
}

// The ninth bundled Livox pair (4.1 m and 21 deg apart on a walk), both ways: each way leaves
// a direction free (one a roll, the other a shift across), and the alignment of the clouds
// swapped, free along the other one, ends within 0.02 m and 0.1 deg. Each side holds what the
// other leaves free, so together they hold every direction: the result converges, with the
// inverse of the two sides' mean information as its covariance. (Before, a degenerate result
// needed a swapped side that holds every direction, and both ways were held back.)
TEST(Registration, TwoSidesFreeAlongDifferentDirectionsConfirmEachOther)
{
  for (const bool swapped : {false, true}) {
    SCOPED_TRACE(swapped);
    pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
    Eigen::Matrix4d reference;
    ASSERT_NO_FATAL_FAILURE(alignBundledPair("livox_avia_hku1", 8, reg, reference, swapped));
    const pcl_mi::Verification& v = reg.getVerification();
    EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
    EXPECT_TRUE(v.reverse_confirmed);
    EXPECT_LT(std::min(v.free_direction_contrast[0], v.free_direction_contrast[1]), 0.05)
        << "this side holds every direction itself";
    EXPECT_GT(reg.getCovariance().diagonal().minCoeff(), 0.0);
    EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
  }
}

// The fifth bundled quickshack pair (a Livox turned 44 deg on the spot in a small room): this
// side's samples find too few target surfaces (26) to hold a pose, but the alignment of the
// clouds swapped, which samples the other cloud, finds enough, holds every direction and
// ends within 0.01 m and 0.5 deg: it confirms the result and lends it its covariance.
// (Before, a result with too little shared surface was never asked of the other side.)
TEST(Registration, TheCloudsSwappedConfirmAResultWithTooLittleSharedSurface)
{
  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(alignBundledPair("livox_avia_quickshack", 4, reg, reference));
  const pcl_mi::Verification& v = reg.getVerification();
  EXPECT_TRUE(reg.hasConverged()) << reg.getLastError();
  EXPECT_TRUE(v.reverse_confirmed);
  EXPECT_LT(v.inliers, 30u); // the fewest the verdict asks of a pose of its own
  EXPECT_GT(reg.getCovariance().diagonal().minCoeff(), 0.0);
  EXPECT_SAMPLE_POSE_NEAR(reg.getFinalTransformation().cast<double>(), reference);
}

TEST(Registration, InOtherUnitsWithTheUnitsSetTheResultIsTheOneInMetres)
{
  // Everything follows the resolution but a few lengths kept in metres: the verdict's (a
  // held-back result's restarts, its confirmation by the clouds swapped) and the
  // refinement's (its smallest step, the lever arm that weighs its turns). With
  // Parameters::units_per_metre set, clouds at 1024 units a metre (a power of two scales the
  // points exactly) give the result in metres, verdict and confidence included. This pair
  // takes both ways to converge, one direction confirmed by the clouds swapped, the other
  // with the turns the refinement holds; before the setting, neither converged at 1024.
  Cloud::Ptr first, second;
  Eigen::Matrix4d reference;
  ASSERT_NO_FATAL_FAILURE(loadBundledPair("livox_avia_hku1", first, second, reference));
  struct Outcome {
    bool converged;
    Eigen::Matrix4d pose; // translation in metres
    pcl_mi::Verification verification;
  };
  auto align = [](const Cloud::Ptr& source, const Cloud::Ptr& target, double units) {
    const Eigen::Affine3f scale(Eigen::Scaling(static_cast<float>(units)));
    Cloud::Ptr scaled_source(new Cloud), scaled_target(new Cloud);
    pcl::transformPointCloud(*source, *scaled_source, scale);
    pcl::transformPointCloud(*target, *scaled_target, scale);
    pcl::MutualInformationRegistration<pcl::PointXYZ, pcl::PointXYZ, double> reg;
    pcl_mi::Parameters p = reg.getParameters();
    p.units_per_metre = units;
    reg.setParameters(p);
    reg.setInputSource(scaled_source);
    reg.setInputTarget(scaled_target);
    Cloud aligned;
    reg.align(aligned);
    Eigen::Matrix4d pose = reg.getFinalTransformation();
    pose.topRightCorner<3, 1>() /= units;
    return Outcome{reg.hasConverged(), pose, reg.getVerification()};
  };
  for (const bool swapped : {false, true}) {
    SCOPED_TRACE(swapped ? "first onto second" : "second onto first");
    const Cloud::Ptr& source = swapped ? first : second;
    const Cloud::Ptr& target = swapped ? second : first;
    const Outcome metres = align(source, target, 1.0);
    const Outcome units = align(source, target, 1024.0);
    EXPECT_TRUE(metres.converged) << metres.verification.reason;
    EXPECT_EQ(units.converged, metres.converged) << units.verification.reason;
    EXPECT_TRUE(units.pose.isApprox(metres.pose, 1e-9));
    EXPECT_EQ(units.verification.reverse_confirmed, metres.verification.reverse_confirmed);
    EXPECT_EQ(units.verification.free_turns_held, metres.verification.free_turns_held);
    EXPECT_EQ(units.verification.refusal, metres.verification.refusal);
    EXPECT_NEAR(units.verification.confidence, metres.verification.confidence, 1e-9);
  }
}
