/*
 * One regression test per defect class of docs/hardening.md (an adversarial corpus of
 * crafted files and API misuse). Each test names its class; scripts/hardening.sh runs them
 * under AddressSanitizer and UndefinedBehaviorSanitizer.
 */
#include "test_data.h"

#include <pcl_mi/io.h>
#include <pcl_mi/mutual_information_registration.h>

#include <pcl/io/pcd_io.h>

#include <gtest/gtest.h>

#include <sys/stat.h>

#include <cfloat>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Registration = pcl::MutualInformationRegistration<pcl::PointXYZ>;

namespace {

std::string
tempPath(const std::string& name)
{
  return testing::TempDir() + "pcl_mi_hardening_" + name;
}

std::string
write(const std::string& name, const std::string& bytes)
{
  const std::string path = tempPath(name);
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  return path;
}

std::string
load(const std::string& path, pcl::PointCloud<pcl::PointXYZI>& cloud)
{
  return pcl_mi::io::loadCloud(path, cloud);
}

/** A PCD header with \a fields float fields of COUNT \a count each. */
std::string
pcdHeader(int fields, int count, std::uint64_t width, const std::string& data)
{
  std::ostringstream s;
  s << "VERSION 0.7\nFIELDS x y z";
  for (int f = 3; f < fields; ++f)
    s << " f" << f;
  s << "\nSIZE";
  for (int f = 0; f < fields; ++f)
    s << " 4";
  s << "\nTYPE";
  for (int f = 0; f < fields; ++f)
    s << " F";
  s << "\nCOUNT";
  for (int f = 0; f < fields; ++f)
    s << " " << count;
  s << "\nWIDTH " << width << "\nHEIGHT 1\nPOINTS " << width << "\nDATA " << data << "\n";
  return s.str();
}

Cloud::Ptr
cloudOf(const std::vector<Eigen::Vector3f>& points)
{
  auto cloud = pcl::make_shared<Cloud>();
  for (const auto& p : points)
    cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  return cloud;
}

class Hardening : public ::testing::Test {
protected:
  static void
  SetUpTestSuite()
  {
    source_ = test_data::loadScan("00", 9);
    target_ = test_data::loadScan("00", 0);
  }
  static Cloud::Ptr source_, target_;
};
Cloud::Ptr Hardening::source_, Hardening::target_;

} // namespace

// Class 1: size arithmetic of the readers in 64 bits, checked against the file's size.
TEST(HardeningIo, Class1ReaderSizeArithmeticDoesNotWrap)
{
  pcl::PointCloud<pcl::PointXYZI> cloud;
  // 4 fields x COUNT 4352 x 4 bytes x WIDTH 61681 = 2^32 + 69632: wrapped to 69632 bytes in
  // 32 bits, and the ASCII reader wrote past that buffer.
  std::string data(130000, ' ');
  for (std::size_t i = 0; i < data.size(); i += 2)
    data[i] = '1';
  EXPECT_NE(load(write("wrap.pcd", pcdHeader(4, 4352, 61681, "ascii") + data), cloud), "");
  // A product of exactly 2^32 (wrapped to 0 bytes: a write through a null pointer).
  EXPECT_NE(load(write("wrap0.pcd", pcdHeader(4, 1024, 1u << 20, "ascii") + data), cloud), "");
  EXPECT_NE(load(write("wrap0b.pcd", pcdHeader(4, 1024, 1u << 20, "binary") + data), cloud), "");
  // WIDTH x HEIGHT beyond 64 bits.
  EXPECT_NE(load(write("wrap64.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 999999999999999\n"
                                     "HEIGHT 999999999999999\nDATA binary\n" + data),
                 cloud),
            "");
  // The same header sizes that do fit still load.
  ASSERT_EQ(load(write("fits.pcd", pcdHeader(3, 1, 2, "ascii") + "1 2 3\n4 5 6\n"), cloud), "");
  EXPECT_EQ(cloud.size(), 2u);
  EXPECT_EQ(cloud[1].z, 6.0f);
}

