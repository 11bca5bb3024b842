// Files as other tools write them (CloudCompare, Agisoft, PCL, Open3D, Leica, MeshLab, Geomview),
// generated here: posekit reads what they hold, keeps what the target format can hold, says what
// it cannot, and refuses what is invalid.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "posekit/core/error.h"
#include "posekit/io/bvh.h"
#include "posekit/io/json.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "testing/bytes_of.h"
#include "testing/temp_dir.h"
#include "testing/test_meshes.h"

using namespace posekit;
using posekit::test::bytes_of;

namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

bool contains(const std::vector<std::string>& lines, const std::string& phrase) {
  for (const auto& l : lines)
    if (l.find(phrase) != std::string::npos) return true;
  return false;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

// ---------------------------------------------------------------- XYZ / PTS

TEST(XyzColumns, SixIntegerColumnsAreColoursNotNormals) {
  test::TempDir dir;
  // Agisoft / CloudCompare "x y z r g b" export without a header.
  const std::string path = dir.write("rgb.xyz", "0.1 0.2 0.3 255 0 12\n1 2 3 0 128 255\n");
  std::vector<std::string> warnings;
  const PointCloud c = read_point_cloud(path, {Unit::kMetre, CloudFormat::kAuto, &warnings});
  EXPECT_FALSE(c.has_normals());
  ASSERT_TRUE(c.has_colors());
  EXPECT_EQ(c.C(0, 0), 255);
  EXPECT_EQ(c.C(0, 2), 12);
  EXPECT_EQ(c.C(1, 1), 128);
  EXPECT_TRUE(contains(warnings, "columns 4-6 as RGB colours")) << "the guess must be said";
}

TEST(XyzColumns, UnitLengthColumnsAreNormals) {
  test::TempDir dir;
  const std::string path = dir.write("n.xyz", "0 0 0 0 0 1\n1 0 0 0.6 0.8 0\n");
  const PointCloud c = read_point_cloud(path);
  ASSERT_TRUE(c.has_normals());
  EXPECT_FALSE(c.has_colors());
  EXPECT_DOUBLE_EQ(c.N(1, 1), 0.8);
}

TEST(XyzColumns, HeaderNamesTheColumnsInAnyOrder) {
  test::TempDir dir;
  const std::string path = dir.write("cc.txt", "//X,Y,Z,R,G,B,Nx,Ny,Nz,Intensity\n1,2,3,10,20,30,0,1,0,0.5\n4,5,6,40,50,60,1,0,0,0.25\n");
  const PointCloud c = read_point_cloud(path);
  ASSERT_TRUE(c.has_colors());
  ASSERT_TRUE(c.has_normals());
  EXPECT_EQ(c.C(1, 2), 60);
  EXPECT_DOUBLE_EQ(c.N(0, 1), 1.0);
  ASSERT_EQ(c.point_scalars.count("Intensity"), 1u);
  EXPECT_DOUBLE_EQ(c.point_scalars.at("Intensity")[1], 0.25);
}

TEST(XyzColumns, PtsWithPointCountAndIntensity) {
  test::TempDir dir;
  // Leica PTS: a count line, then x y z intensity r g b.
  const std::string path = dir.write("scan.pts", "2\n1 2 3 -1200 10 20 30\n4 5 6 300 40 50 60\n");
  const PointCloud c = read_point_cloud(path);
  ASSERT_EQ(c.size(), 2);
  ASSERT_TRUE(c.has_colors());
  EXPECT_EQ(c.C(1, 0), 40);
  EXPECT_DOUBLE_EQ(c.point_scalars.at("intensity")[0], -1200);
  // A count that disagrees with the points is refused, naming both.
  const std::string bad = dir.write("bad.pts", "3\n1 2 3\n4 5 6\n");
  const std::string msg = error_of([&] { read_point_cloud(bad); });
  EXPECT_NE(msg.find("declare 3 points, the file has 2"), std::string::npos) << msg;
}

TEST(XyzColumns, RoundTripKeepsColoursNormalsAndScalars) {
  test::TempDir dir;
  PointCloud c;
  c.P = Eigen::MatrixXd::Random(20, 3);
  c.N = c.P.rowwise().normalized();
  c.C = RowMatrixX3u8::Constant(20, 3, 7);
  c.point_scalars["intensity"] = Eigen::VectorXd::LinSpaced(20, 0, 1);
  write_point_cloud(dir.file("c.xyz"), c);
  const PointCloud r = read_point_cloud(dir.file("c.xyz"));
  ASSERT_TRUE(r.has_colors() && r.has_normals());
  EXPECT_EQ(r.C, c.C);
  EXPECT_LT((r.N - c.N).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT((r.P - c.P).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT((r.point_scalars.at("intensity") - c.point_scalars.at("intensity")).cwiseAbs().maxCoeff(), 1e-15);
}

TEST(XyzColumns, UnitChangeWritesNoRoundingNoise) {
  test::TempDir dir;
  PointCloud c;
  c.P.resize(1, 3);
  c.P << -0.0453607, 1.7, 0.0001;
  write_point_cloud(dir.file("mm.xyz"), c, {Unit::kMillimetre});
  EXPECT_EQ(slurp(dir.file("mm.xyz")), "-45.3607 1700 0.1\n");
  const PointCloud r = read_point_cloud(dir.file("mm.xyz"), {Unit::kMillimetre});
  EXPECT_NEAR(r.P(0, 0), -0.0453607, 1e-15);
}

TEST(XyzColumns, LeadingPlusSignsAreNumbers) {
  test::TempDir dir;
  const PointCloud c = read_point_cloud(dir.write("plus.xyz", "+1.5 +2 -3\n"));
  EXPECT_DOUBLE_EQ(c.P(0, 0), 1.5);
  EXPECT_DOUBLE_EQ(c.P(0, 1), 2.0);
}

// ---------------------------------------------------------------- NaN points: one rule

TEST(NonFinitePoints, EveryCloudFormatDropsThemAndSaysHowMany) {
  test::TempDir dir;
  const std::string pcd =
      "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\nHEIGHT 1\n"
      "POINTS 3\nDATA ascii\n0 0 0\nnan nan nan\n1 1 1\n";
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n0 0 0\nnan nan nan\n1 1 1\n";
  for (const auto& [name, text] :
       {std::pair<std::string, std::string>{"o.pcd", pcd}, {"o.ply", ply}, {"o.xyz", "0 0 0\nnan nan nan\n1 1 1\n"}}) {
    std::vector<std::string> warnings;
    const PointCloud c = read_point_cloud(dir.write(name, text), {Unit::kMetre, CloudFormat::kAuto, &warnings});
    EXPECT_EQ(c.size(), 2) << name;
    EXPECT_TRUE(contains(warnings, "dropped 1 of 3 points")) << name;
  }
}

// ---------------------------------------------------------------- PCD

TEST(Pcd, GeoreferencedCoordinatesKeepMicrometres) {
  test::TempDir dir;
  PointCloud c;
  c.P.resize(2, 3);
  c.P << 512345.678912, 5412345.123456, 312.000001, 512345.678913, 5412345.123457, 312.000002;
  write_point_cloud(dir.file("geo.pcd"), c);
  const PointCloud r = read_point_cloud(dir.file("geo.pcd"));
  EXPECT_LT((r.P - c.P).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_NE(slurp(dir.file("geo.pcd")).find("SIZE 8 8 8"), std::string::npos);
  // A body in metres stays float32 (half the size): float moves it by under a micrometre.
  PointCloud body;
  body.P = test::icosphere(2).V;
  write_point_cloud(dir.file("body.pcd"), body);
  EXPECT_NE(slurp(dir.file("body.pcd")).find("SIZE 4 4 4"), std::string::npos);
  EXPECT_LT((read_point_cloud(dir.file("body.pcd")).P - body.P).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(Pcd, AsciiFloatFieldsAreWrittenWithoutWideningNoise) {
  test::TempDir dir;
  PointCloud c;
  c.P.resize(1, 3);
  c.P << 0.1, 0.25, 1.7;
  write_point_cloud(dir.file("a.pcd"), c, {Unit::kMetre, CloudFormat::kAuto, false});
  const std::string text = slurp(dir.file("a.pcd"));
  EXPECT_NE(text.find("\n0.1 0.25 1.7\n"), std::string::npos) << text;
}

TEST(Pcd, PackedColoursAreReadInEveryEncodingAndWritten) {
  test::TempDir dir;
  const std::uint32_t orange = (255u << 16) | (128u << 8) | 7u;
  float as_float;
  std::memcpy(&as_float, &orange, 4);
  const std::string head =
      "VERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F %\nCOUNT 1 1 1 1\nWIDTH 1\nHEIGHT 1\n"
      "POINTS 1\nDATA ";
  auto with_type = [&](char t) {
    std::string h = head;
    h[h.find('%')] = t;
    return h;
  };
  char old_pcl_text[64];
  std::snprintf(old_pcl_text, sizeof(old_pcl_text), "%.9g", as_float);
  const std::vector<std::pair<std::string, std::string>> files = {
      {"u_ascii.pcd", with_type('U') + "ascii\n1 2 3 " + std::to_string(orange) + "\n"},     // PCL 1.13
      {"f_ascii.pcd", with_type('F') + "ascii\n1 2 3 " + std::string(old_pcl_text) + "\n"},  // older PCL
      {"f_binary.pcd", with_type('F') + "binary\n" + bytes_of(1.f) + bytes_of(2.f) + bytes_of(3.f) + bytes_of(as_float)},
  };
  for (const auto& [name, text] : files) {
    const PointCloud c = read_point_cloud(dir.write(name, text));
    ASSERT_TRUE(c.has_colors()) << name;
    EXPECT_EQ(int(c.C(0, 0)), 255) << name;
    EXPECT_EQ(int(c.C(0, 1)), 128) << name;
    EXPECT_EQ(int(c.C(0, 2)), 7) << name;
    EXPECT_EQ(c.point_scalars.count("rgb"), 0u) << name;
  }
  // PCD -> PLY -> PCD keeps them (a PLY point cloud's red/green/blue included).
  const PointCloud c = read_point_cloud(dir.file("f_binary.pcd"));
  write_point_cloud(dir.file("c.ply"), c);
  write_point_cloud(dir.file("back.pcd"), read_point_cloud(dir.file("c.ply")));
  EXPECT_EQ(read_point_cloud(dir.file("back.pcd")).C, c.C);
}

TEST(Pcd, HeaderMustBeCompleteAndConsistent) {
  test::TempDir dir;
  const std::string no_height = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nPOINTS 1\nDATA ascii\n1 2 3\n";
  const std::string no_size = "FIELDS x y z\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n";
  const std::string mismatch =
      "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 2\nPOINTS 3\nDATA ascii\n"
      "1 2 3\n1 2 3\n1 2 3\n";
  EXPECT_NE(error_of([&] { read_point_cloud(dir.write("a.pcd", no_height)); }).find("lacks HEIGHT"), std::string::npos);
  EXPECT_NE(error_of([&] { read_point_cloud(dir.write("b.pcd", no_size)); }).find("lacks SIZE"), std::string::npos);
  EXPECT_NE(error_of([&] { read_point_cloud(dir.write("c.pcd", mismatch)); }).find("POINTS 3 but WIDTH x HEIGHT = 2 x 2"),
            std::string::npos);
}

// ---------------------------------------------------------------- PLY

TEST(Ply, PclPcd2PlyOutputWithEmptyFaceAndCameraElements) {
  test::TempDir dir;
  std::string ply =
      "ply\nformat binary_little_endian 1.0\ncomment PCL generated\nelement vertex 2\n"
      "property float x\nproperty float y\nproperty float z\nelement face 0\nelement camera 1\n"
      "property float view_px\nproperty float view_py\nproperty float view_pz\nend_header\n";
  for (float v : {1.f, 2.f, 3.f, 4.f, 5.f, 6.f, 0.f, 0.f, 0.f}) ply += bytes_of(v);
  const PointCloud c = read_point_cloud(dir.write("pcl.ply", ply));
  ASSERT_EQ(c.size(), 2);
  EXPECT_EQ(c.P(1, 2), 6.0);
}

TEST(Ply, ExporterNotesBeforeTheElementsAreSkippedWithAWarning) {
  test::TempDir dir;
  const std::string ply =
      "ply\nformat ascii 1.0\nCreated by SomeScanner 2.1\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n"
      "end_header\n+0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  std::vector<std::string> warnings;
  const TriangleMesh m = read_mesh(dir.write("note.ply", ply), {Unit::kMetre, MeshFormat::kAuto, &warnings});
  EXPECT_EQ(m.num_faces(), 1);
  EXPECT_TRUE(contains(warnings, "skipped the header line 'Created by SomeScanner 2.1'"));
  // The same line among the properties would shift every value: refused.
  const std::string inside = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\npropery float y\nend_header\n1\n";
  EXPECT_NE(error_of([&] { read_mesh(dir.write("typo.ply", inside)); }).find("unexpected header keyword 'propery'"), std::string::npos);
}

TEST(Ply, ExtraValuesAndDuplicatePropertiesAreRefused) {
  test::TempDir dir;
  const std::string head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const std::string extra = head + "0 0 0 9\n1 0 0\n0 1 0\n3 0 1 2\n";
  EXPECT_NE(error_of([&] { read_mesh(dir.write("extra.ply", extra)); }).find("#0 of 3: 1 more value(s)"), std::string::npos);
  const std::string dup =
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
      "property float z\nproperty float x\nend_header\n1 2 3 4\n";
  EXPECT_NE(error_of([&] { read_point_cloud(dir.write("dup.ply", dup)); }).find("property 'x' of element 'vertex' is declared twice"),
            std::string::npos);
}

TEST(Ply, AlphaAndTextureCoordinatesAreKept) {
  test::TempDir dir;
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n"
      "property float s\nproperty float t\nelement face 1\nproperty list uchar int vertex_indices\n"
      "end_header\n0 0 0 1 2 3 128 0.25 0.5\n1 0 0 1 2 3 255 1 0\n0 1 0 1 2 3 0 0 1\n3 0 1 2\n";
  const TriangleMesh m = read_mesh(dir.write("a.ply", ply));
  ASSERT_TRUE(m.has_uv());
  EXPECT_DOUBLE_EQ(m.UV(0, 1), 0.5);
  ASSERT_EQ(m.vertex_scalars.count("alpha"), 1u);
  EXPECT_DOUBLE_EQ(m.vertex_scalars.at("alpha")[0], 128);
}

// ---------------------------------------------------------------- OBJ

TEST(Obj, TextureCoordinatesSurvivePlyToObjToPly) {
  test::TempDir dir;
  TriangleMesh m = test::icosphere(1);
  m.UV = m.V.leftCols(2) * 0.5;
  write_mesh(dir.file("a.ply"), m);
  write_mesh(dir.file("b.obj"), read_mesh(dir.file("a.ply")));
  write_mesh(dir.file("c.ply"), read_mesh(dir.file("b.obj")));
  const TriangleMesh r = read_mesh(dir.file("c.ply"));
  ASSERT_TRUE(r.has_uv());
  EXPECT_LT((r.UV - m.UV).cwiseAbs().maxCoeff(), 1e-7);  // float32 in PLY
}

TEST(Obj, UvSeamsAreReportedNotSilentlyMerged) {
  test::TempDir dir;
  const std::string obj =
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvt 0.5 0.5\n"
      "f 1/1 2/2 3/3\nf 2/5 4/4 3/3\n";
  std::vector<std::string> warnings;
  const TriangleMesh m = read_mesh(dir.write("seam.obj", obj), {Unit::kMetre, MeshFormat::kAuto, &warnings});
  EXPECT_FALSE(m.has_uv());
  EXPECT_TRUE(contains(warnings, "UV seams"));
}

TEST(Obj, LineContinuationsAndPointOnlyFiles) {
  test::TempDir dir;
  const TriangleMesh m = read_mesh(dir.write("cont.obj", "v 0 0 0\nv 1 0 \\\n 0\nv 0 1 0\nf 1 2 \\\n3\n"));
  EXPECT_EQ(m.num_faces(), 1);
  EXPECT_EQ(m.V(1, 0), 1.0);
  // A point-only OBJ (vertices and `p`) is a point cloud; read_mesh says so.
  const std::string points = dir.write("points.obj", "v 0 0 0\nv 1 2 3\np 1 2\n");
  EXPECT_NE(error_of([&] { read_mesh(points); }).find("read it as a point cloud"), std::string::npos);
  const PointCloud c = read_point_cloud(points);
  ASSERT_EQ(c.size(), 2);
  EXPECT_EQ(c.P(1, 2), 3.0);
}

// ---------------------------------------------------------------- OFF

TEST(Off, ColoursNormalsAndFacesOverSeveralLines) {
  test::TempDir dir;
  const std::string coff = "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1\n 2\n";
  const TriangleMesh c = read_mesh(dir.write("c.off", coff));
  ASSERT_TRUE(c.has_colors());
  EXPECT_EQ(int(c.C(1, 1)), 255);
  EXPECT_EQ(c.num_faces(), 1);
  const std::string noff = "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2 0.5 0.5 0.5\n";
  const TriangleMesh n = read_mesh(dir.write("n.off", noff));
  ASSERT_TRUE(n.has_normals());
  EXPECT_EQ(n.N(2, 2), 1.0);
  // Geomview's 0..1 float colours.
  const std::string fcoff = "COFF\n3 1 0\n0 0 0 1 0 0 1\n1 0 0 0 0.5 0 1\n0 1 0 0 0 1 1\n3 0 1 2\n";
  EXPECT_EQ(int(read_mesh(dir.write("f.off", fcoff)).C(1, 1)), 128);
  // Written and read back with both.
  TriangleMesh m = test::icosphere(1);
  m.N = m.V.rowwise().normalized();
  m.C = RowMatrixX3u8::Constant(m.V.rows(), 3, 9);
  write_mesh(dir.file("rt.off"), m);
  const TriangleMesh r = read_mesh(dir.file("rt.off"));
  EXPECT_EQ(r.C, m.C);
  EXPECT_LT((r.N - m.N).cwiseAbs().maxCoeff(), 1e-15);
}

// ---------------------------------------------------------------- what a format cannot hold

TEST(WriteMesh, WarnsOfEveryAttributeTheFormatCannotHold) {
  test::TempDir dir;
  TriangleMesh m = test::icosphere(1);
  m.vertex_scalars["signed_distance_mm"] = Eigen::VectorXd::Zero(m.V.rows());
  m.C = RowMatrixX3u8::Zero(m.V.rows(), 3);
  std::vector<std::string> warnings;
  write_mesh(dir.file("m.obj"), m, {Unit::kMetre, MeshFormat::kAuto, true, &warnings});
  EXPECT_TRUE(contains(warnings, "OBJ cannot hold the vertex scalar field(s) signed_distance_mm"));
  EXPECT_FALSE(contains(warnings, "colours"));  // OBJ holds them
  warnings.clear();
  write_mesh(dir.file("m.stl"), m, {Unit::kMetre, MeshFormat::kAuto, true, &warnings});
  EXPECT_TRUE(contains(warnings, "STL cannot hold vertex colours"));
  warnings.clear();
  write_mesh(dir.file("m.ply"), m, {Unit::kMetre, MeshFormat::kAuto, true, &warnings});
  EXPECT_TRUE(warnings.empty());
}

// ---------------------------------------------------------------- BVH and pose JSON

TEST(BvhFrameTime, MustBeAPositiveNumberOfSeconds) {
  test::TempDir dir;
  for (const std::string t : {"nan", "inf", "0", "-1"}) {
    const std::string text = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 Zrotation\n}\nMOTION\nFrames: 1\nFrame Time: " + t + "\n5\n";
    const std::string msg = error_of([&] { read_bvh(dir.write("t.bvh", text)); });
    EXPECT_NE(msg.find("Frame Time must be a positive number"), std::string::npos) << t << ": " << msg;
  }
}

TEST(Json, DuplicateKeysAreRefusedWithTheirObject) {
  const std::string msg = error_of([] { parse_json(R"({"joints": {"left_knee": [0, 0, 1], "left_knee": [0, 0, 0]}})", "pose.json"); });
  EXPECT_NE(msg.find("pose.json: the key 'left_knee' appears twice in 'joints'"), std::string::npos) << msg;
  // The same key in two objects is fine.
  EXPECT_NO_THROW(parse_json(R"({"a": {"x": 1}, "b": {"x": 2}, "c": [{"x": 1}, {"x": 2}]})", "ok.json"));
}
