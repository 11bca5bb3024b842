#include "posekit/io/point_stream.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>

#include "posekit/core/error.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "testing/temp_dir.h"

using namespace posekit;

namespace {

template <class T>
std::string bytes_of(T v, bool big_endian = false) {
  std::string b(sizeof(T), '\0');
  std::memcpy(b.data(), &v, sizeof(T));
  if (big_endian) std::reverse(b.begin(), b.end());
  return b;
}

/// Every point PointStream gives, read in pieces of `piece`, against read_point_cloud's.
void expect_same_points(const std::string& path, double scale, Eigen::Index piece) {
  std::vector<std::string> warnings;
  const auto stream = PointStream::open(path, scale, &warnings);
  ASSERT_NE(stream, nullptr) << path;
  Unit unit = Unit::kMetre;
  for (Unit u : {Unit::kMetre, Unit::kDecimetre, Unit::kCentimetre, Unit::kMillimetre})
    if (metres_per_unit(u) == scale) unit = u;
  std::vector<std::string> whole_warnings;
  const PointCloud whole = read_point_cloud(path, {unit, CloudFormat::kAuto, &whole_warnings});
  ASSERT_EQ(stream->size(), whole.size());
  EXPECT_EQ(warnings, whole_warnings);
  Eigen::MatrixXd P;
  for (Eigen::Index first = 0; first < stream->size(); first += piece) {
    const Eigen::Index count = std::min(piece, stream->size() - first);
    stream->read(first, count, &P);
    stream->release(first + count);
    ASSERT_TRUE((P.array() == whole.P.middleRows(first, count).array()).all()) << path << " from point " << first;
  }
  for (Eigen::Index i : {Eigen::Index(0), stream->size() / 3, stream->size() - 1}) {  // single points anywhere
    stream->read(i, 1, &P);
    EXPECT_TRUE((P.row(0).array() == whole.P.row(i).array()).all()) << path << " point " << i;
  }
  EXPECT_THROW(stream->read(stream->size() - 1, 2, &P), InvalidInput);
}

}  // namespace

TEST(PointStream, GivesReadPointCloudsPointsToTheBitInAnyPieces) {
  test::TempDir dir;
  PointCloud c;
  c.P = Eigen::MatrixXd::Random(5000, 3) * 900;
  c.P.row(17).setConstant(std::numeric_limits<double>::quiet_NaN());  // left out by both
  c.P(4000, 2) = std::numeric_limits<double>::infinity();
  c.point_scalars["intensity"] = Eigen::VectorXd::LinSpaced(5000, 0, 1);
  // posekit's binary PLY (doubles) and PCD (floats, with a scalar field), in mm.
  PointCloud finite = c;
  finite.P.row(17).setZero();
  finite.P(4000, 2) = 0;
  write_point_cloud(dir.file("a.ply"), finite, {Unit::kMillimetre});
  write_point_cloud(dir.file("a.pcd"), finite, {Unit::kMillimetre});
  for (const char* name : {"a.ply", "a.pcd"})
    for (Eigen::Index piece : {Eigen::Index(1000), Eigen::Index(333), Eigen::Index(5000)}) expect_same_points(dir.file(name), 0.001, piece);
  // Big-endian floats with other properties around x, y, z and non-finite points; faces after.
  std::string ply =
      "ply\nformat binary_big_endian 1.0\ncomment made by hand\nelement vertex 300\nproperty uchar red\n"
      "property float z\nproperty float x\nproperty short id\nproperty float y\nelement face 0\n"
      "property list uchar int vertex_indices\nend_header\n";
  for (int i = 0; i < 300; ++i) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float x = 0.01f * static_cast<float>(i), y = i % 41 == 0 ? nan : 1.5f, z = -0.25f * static_cast<float>(i % 7);
    ply += bytes_of<std::uint8_t>(200) + bytes_of(z, true) + bytes_of(x, true) +
           bytes_of<std::int16_t>(static_cast<std::int16_t>(i), true) + bytes_of(y, true);
  }
  dir.write("big.ply", ply);
  for (Eigen::Index piece : {Eigen::Index(7), Eigen::Index(100)}) expect_same_points(dir.file("big.ply"), 1.0, piece);
}

TEST(PointStream, LeavesEveryOtherFileToTheWholeReader) {
  test::TempDir dir;
  PointCloud c;
  c.P = Eigen::MatrixXd::Random(50, 3);
  write_point_cloud(dir.file("ascii.ply"), c, {Unit::kMetre, CloudFormat::kAuto, false});
  write_point_cloud(dir.file("ascii.pcd"), c, {Unit::kMetre, CloudFormat::kAuto, false});
  write_point_cloud(dir.file("c.xyz"), c);
  write_point_cloud(dir.file("whole.ply"), c);
  std::ifstream in(dir.file("whole.ply"), std::ios::binary);
  std::string truncated((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  truncated.resize(truncated.size() - 5);
  dir.write("truncated.ply", truncated);
  dir.write("list.ply",
            "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty list uchar float xyz\nend_header\n" + std::string(13, '\0'));
  dir.write("noy.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float z\nend_header\n" +
                           std::string(8, '\0'));
  for (const char* name : {"ascii.ply", "ascii.pcd", "c.xyz", "truncated.ply", "list.ply", "noy.ply", "missing.ply"})
    EXPECT_EQ(PointStream::open(dir.file(name), 1.0, nullptr), nullptr) << name;
  EXPECT_NE(PointStream::open(dir.file("whole.ply"), 1.0, nullptr), nullptr);
}