// Class 2: PCL's PLY reader aborted on a vertex list property of more than 255 entries;
// the own reader skips list properties of any length, in any element.
TEST(HardeningIo, Class2PlyListPropertiesOfAnyLengthAreSkipped)
{
  std::ostringstream ascii;
  ascii << "ply\nformat ascii 1.0\ncomment crafted\nelement face 1\n"
           "property list uchar int vertex_indices\nelement vertex 2\nproperty float x\n"
           "property list uint int neighbours\nproperty float y\nproperty float z\n"
           "property float intensity\nend_header\n3 0 1 2\n";
  for (int v = 0; v < 2; ++v) {
    ascii << 1.5 + v << " 300";
    for (int i = 0; i < 300; ++i)
      ascii << " " << i;
    ascii << " " << -2.0 - v << " " << 3.25 << " " << 7 << "\n";
  }
  pcl::PointCloud<pcl::PointXYZI> cloud;
  ASSERT_EQ(load(write("list.ply", ascii.str()), cloud), "");
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_EQ(cloud[1].x, 2.5f);
  EXPECT_EQ(cloud[1].y, -3.0f);
  EXPECT_EQ(cloud[1].z, 3.25f);
  EXPECT_EQ(cloud[1].intensity, 7.0f);

  // Binary, big-endian, with a list longer than the file: refused, not allocated.
  std::string binary = "ply\nformat binary_big_endian 1.0\nelement vertex 1\nproperty float x\n"
                       "property float y\nproperty float z\nproperty list uint int n\nend_header\n";
  const unsigned char point[] = {0x3f, 0x80, 0, 0, 0x40, 0, 0, 0, 0x40, 0x40, 0, 0, // 1 2 3
                                 0x7f, 0xff, 0xff, 0xff};                           // 2^31 - 1
  binary.append(reinterpret_cast<const char*>(point), sizeof point);
  EXPECT_NE(load(write("list_long.ply", binary), cloud), "");
  binary.replace(binary.size() - 4, 4, std::string(4, '\0')); // an empty list: valid
  ASSERT_EQ(load(write("list_empty.ply", binary), cloud), "");
  ASSERT_EQ(cloud.size(), 1u);
  EXPECT_EQ(cloud[0].x, 1.0f);
  EXPECT_EQ(cloud[0].y, 2.0f);
  EXPECT_EQ(cloud[0].z, 3.0f);
}

// Class 4: a binary_compressed header's claim is checked against what LZF can expand the
// file's bytes into before it is allocated; real compressed files still load.
TEST(HardeningIo, Class4CompressedSizeClaimsAreBoundedByTheFile)
{
  pcl::PointCloud<pcl::PointXYZ> points;
  for (int i = 0; i < 5000; ++i)
    points.push_back(pcl::PointXYZ(0.01f * i, std::sin(0.1f * i), 2.0f));
  const std::string real = tempPath("real_compressed.pcd");
  ASSERT_EQ(pcl::io::savePCDFileBinaryCompressed(real, points), 0);
  pcl::PointCloud<pcl::PointXYZI> cloud;
  ASSERT_EQ(load(real, cloud), "");
  ASSERT_EQ(cloud.size(), points.size());
  for (std::size_t i = 0; i < points.size(); i += 997) {
    EXPECT_EQ(cloud[i].x, points[i].x);
    EXPECT_EQ(cloud[i].y, points[i].y);
    EXPECT_EQ(cloud[i].z, points[i].z);
  }
  // A header announcing 1 GB of points whose data claims to unpack to 1 GB from 370 KB.
  const std::uint32_t points_announced = 1u << 26; // x 16 bytes = 1 GiB
  std::string file = "FIELDS x y z w\nSIZE 4 4 4 4\nTYPE F F F F\nWIDTH " +
                     std::to_string(points_announced) + "\nHEIGHT 1\nDATA binary_compressed\n";
  const std::uint32_t sizes[2] = {370000, points_announced * 16u};
  file.append(reinterpret_cast<const char*>(sizes), sizeof sizes);
  file.append(370000, '\x1f');
  const std::string error = load(write("bomb.pcd", file), cloud);
  EXPECT_NE(error.find("more than LZF can expand"), std::string::npos) << error;
  // A claim that disagrees with the header.
  const std::uint32_t wrong[2] = {16, 64};
  std::string small = pcdHeader(3, 1, 2, "binary_compressed");
  small.append(reinterpret_cast<const char*>(wrong), sizeof wrong);
  small.append(16, '\0');
  EXPECT_NE(load(write("wrong.pcd", small), cloud).find("header announces"), std::string::npos);
}

