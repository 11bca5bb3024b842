#include "posekit/io/mesh_io.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "testing/temp_dir.h"
#include "testing/test_meshes.h"

using namespace posekit;

namespace {

TriangleMesh decorated_sphere() {
  TriangleMesh m = test::icosphere(2, 0.3);
  m.V.rowwise() += Eigen::RowVector3d(0.1, 0.9, -0.05);
  m.N = vertex_normals(m.V, m.F);
  m.C.resize(m.V.rows(), 3);
  for (Eigen::Index v = 0; v < m.V.rows(); ++v) m.C.row(v) << v % 256, (3 * v) % 256, 200;
  m.vertex_scalars["error_mm"] = Eigen::VectorXd::LinSpaced(m.V.rows(), -3.5, 12.25);
  m.vertex_scalars["part"] = Eigen::VectorXd::LinSpaced(m.V.rows(), 0, 15).array().round();
  return m;
}

/// Same triangles at the same places; `same_indexing` also requires identical vertex order.
void expect_same_geometry(const TriangleMesh& a, const TriangleMesh& b, double tol, bool same_indexing) {
  ASSERT_EQ(a.V.rows(), b.V.rows());
  ASSERT_EQ(a.F.rows(), b.F.rows());
  double worst = 0;
  for (Eigen::Index f = 0; f < a.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) worst = std::max(worst, (a.V.row(a.F(f, c)) - b.V.row(b.F(f, c))).cwiseAbs().maxCoeff());
  EXPECT_LE(worst, tol);
  if (same_indexing) {
    EXPECT_EQ(a.F, b.F);
  }
}

}  // namespace

struct FormatCase {
  const char* file;
  bool binary;
  double tol;
};

void PrintTo(const FormatCase& c, std::ostream* os) { *os << c.file; }

class MeshRoundTrip : public ::testing::TestWithParam<FormatCase> {};

TEST_P(MeshRoundTrip, PreservesGeometry) {
  test::TempDir dir;
  const TriangleMesh m = decorated_sphere();
  const std::string path = dir.file(GetParam().file);
  write_mesh(path, m, {Unit::kMetre, MeshFormat::kAuto, GetParam().binary});
  const TriangleMesh r = read_mesh(path);
  // STL stores triangle soups: welding on load renumbers the vertices.
  expect_same_geometry(m, r, GetParam().tol, mesh_format_from_path(path) != MeshFormat::kStl);
  EXPECT_EQ(dir.count(), 1) << "no temporary file left behind";
}

INSTANTIATE_TEST_SUITE_P(Formats, MeshRoundTrip,
                         ::testing::Values(FormatCase{"m.obj", false, 1e-15}, FormatCase{"m.off", false, 1e-15},
                                           FormatCase{"a.ply", false, 1e-6}, FormatCase{"b.ply", true, 1e-6},
                                           FormatCase{"b.stl", true, 1e-7}, FormatCase{"a.stl", false, 1e-7}),
                         [](const auto& info) {
                           std::string n = info.param.file;
                           n[n.find('.')] = '_';
                           return n;
                         });

TEST(MeshIo, PlyKeepsNormalsColoursAndScalarFieldsAsciiAndBinary) {
  test::TempDir dir;
  const TriangleMesh m = decorated_sphere();
  for (bool binary : {false, true}) {
    const std::string path = dir.file(binary ? "b.ply" : "a.ply");
    write_mesh(path, m, {Unit::kMetre, MeshFormat::kAuto, binary});
    const TriangleMesh r = read_mesh(path);
    ASSERT_TRUE(r.has_normals());
    ASSERT_TRUE(r.has_colors());
    EXPECT_LE((r.N - m.N).cwiseAbs().maxCoeff(), 1e-7);  // float32
    EXPECT_EQ(r.C, m.C);
    ASSERT_EQ(r.vertex_scalars.size(), 2u);
    EXPECT_LE((r.vertex_scalars.at("error_mm") - m.vertex_scalars.at("error_mm")).cwiseAbs().maxCoeff(), 12.25 * 1e-7);
    EXPECT_EQ(r.vertex_scalars.at("part"), m.vertex_scalars.at("part"));
  }
}

