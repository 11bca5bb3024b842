// The fuzzer's findings, rebuilt from small generated files: a BVH nested 100,000 joints deep, and
// headers claiming 2^31 elements. Each gets a clear error naming the file and the count (or is read,
// where it is valid), in memory bounded by a small multiple of the file size.
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <functional>
#include <string>

#include "posekit/core/error.h"
#include "posekit/io/bvh.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "testing/bytes_of.h"
#include "testing/temp_dir.h"

using namespace posekit;
using posekit::test::bytes_of;

namespace {

/// Peak resident memory (VmHWM) in bytes, or -1 where /proc cannot tell.
long long peak_rss_bytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stoll(line.substr(6)) * 1024;
  return -1;
}

/// Resets the peak to the current resident size (Linux 4.0+); false where that is not allowed.
bool reset_peak_rss() {
  std::ofstream clear("/proc/self/clear_refs");
  clear << "5";
  clear.flush();
  return static_cast<bool>(clear);
}

/// Runs `read`, which must throw an IoError whose message holds `path` and `phrase`, and checks the
/// peak memory it took is under 64 MiB plus 16 times the file's size.
void expect_refused_cheaply(const std::string& path, const std::string& phrase, const std::function<void()>& read) {
  const bool measured = reset_peak_rss();
  const long long before = peak_rss_bytes();
  try {
    read();
    ADD_FAILURE() << path << ": read without error";
  } catch (const IoError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find(phrase), std::string::npos) << "message: " << msg << "\nexpected: " << phrase;
  }
  if (measured && before > 0) {
    std::ifstream f(path, std::ios::binary | std::ios::ate);
    const long long size = static_cast<long long>(f.tellg());
    EXPECT_LT(peak_rss_bytes() - before, (64ll << 20) + 16 * size) << path;
  }
}

constexpr std::uint32_t kClaim = 2147483648u;  // 2^31
const std::string kClaimText = "2147483648";

}  // namespace

TEST(HostileFiles, BvhNested100000DeepIsReadWithoutRecursion) {
  // A valid file: each joint is the child of the one before. The recursive parser overflowed the
  // stack at about 20,000.
  test::TempDir dir;
  constexpr int kDepth = 100000;
  std::string text = "HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n";
  text.reserve(static_cast<size_t>(kDepth) * 64);
  for (int j = 1; j < kDepth; ++j) text += "JOINT j" + std::to_string(j) + "\n{\nOFFSET 0 0.001 0\nCHANNELS 1 Zrotation\n";
  text += "End Site\n{\nOFFSET 0 0.001 0\n}\n";
  for (int j = 0; j < kDepth; ++j) text += "}\n";
  text += "MOTION\nFrames: 1\nFrame Time: 0.0083333\n0 0 0";
  for (int j = 1; j < kDepth; ++j) text += " 0";
  text += "\n";
  const std::string path = dir.write("deep.bvh", text);
  const BvhMotion m = read_bvh(path);
  ASSERT_EQ(m.joints.size(), static_cast<size_t>(kDepth));
  EXPECT_EQ(m.joints.back().parent, kDepth - 2);
  EXPECT_TRUE(m.joints.back().has_end_site);
  // Forward kinematics and writing are iterative too: the chain is 100 m tall.
  EXPECT_NEAR(m.joint_positions(0).row(kDepth - 1).y(), (kDepth - 1) * 0.001, 1e-6);
  write_bvh(dir.file("again.bvh"), m);
  EXPECT_EQ(read_bvh(dir.file("again.bvh")).joints.size(), static_cast<size_t>(kDepth));
}

TEST(HostileFiles, BvhUnclosedDeepHierarchyIsAnErrorNotACrash) {
  test::TempDir dir;
  std::string text = "HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\n";
  for (int j = 1; j < 100000; ++j) text += "JOINT j\n{\nOFFSET 0 0 0\n";
  const std::string path = dir.write("open.bvh", text);
  expect_refused_cheaply(path, "file ends early", [&] { read_bvh(path); });
}

TEST(HostileFiles, PlyClaimingTwoToThe31Elements) {
  test::TempDir dir;
  const std::string vertices =
      "ply\nformat ascii 1.0\nelement vertex " + kClaimText + "\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n";
  const std::string path1 = dir.write("ascii_vertices.ply", vertices);
  expect_refused_cheaply(path1, "claims " + kClaimText, [&] { read_mesh(path1); });
  expect_refused_cheaply(path1, "claims " + kClaimText, [&] { read_point_cloud(path1); });
  std::string faces =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face " +
      kClaimText + "\nproperty list uchar int vertex_indices\nend_header\n";
  for (int k = 0; k < 9; ++k) faces += bytes_of(0.f);
  const std::string path2 = dir.write("binary_faces.ply", faces);
  expect_refused_cheaply(path2, "element 'face' claims " + kClaimText, [&] { read_mesh(path2); });
}

TEST(HostileFiles, PcdClaimingTwoToThe31Points) {
  test::TempDir dir;
  for (const std::string data : {"ascii", "binary", "binary_compressed"}) {
    std::string pcd = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " + kClaimText + "\nHEIGHT 1\nPOINTS " +
                      kClaimText + "\nDATA " + data + "\n";
    if (data == "binary_compressed") pcd += bytes_of<std::uint32_t>(12) + bytes_of<std::uint32_t>(0) + std::string(12, 'x');
    else pcd += "0 0 0\n";
    const std::string path = dir.write(data + ".pcd", pcd);
    expect_refused_cheaply(path, kClaimText + " points", [&] { read_point_cloud(path); });
  }
  // The 149-byte header that cost 6-7 GB before the check.
  const std::string small =
      "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 200000000\nHEIGHT 1\n"
      "POINTS 200000000\nDATA binary\n";
  const std::string path = dir.write("small.pcd", small);
  expect_refused_cheaply(path, "200000000 points", [&] { read_point_cloud(path); });
}

// Found by the PCD fuzzer: an rgb value no 32-bit packed colour can hold (negative, huge, NaN).
TEST(HostileFiles, PcdColourOutsideAPackedRgbIsAnError) {
  test::TempDir dir;
  for (const std::string rgb : {"131586000000000", "-1", "nan"}) {
    const std::string path = dir.write("rgb.pcd",
                                       "VERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\n"
                                       "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n0 0 0 255\n1 0 0 " +
                                           rgb + "\n");
    try {
      read_point_cloud(path);
      FAIL() << "rgb " << rgb << " was read";
    } catch (const IoError& e) {
      EXPECT_NE(std::string(e.what()).find("point 1: colour field 'rgb'"), std::string::npos) << e.what();
    }
  }
}

TEST(HostileFiles, StlAndOffClaimingTwoToThe31Elements) {
  test::TempDir dir;
  std::string stl(80, ' ');
  stl += bytes_of(kClaim) + std::string(50, '\0');
  const std::string stl_path = dir.write("huge.stl", stl);
  expect_refused_cheaply(stl_path, "declares " + kClaimText + " triangles", [&] { read_mesh(stl_path); });
  const std::string off_path = dir.write("huge.off", "OFF\n3 " + kClaimText + " 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  expect_refused_cheaply(off_path, kClaimText + " faces", [&] { read_mesh(off_path); });
}
