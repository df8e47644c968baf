/*
 * Readers: KITTI calibration/poses and the velodyne-frame conversion, scan files, matrices.
 */
#include "test_data.h"

#include <pcl_mi/io.h>
#include <pcl_mi/kitti.h>

#include <pcl/io/pcd_io.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

namespace {

std::string
writeTemp(const std::string& name, const std::string& content)
{
  const std::string path = testing::TempDir() + name;
  std::ofstream(path, std::ios::binary) << content;
  return path;
}

} // namespace

TEST(Kitti, VelodynePoseHandComputed)
{
  // Tr swaps axes like KITTI's (velodyne x forward -> camera z forward); the camera moves
  // 2 m forward (camera z). In the velodyne frame that is 2 m along x.
  Eigen::Matrix4d tr;
  tr << 0, -1, 0, 0,  //
      0, 0, -1, 0,    //
      1, 0, 0, 0,     //
      0, 0, 0, 1;
  Eigen::Matrix4d cam = Eigen::Matrix4d::Identity();
  cam(2, 3) = 2.0;
  const Eigen::Matrix4d velo = pcl_mi::kitti::velodynePose(tr, cam);
  EXPECT_TRUE(velo.isApprox(test_data::planarMotion(2.0, 0.0, 0.0), 1e-12)) << velo;
  // Relative transform: scan j (at +2 m) into scan i (at 0): points move forward by 2 m.
  const Eigen::Matrix4d rel =
      pcl_mi::kitti::relativeVelodyneTransform(tr, Eigen::Matrix4d::Identity(), cam);
  EXPECT_TRUE(rel.isApprox(test_data::planarMotion(2.0, 0.0, 0.0), 1e-12)) << rel;
}

TEST(Kitti, BundledPairMatchesIndependentDerivation)
{
  // ../shared/data/kitti_odometry/pairs_velo.csv, row "00,0,9,semantickitti" (float64,
  // computed outside this project): tx, ty, tz and r11.
  const Eigen::Matrix4d t = test_data::referenceTransform("00", 0, 9);
  EXPECT_NEAR(t(0, 3), 6.6831862, 1e-6);
  EXPECT_NEAR(t(1, 3), 0.169442788, 1e-6);
  EXPECT_NEAR(t(2, 3), 0.0827515684, 1e-6);
  EXPECT_NEAR(t(0, 0), 0.999257882, 1e-8);
}

TEST(Kitti, ReadersReportBadFiles)
{
  Eigen::Matrix4d tr;
  std::vector<Eigen::Matrix4d> poses;
  EXPECT_NE(pcl_mi::kitti::loadCalibrationTr("/nonexistent/calib.txt", tr), "");
  EXPECT_NE(pcl_mi::kitti::loadCalibrationTr(writeTemp("calib_no_tr.txt", "P0: 1 2 3\n"), tr)
                .find("no 'Tr:'"),
            std::string::npos);
  EXPECT_NE(pcl_mi::kitti::loadCalibrationTr(writeTemp("calib_short.txt", "Tr: 1 2 3\n"), tr), "");
  EXPECT_NE(pcl_mi::kitti::loadPoses(writeTemp("poses_bad.txt", "1 0 0 0 0 1 0 0 0 0 1\n"), poses)
                .find("line 1"),
            std::string::npos);
  EXPECT_EQ(pcl_mi::kitti::loadPoses(writeTemp("poses_ok.txt", "1 0 0 5 0 1 0 0 0 0 1 0\n"), poses), "");
  ASSERT_EQ(poses.size(), 1u);
  EXPECT_EQ(poses[0](0, 3), 5.0);
}