TEST(MeshIo, ObjKeepsGroupsAndTriangulatesPolygons) {
  test::TempDir dir;
  const std::string path = dir.write("q.obj",
                                     "# quads and a pentagon in two groups\n"
                                     "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 1.5 0\nv 0 0 1\nvt 0 0\n"
                                     "g skin\nf 1/1 2/1 3/1 4/1\n"
                                     "g helper-x\nf -6//1 -5//1 -4//1 -2//1 -3//1\n"
                                     "g skin\nf 1 2 6\n");
  const TriangleMesh m = read_mesh(path);
  EXPECT_EQ(m.num_vertices(), 6);
  EXPECT_EQ(m.num_faces(), 2 + 3 + 1);
  ASSERT_EQ(m.group_names.size(), 2u);
  EXPECT_EQ(m.group_names[0], "skin");
  EXPECT_EQ((m.face_group.array() == 0).count(), 3);
  EXPECT_EQ((m.face_group.array() == 1).count(), 3);
  EXPECT_NEAR(surface_area(m.V, m.F.topRows(2)), 1.0, 1e-12);
  // Groups survive a write/read cycle.
  write_mesh(dir.file("out.obj"), m);
  const TriangleMesh r = read_mesh(dir.file("out.obj"));
  EXPECT_EQ(r.group_names, m.group_names);
  EXPECT_EQ(r.face_group, m.face_group);
  EXPECT_EQ(extract_group(r, "helper-x").num_faces(), 3);
}

TEST(MeshIo, UnitsConvertAtLoadAndSave) {
  test::TempDir dir;
  const TriangleMesh m = test::unit_cube();  // 1 m cube
  write_mesh(dir.file("mm.ply"), m, {Unit::kMillimetre});
  const TriangleMesh as_mm = read_mesh(dir.file("mm.ply"));  // numbers as written: 1000
  EXPECT_NEAR(as_mm.V.maxCoeff(), 1000.0, 1e-9);
  const TriangleMesh back = read_mesh(dir.file("mm.ply"), {Unit::kMillimetre});
  EXPECT_NEAR(back.V.maxCoeff(), 1.0, 1e-12);
  write_mesh(dir.file("dm.obj"), m, {Unit::kDecimetre});
  EXPECT_NEAR(read_mesh(dir.file("dm.obj"), {Unit::kDecimetre}).V.maxCoeff(), 1.0, 1e-12);
  EXPECT_NEAR(read_mesh(dir.file("dm.obj"), {Unit::kCentimetre}).V.maxCoeff(), 0.1, 1e-12);
}

TEST(MeshIo, BinaryStlWeldsSharedCornersIntoAClosedMesh) {
  test::TempDir dir;
  const TriangleMesh sphere = test::icosphere(2);
  write_mesh(dir.file("s.stl"), sphere);
  const TriangleMesh r = read_mesh(dir.file("s.stl"));
  EXPECT_EQ(r.num_vertices(), sphere.num_vertices());
  EXPECT_NEAR(signed_volume(r.V, r.F), signed_volume(sphere.V, sphere.F), 1e-5);
}

TEST(MeshIo, FailedWriteLeavesNothingAndKeepsTheOldFile) {
  test::TempDir dir;
  const std::string path = dir.write("keep.ply", "old content");
  TriangleMesh bad = test::unit_cube();
  bad.V(3, 1) = std::nan("");
  EXPECT_THROW(write_mesh(path, bad), InvalidInput);
  EXPECT_EQ(dir.count(), 1);
  EXPECT_EQ(std::filesystem::file_size(path), 11u);
  EXPECT_THROW(write_mesh(dir.path() + "/no/such/dir/m.ply", test::unit_cube()), IoError);
  EXPECT_THROW(write_mesh(dir.file("m.xyz3"), test::unit_cube()), IoError);
  EXPECT_EQ(dir.count(), 1);
}