// Class 8: special files are refused before they are opened (a FIFO blocked forever).
TEST(HardeningIo, Class8SpecialFilesAreRefusedWithoutBlocking)
{
  const std::string fifo = tempPath("fifo.pcd");
  std::remove(fifo.c_str());
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  pcl::PointCloud<pcl::PointXYZI> cloud;
  EXPECT_NE(load(fifo, cloud).find("not a regular file"), std::string::npos);
  const std::string bin = tempPath("fifo.bin");
  std::remove(bin.c_str());
  ASSERT_EQ(::mkfifo(bin.c_str(), 0600), 0);
  EXPECT_NE(load(bin, cloud).find("not a regular file"), std::string::npos);
  Eigen::Matrix4d t;
  EXPECT_NE(pcl_mi::io::loadTransform(fifo, t).find("not a regular file"), std::string::npos);
  EXPECT_NE(load(testing::TempDir() + ".", cloud), ""); // a directory named like a file
  std::remove(fifo.c_str());
  std::remove(bin.c_str());
}

// Class 13: any number of comment lines, as PCL's reader takes; a header line of unbounded
// length is refused rather than read into memory whole.
TEST(HardeningIo, Class13LongHeadersAreRead)
{
  std::string comments;
  for (int i = 0; i < 500; ++i)
    comments += "# comment line " + std::to_string(i) + "\n";
  pcl::PointCloud<pcl::PointXYZI> cloud;
  ASSERT_EQ(load(write("comments.pcd", comments + pcdHeader(3, 1, 1, "ascii") + "1 2 3\n"), cloud),
            "");
  EXPECT_EQ(cloud.size(), 1u);
  EXPECT_NE(load(write("longline.pcd", "# " + std::string(1 << 17, 'x')), cloud), "");
  std::string ply = "ply\nformat ascii 1.0\n";
  for (int i = 0; i < 500; ++i)
    ply += "comment " + std::to_string(i) + "\n";
  ply += "element vertex 1\nproperty double x\nproperty double y\nproperty double z\nend_header\n"
         "1 2 3\n";
  ASSERT_EQ(load(write("comments.ply", ply), cloud), "");
  EXPECT_EQ(cloud[0].z, 3.0f);
}

// Class 5: clouds without structure at the resolution are refused, with the reason.
TEST_F(Hardening, Class5InformationFreeInputIsRefused)
{
  {
    Registration reg;
    reg.setInputSource(cloudOf({{1, 2, 3}, {1, 2, 3}, {1, 2, 3}}));
    reg.setInputTarget(target_);
    test_data::expectRefused(reg, "all lie at one position");
  }
  {
    std::vector<Eigen::Vector3f> line;
    for (int i = 0; i < 200; ++i)
      line.emplace_back(0.3f * i, 0.15f * i, 0.05f * i);
    Registration reg;
    reg.setInputSource(source_);
    reg.setInputTarget(cloudOf(line));
    test_data::expectRefused(reg, "lie on a line");
  }
  {
    Registration reg;
    reg.setResolution(1e30);
    reg.setInputSource(source_);
    reg.setInputTarget(target_);
    test_data::expectRefused(reg, "carries no structure at resolution 1e+30");
  }
}

// Class 6: a refusal by the base class's checks leaves no stale result behind.
TEST_F(Hardening, Class6NoStaleResultAfterARefusal)
{
  Registration reg;
  reg.setInputSource(source_);
  reg.setInputTarget(target_);
  Cloud output;
  reg.align(output);
  ASSERT_TRUE(reg.getLastError().empty()) << reg.getLastError();
  Eigen::Matrix4f guess = Eigen::Matrix4f::Identity();
  guess(0, 3) = 0.5f;
  reg.setInputSource(Cloud::Ptr());
  test_data::expectRefused(reg, "no source cloud", guess);
  Registration no_target;
  no_target.setInputSource(source_);
  test_data::expectRefused(no_target, "no target cloud", guess);
  reg.setInputSource(source_);
  reg.setInputTarget(Cloud::Ptr());
  test_data::expectRefused(reg, "no target cloud", guess);
}