TEST(CloudIo, KittiBinAndErrors)
{
  const float data[8] = {1, 2, 3, 0.5f, -1, -2, -3, 0.25f};
  const std::string bin = writeTemp("two.bin", std::string(reinterpret_cast<const char*>(data), sizeof(data)));
  pcl::PointCloud<pcl::PointXYZI> cloud;
  ASSERT_EQ(pcl_mi::io::loadCloud(bin, cloud), "");
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_EQ(cloud[1].z, -3.0f);
  EXPECT_EQ(cloud[0].intensity, 0.5f);

  EXPECT_NE(pcl_mi::io::loadCloud(writeTemp("odd.bin", "12345"), cloud).find("multiple of 16"),
            std::string::npos);
  EXPECT_NE(pcl_mi::io::loadCloud(writeTemp("empty.bin", ""), cloud), "");
  EXPECT_NE(pcl_mi::io::loadCloud("/nonexistent.pcd", cloud).find("cannot open"), std::string::npos);
  EXPECT_NE(pcl_mi::io::loadCloud(writeTemp("junk.pcd", "not a pcd file\n"), cloud), "");
  EXPECT_NE(pcl_mi::io::loadCloud(writeTemp("cloud.xyz", "1 2 3\n"), cloud).find("unknown format"),
            std::string::npos);
}

TEST(CloudIo, TransformFiles)
{
  Eigen::Matrix4d t;
  EXPECT_EQ(pcl_mi::io::loadTransform(writeTemp("t16.txt", "1 0 0 1\n0 1 0 2\n0 0 1 3\n0 0 0 1\n"), t), "");
  EXPECT_EQ(t(1, 3), 2.0);
  EXPECT_EQ(pcl_mi::io::loadTransform(writeTemp("t12.txt", "1,0,0,4, 0,1,0,5, 0,0,1,6"), t), "");
  EXPECT_EQ(t(2, 3), 6.0);
  EXPECT_EQ(t(3, 3), 1.0);
  EXPECT_NE(pcl_mi::io::loadTransform(writeTemp("t5.txt", "1 2 3 4 5"), t), "");
  EXPECT_NE(pcl_mi::io::loadTransform(writeTemp("tx.txt", "1 0 0 x"), t), "");

  // What saveTransform() writes reads back as the same doubles.
  const Eigen::Matrix4d written = test_data::planarMotion(1.0 / 3.0, -2e-7, 17.25);
  const std::string path = writeTemp("saved.txt", "");
  EXPECT_EQ(pcl_mi::io::saveTransform(path, written), "");
  EXPECT_EQ(pcl_mi::io::loadTransform(path, t), "");
  EXPECT_EQ(t, written);
  EXPECT_NE(pcl_mi::io::saveTransform("/nonexistent/dir/t.txt", written).find("cannot write"),
            std::string::npos);
}

TEST(CloudIo, PoseErrorOfKnownOffsets)
{
  const Eigen::Matrix4d ref = test_data::planarMotion(3, 4, 30);
  const auto e = pcl_mi::io::poseError(test_data::planarMotion(0.3, 0.4, 0) * ref, ref);
  EXPECT_NEAR(e.translation, 0.5, 1e-9);
  EXPECT_NEAR(e.rotation_deg, 0.0, 1e-6);
  const auto r = pcl_mi::io::poseError(ref * test_data::planarMotion(0, 0, 2), ref);
  EXPECT_NEAR(r.rotation_deg, 2.0, 1e-9);
}

TEST(CloudIo, FuzzFoundInputsGiveErrorsNotCrashes)
{
  // Every file in test/data/fuzz_regressions was a crash found by fuzz/fuzz_readers.
  for (const char* name : {"pcd_header_throws.pcd", "pcd_huge_count.pcd", "pcd_duplicate_field.pcd",
                           "ply_huge_element_count.ply", "pcd_garbage_points.pcd",
                           "pcd_garbage_height.pcd", "pcd_state_corruption.pcd",
                           "pcd_int8_out_of_range.pcd"}) {
    SCOPED_TRACE(name);
    pcl::PointCloud<pcl::PointXYZI> cloud;
    const std::string error = pcl_mi::io::loadCloud(
        std::string(PCL_MI_TEST_DATA_DIR) + "/fuzz_regressions/" + name, cloud);
    // An error, or a cloud; the sanitizer build (scripts/hardening.sh) checks for UB.
    EXPECT_TRUE(!error.empty() || !cloud.empty());
  }
}

