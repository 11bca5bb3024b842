#include "posekit/io/point_cloud_io.h"

#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include "posekit/core/error.h"
#include "testing/temp_dir.h"

using namespace posekit;

namespace {
PointCloud random_cloud(int n, bool normals) {
  PointCloud c;
  c.P = Eigen::MatrixXd::Random(n, 3) * 0.9;
  if (normals) c.N = Eigen::MatrixXd::Random(n, 3).rowwise().normalized();
  c.point_scalars["intensity"] = Eigen::VectorXd::LinSpaced(n, 0, 100);
  return c;
}
}  // namespace

TEST(PointCloudIo, RoundTripsEveryFormat) {
  test::TempDir dir;
  const PointCloud c = random_cloud(500, true);
  struct Case {
    const char* file;
    bool binary;
    double tol;
  };
  for (const Case& k : {Case{"a.pcd", false, 1e-6}, Case{"b.pcd", true, 1e-6}, Case{"a.ply", false, 1e-6}, Case{"b.ply", true, 1e-6},
                        Case{"c.xyz", false, 1e-15}}) {
    write_point_cloud(dir.file(k.file), c, {Unit::kMetre, CloudFormat::kAuto, k.binary});
    const PointCloud r = read_point_cloud(dir.file(k.file));
    ASSERT_EQ(r.size(), c.size()) << k.file;
    EXPECT_LE((r.P - c.P).cwiseAbs().maxCoeff(), k.tol) << k.file;
    ASSERT_TRUE(r.has_normals()) << k.file;
    EXPECT_LE((r.N - c.N).cwiseAbs().maxCoeff(), std::max(k.tol, 1e-6)) << k.file;
    if (std::string(k.file).find("xyz") == std::string::npos) {
      ASSERT_EQ(r.point_scalars.count("intensity"), 1u) << k.file;
      EXPECT_LE((r.point_scalars.at("intensity") - c.point_scalars.at("intensity")).cwiseAbs().maxCoeff(), 1e-5);
    }
  }
}

TEST(PointCloudIo, ScannerMillimetresBecomeMetres) {
  test::TempDir dir;
  const std::string path = dir.write("scan.xyz", "# x y z in mm\n1000 1700 -20\n0,5,10\n");
  const PointCloud c = read_point_cloud(path, {Unit::kMillimetre});
  ASSERT_EQ(c.size(), 2);
  EXPECT_NEAR(c.P(0, 1), 1.7, 1e-12);
  EXPECT_NEAR(c.P(1, 2), 0.01, 1e-12);
}

TEST(PointCloudIo, PclReadsOurPcdAndWeReadPclCompressedPcd) {
  test::TempDir dir;
  const PointCloud c = random_cloud(300, true);
  write_point_cloud(dir.file("ours.pcd"), c);
  pcl::PointCloud<pcl::PointNormal> pc;
  ASSERT_EQ(pcl::io::loadPCDFile(dir.file("ours.pcd"), pc), 0);
  ASSERT_EQ(pc.size(), 300u);
  EXPECT_NEAR(pc[17].x, c.P(17, 0), 1e-6);
  EXPECT_NEAR(pc[17].normal_z, c.N(17, 2), 1e-6);
  pcl::io::savePCDFileBinaryCompressed(dir.file("pcl.pcd"), pc);
  const PointCloud r = read_point_cloud(dir.file("pcl.pcd"));
  ASSERT_EQ(r.size(), 300);
  EXPECT_LE((r.P - c.P).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LE((r.N - c.N).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(PointCloudIo, ReadsPclCompressedPcdWithLongRepeats) {
  // Runs of equal records compress into LZF back-references of every length, overlapping the output.
  test::TempDir dir;
  pcl::PointCloud<pcl::PointXYZ> pc;
  for (int i = 0; i < 5000; ++i) pc.push_back(pcl::PointXYZ(static_cast<float>(i / 1000), 0.5f, static_cast<float>(i % 7) * 0.25f));
  pcl::io::savePCDFileBinaryCompressed(dir.file("repeats.pcd"), pc);
  const PointCloud r = read_point_cloud(dir.file("repeats.pcd"), {Unit::kMetre});
  ASSERT_EQ(r.size(), 5000);
  for (int i = 0; i < 5000; ++i) {
    ASSERT_EQ(r.P(i, 0), i / 1000) << "point " << i;
    ASSERT_EQ(r.P(i, 1), 0.5) << "point " << i;
    ASSERT_EQ(r.P(i, 2), (i % 7) * 0.25) << "point " << i;
  }
}

TEST(PointCloudIo, OrganisedCloudDropsNanPoints) {
  test::TempDir dir;
  const std::string path = dir.write("org.pcd",
                                     "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 2\n"
                                     "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 4\nDATA ascii\n1 2 3\nnan nan nan\n4 5 6\n7 8 9\n");
  const PointCloud c = read_point_cloud(path);
  EXPECT_EQ(c.size(), 3);
  EXPECT_EQ(c.P(1, 0), 4.0);
}