// Class 7: restarts are bounded, and each costs the budget an iteration even when it
// starts inside the tolerance.
TEST_F(Hardening, Class7RestartsAreBounded)
{
  Registration reg;
  reg.setNumberOfRestarts(std::numeric_limits<int>::max());
  EXPECT_EQ(reg.getNumberOfRestarts(), 0);
  reg.setNumberOfRestarts(100);
  reg.setSimplexSteps((Registration::Vector6d() << 1e-6, 1e-6, 1e-6, 1e-7, 1e-7, 1e-7).finished());
  reg.setMaximumIterations(20);
  // The second and the reverse search's starts each cost a simplex, whatever the budget:
  // not the subject.
  reg.setSecondSearchHeadings(0);
  reg.setReverseSearch(false);
  reg.setInputSource(source_);
  reg.setInputTarget(target_);
  Cloud output;
  reg.align(output);
  // 100 restarts of 7 evaluations each would run; the budget of 20 ends them.
  EXPECT_LE(reg.getNumberOfEvaluations(), 300);
}

// Class 9: getFitnessScore() before any align(), and with targets FLANN cannot search.
TEST_F(Hardening, Class9FitnessScoreIsDefinedEverywhere)
{
  Registration fresh;
  EXPECT_EQ(fresh.getFitnessScore(), std::numeric_limits<double>::max());
  fresh.setInputSource(source_);
  fresh.setInputTarget(target_);
  const double before_align = fresh.getFitnessScore();
  EXPECT_GT(before_align, 0.0);
  EXPECT_LT(before_align, 100.0);

  auto target = pcl::make_shared<Cloud>(*target_);
  target->push_back(pcl::PointXYZ(FLT_MAX, 0, 0));
  target->push_back(pcl::PointXYZ(1e30f, -1e30f, 1e30f));
  target->push_back(pcl::PointXYZ(-FLT_MAX, FLT_MAX, 0));
  Registration reg;
  reg.setInputSource(source_);
  reg.setInputTarget(target);
  Cloud output;
  reg.align(output);
  EXPECT_TRUE(reg.getLastError().empty()) << reg.getLastError();
  const double score = reg.getFitnessScore();
  EXPECT_TRUE(std::isfinite(score));
  EXPECT_LT(score, 1.0);
}

// Class 10: indices out of range, stale or not, are an error instead of a read past the end.
TEST_F(Hardening, Class10IndicesOutOfRangeAreRefused)
{
  Registration reg;
  reg.setInputSource(source_);
  reg.setInputTarget(target_);
  auto indices = pcl::make_shared<pcl::Indices>();
  for (int i = 0; i < 1000; ++i)
    indices->push_back(i * 50);
  indices->push_back(static_cast<pcl::index_t>(source_->size()) + 7);
  reg.setIndices(indices);
  test_data::expectRefused(reg, "out of range");
  indices->pop_back();
  reg.setIndices(indices);
  Cloud output;
  reg.align(output);
  EXPECT_TRUE(reg.getLastError().empty()) << reg.getLastError();
  // Stale: the same indices for a smaller source.
  auto smaller = pcl::make_shared<Cloud>(*source_);
  smaller->resize(100);
  reg.setInputSource(smaller);
  test_data::expectRefused(reg, "out of range");
  EXPECT_LT(reg.evaluate(Eigen::Matrix4f::Identity()), 0.0);
}

// Class 11: each message names the real cause.
TEST_F(Hardening, Class11MessagesNameTheCause)
{
  {
    Registration reg;
    reg.setResolution(1e-6);
    reg.setInputSource(source_);
    reg.setInputTarget(target_);
    test_data::expectRefused(reg, "too fine");
  }
  {
    Registration reg;
    reg.setResolution(1e300);
    reg.setInputSource(source_);
    reg.setInputTarget(target_);
    test_data::expectRefused(reg, "no structure");
  }
  {
    Registration reg;
    reg.setInputSource(source_);
    reg.setInputTarget(target_);
    reg.setMaximumIterations(0);
    test_data::expectRefused(reg, "maximum iterations must be at least 1, got 0 (setMaximumIterations)");
  }
}

// Class 12: only rigid guesses are taken.
TEST_F(Hardening, Class12GuessesMustBeRigid)
{
  Registration reg;
  reg.setInputSource(source_);
  reg.setInputTarget(target_);
  Eigen::Matrix4f scaled = Eigen::Matrix4f::Identity();
  scaled.topLeftCorner<3, 3>() *= 2.0f;
  test_data::expectRefused(reg, "not a rigid transformation", scaled);
  test_data::expectRefused(reg, "not a rigid transformation", Eigen::Matrix4f::Zero());
  Eigen::Matrix4f mirror = Eigen::Matrix4f::Identity();
  mirror(2, 2) = -1.0f;
  test_data::expectRefused(reg, "reflection", mirror);
  // A float-rounded rotation is rigid.
  Eigen::Matrix4f turned = Eigen::Matrix4f::Identity();
  turned.topLeftCorner<3, 3>() =
      Eigen::AngleAxisf(0.3f, Eigen::Vector3f(0.2f, 0.1f, 1.0f).normalized()).toRotationMatrix();
  Cloud output;
  reg.align(output, turned);
  EXPECT_EQ(reg.getLastError().find("rigid"), std::string::npos) << reg.getLastError();
}