TEST(CloudIo, ConvertsCoordinatesOfAnyNumericType)
{
  // pcl::fromPCLPointCloud2 leaves non-float32 coordinates at zero; the loader must not.
  const std::string path = testing::TempDir() + "pcl_mi_double.pcd";
  {
    std::ofstream out(path);
    out << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 8 8 2\nTYPE F F I\nCOUNT 1 1 1\n"
           "WIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n"
           "1000000.25 -2.5 7\n3.125 4 -9\n";
  }
  pcl::PointCloud<pcl::PointXYZI> cloud;
  ASSERT_EQ(pcl_mi::io::loadCloud(path, cloud), "");
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_FLOAT_EQ(cloud[0].x, 1000000.25f);
  EXPECT_FLOAT_EQ(cloud[0].y, -2.5f);
  EXPECT_FLOAT_EQ(cloud[0].z, 7.0f);
  EXPECT_FLOAT_EQ(cloud[1].x, 3.125f);
  EXPECT_FLOAT_EQ(cloud[1].z, -9.0f);
  std::remove(path.c_str());
}

// Drivers write their own point layouts: the Ouster driver pads with fields named "_", the
// Livox driver mixes 1-byte fields with a double timestamp, and a layout need not start with
// x. Each is read as PCL reads it.
TEST(CloudIo, ReadsDriverPointLayouts)
{
  struct Layout {
    const char* name;
    const char* fields;
    const char* types;
    std::vector<int> size_of; // bytes per field
    int x, intensity;         // field index of x (y and z follow) and of the intensity
  };
  const std::vector<Layout> layouts = {
      {"ouster", "x y z _ intensity t reflectivity ring ambient _ range", "F F F F F U U U U U U",
       {4, 4, 4, 4, 4, 4, 2, 2, 2, 2, 4}, 0, 4},
      {"livox", "x y z intensity tag line timestamp", "F F F F U U F", {4, 4, 4, 4, 1, 1, 8}, 0, 3},
      {"intensity_first", "intensity ring x y z time", "F U F F F F", {4, 2, 4, 4, 4, 4}, 2, 0},
  };
  for (const Layout& layout : layouts) {
    SCOPED_TRACE(layout.name);
    const int points = 5;
    std::string body;
    for (int i = 0; i < points; ++i)
      for (std::size_t f = 0; f < layout.size_of.size(); ++f) {
        const int k = static_cast<int>(f);
        std::string bytes(static_cast<std::size_t>(layout.size_of[f]), '\x5a'); // padding, ids
        if (k >= layout.x && k < layout.x + 3) {
          const float v = 1.5f * static_cast<float>(i) - 2.25f * static_cast<float>(k - layout.x);
          bytes.assign(reinterpret_cast<const char*>(&v), sizeof v);
        }
        else if (k == layout.intensity) {
          const float v = 10.0f + static_cast<float>(i);
          bytes.assign(reinterpret_cast<const char*>(&v), sizeof v);
        }
        body += bytes;
      }
    std::string sizes, counts;
    for (const int size : layout.size_of) {
      sizes += " " + std::to_string(size);
      counts += " 1";
    }
    const std::string n = std::to_string(points);
    const std::string path = writeTemp(
        std::string("pcl_mi_") + layout.name + ".pcd",
        std::string("# .PCD v0.7\nVERSION 0.7\nFIELDS ") + layout.fields + "\nSIZE" + sizes +
            "\nTYPE " + layout.types + "\nCOUNT" + counts + "\nWIDTH " + n +
            "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + n + "\nDATA binary\n" + body);
    pcl::PointCloud<pcl::PointXYZI> by_pcl, by_pcl_mi;
    ASSERT_EQ(pcl::io::loadPCDFile(path, by_pcl), 0);
    ASSERT_EQ(pcl_mi::io::loadCloud(path, by_pcl_mi), "");
    ASSERT_EQ(by_pcl_mi.size(), static_cast<std::size_t>(points));
    for (int i = 0; i < points; ++i) {
      const pcl::PointXYZI& p = by_pcl_mi[i];
      EXPECT_EQ(p.x, 1.5f * static_cast<float>(i)) << i;
      EXPECT_EQ(p.y, 1.5f * static_cast<float>(i) - 2.25f) << i;
      EXPECT_EQ(p.z, 1.5f * static_cast<float>(i) - 4.5f) << i;
      EXPECT_EQ(p.intensity, 10.0f + static_cast<float>(i)) << i;
      EXPECT_EQ(p.getVector3fMap(), by_pcl[i].getVector3fMap()) << i;
      EXPECT_EQ(p.intensity, by_pcl[i].intensity) << i;
    }
    std::remove(path.c_str());
  }
}

TEST(CloudIo, SavedPcdReadsBackInPclAndPclMi)
{
  // Organised (width x height), more than one write chunk (65536 points), a viewpoint.
  pcl::PointCloud<pcl::PointXYZI> cloud(350, 200);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    cloud[i].x = 0.25f * static_cast<float>(i);
    cloud[i].y = -static_cast<float>(i % 97);
    cloud[i].z = 1e-3f * static_cast<float>(i % 13);
    cloud[i].intensity = static_cast<float>(i % 256);
  }
  cloud[7].x = std::numeric_limits<float>::quiet_NaN(); // a beam without a return
  cloud.is_dense = false;
  cloud.sensor_origin_ = Eigen::Vector4f(1.0f, 2.0f, 3.0f, 0.0f);
  const std::string path = testing::TempDir() + "pcl_mi_saved.pcd";
  ASSERT_EQ(pcl_mi::io::savePcd(path, cloud), "");

  pcl::PointCloud<pcl::PointXYZI> by_pcl;
  ASSERT_EQ(pcl::io::loadPCDFile(path, by_pcl), 0);
  ASSERT_EQ(by_pcl.width, cloud.width);
  ASSERT_EQ(by_pcl.height, cloud.height);
  EXPECT_EQ(by_pcl.sensor_origin_.head<3>(), cloud.sensor_origin_.head<3>());
  pcl::PointCloud<pcl::PointXYZI> by_pcl_mi;
  ASSERT_EQ(pcl_mi::io::loadCloud(path, by_pcl_mi), "");
  ASSERT_EQ(by_pcl_mi.size(), cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    for (const auto* read : {&by_pcl, &by_pcl_mi}) {
      const pcl::PointXYZI& p = (*read)[i];
      if (i == 7) {
        ASSERT_TRUE(std::isnan(p.x)) << i;
        continue;
      }
      ASSERT_EQ(p.x, cloud[i].x) << i;
      ASSERT_EQ(p.y, cloud[i].y) << i;
      ASSERT_EQ(p.z, cloud[i].z) << i;
      ASSERT_EQ(p.intensity, cloud[i].intensity) << i;
    }
  std::remove(path.c_str());

  EXPECT_NE(pcl_mi::io::savePcd(testing::TempDir(), cloud), "") << "a directory is not a file";
}

TEST(CloudIo, MergedPcdReadsBackAsTheTwoCloudsColoured)
{
  // More than one write chunk (65536 points), so chunk boundaries are covered.
  pcl::PointCloud<pcl::PointXYZI> target, aligned;
  for (int i = 0; i < 70000; ++i) {
    pcl::PointXYZI p;
    p.x = 0.25f * static_cast<float>(i);
    p.y = -static_cast<float>(i % 97);
    p.z = 1e-3f * static_cast<float>(i % 13);
    p.intensity = 0.5f;
    (i % 3 == 0 ? aligned : target).push_back(p);
  }
  const std::string path = testing::TempDir() + "pcl_mi_merged.pcd";
  ASSERT_EQ(pcl_mi::io::saveMergedPcd(path, target, aligned), "");

  pcl::PointCloud<pcl::PointXYZRGB> read;
  ASSERT_EQ(pcl::io::loadPCDFile(path, read), 0);
  ASSERT_EQ(read.size(), target.size() + aligned.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    const bool is_target = i < target.size();
    const pcl::PointXYZI& in = is_target ? target[i] : aligned[i - target.size()];
    ASSERT_EQ(read[i].x, in.x) << i;
    ASSERT_EQ(read[i].y, in.y) << i;
    ASSERT_EQ(read[i].z, in.z) << i;
    ASSERT_EQ(read[i].r, is_target ? 170 : 230) << i;
    ASSERT_EQ(read[i].g, is_target ? 170 : 40) << i;
    ASSERT_EQ(read[i].b, is_target ? 170 : 40) << i;
  }
  std::remove(path.c_str());

  EXPECT_NE(pcl_mi::io::saveMergedPcd(testing::TempDir(), target, aligned), "")
      << "a directory is not a writable file";
}