// Class 14: the far-outlier rule is exact (a gap of 64 voxels or more splits, whatever its
// alignment to any grid) and keeps the largest group; a large loss is warned about.
TEST_F(Hardening, Class14FarOutliersFollowAnExactRule)
{
  auto withGroup = [&](float offset, std::size_t every) {
    auto cloud = pcl::make_shared<Cloud>(*target_);
    for (std::size_t i = 0; i < target_->size(); i += every) {
      pcl::PointXYZ p = (*target_)[i];
      p.x += offset;
      cloud->push_back(p);
    }
    return cloud;
  };
  float max_x = -FLT_MAX;
  for (const auto& p : *target_)
    if (std::isfinite(p.x) && !(p.x == 0 && p.y == 0 && p.z == 0))
      max_x = std::max(max_x, p.x);
  float min_x = FLT_MAX;
  for (const auto& p : *target_)
    if (std::isfinite(p.x) && !(p.x == 0 && p.y == 0 && p.z == 0))
      min_x = std::min(min_x, p.x);
  const float span = max_x - min_x;
  // The copy's nearest point lies exactly `gap` beyond the scan's farthest one.
  for (const float gap : {60.0f, 64.5f, 110.0f}) {
    SCOPED_TRACE(gap);
    auto target = withGroup(span + gap, 2); // half the scan again: a third of all points
    Registration reg;
    // The gap is 64 voxels: at 1 m, the gaps above are metres. (A derived resolution would
    // follow the two groups' joint extent.)
    reg.setResolution(1.0);
    reg.setInputSource(source_);
    reg.setInputTarget(target);
    Cloud output;
    reg.align(output);
    ASSERT_TRUE(reg.getLastError().empty()) << reg.getLastError();
    const bool split = gap >= 64.0f;
    const std::size_t copied = target->size() - target_->size();
    EXPECT_GE(reg.core().droppedTargetPoints(), split ? copied : 0u);
    EXPECT_LT(reg.core().droppedTargetPoints(), split ? copied + 1000 : 1000u);
    ASSERT_EQ(reg.getLastResult().warnings.size(), split ? 1u : 0u);
    if (split)
      EXPECT_NE(reg.getLastResult().warnings[0].find("far outliers"), std::string::npos);
  }
}

// Inherited PCL setters that MI registration does not use warn once each, naming what to
// use instead, and keep PCL's getters.
TEST(PclContract, UnusedInheritedSettersWarnOnce)
{
  Registration reg;
  const auto warning = [&](auto&& call) {
    testing::internal::CaptureStderr();
    call();
    return testing::internal::GetCapturedStderr();
  };
  const std::string first = warning([&] { reg.setMaxCorrespondenceDistance(5.0); });
  EXPECT_NE(first.find("setMaxCorrespondenceDistance"), std::string::npos) << first;
  EXPECT_NE(first.find("setResolution()"), std::string::npos) << first;
  EXPECT_EQ(warning([&] { reg.setMaxCorrespondenceDistance(2.0); }), "");
  EXPECT_EQ(reg.getMaxCorrespondenceDistance(), 2.0);
  EXPECT_NE(warning([&] { reg.setTransformationEpsilon(1e-8); }).find("setTranslationTolerance()"),
            std::string::npos);
  EXPECT_NE(warning([&] { reg.setEuclideanFitnessEpsilon(1e-5); }).find("setRotationTolerance()"),
            std::string::npos);
  EXPECT_NE(warning([&] { reg.setRANSACOutlierRejectionThreshold(0.1); }).find("no correspondences"),
            std::string::npos);
  EXPECT_NE(warning([&] { reg.setRANSACIterations(10); }).find("no correspondences"),
            std::string::npos);
  EXPECT_EQ(reg.getClassName(), "MutualInformationRegistration");
}
