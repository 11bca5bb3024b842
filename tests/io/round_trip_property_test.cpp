// Every reader against its writer on random content: write a mesh or cloud with every field the
// format can hold, read it back, compare field by field (to the bit where the format stores doubles
// or exact text, to float32 precision where it stores floats).
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>

#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "testing/temp_dir.h"

namespace posekit {
namespace {

/// A random mesh of `n` vertices with normals, colours, texture coordinates, two vertex fields, a
/// face field and two face groups; faces never repeat a vertex.
TriangleMesh random_mesh(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_int_distribution<int> vertex(0, n - 1), byte(0, 255);
  TriangleMesh m;
  m.V.resize(n, 3);
  m.N.resize(n, 3);
  m.C.resize(n, 3);
  m.UV.resize(n, 2);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) m.V(i, k) = unit(rng) * 0.9;
    m.N.row(i) = Eigen::RowVector3d(unit(rng), unit(rng), unit(rng)).normalized();
    for (int k = 0; k < 3; ++k) m.C(i, k) = static_cast<std::uint8_t>(byte(rng));
    m.UV.row(i) << (unit(rng) + 1) / 2, (unit(rng) + 1) / 2;
  }
  m.vertex_scalars["error_mm"] = Eigen::VectorXd::NullaryExpr(n, [&] { return unit(rng) * 30; });
  m.vertex_scalars["part"] = Eigen::VectorXd::NullaryExpr(n, [&] { return static_cast<double>(vertex(rng) % 16); });
  const int faces = 2 * n;
  m.F.resize(faces, 3);
  for (int f = 0; f < faces; ++f) {
    const int a = f % n;  // every vertex on a face
    int b = vertex(rng), c = vertex(rng);
    while (b == a) b = vertex(rng);
    while (c == a || c == b) c = vertex(rng);
    m.F.row(f) << a, b, c;
  }
  m.face_scalars["quality"] = Eigen::VectorXd::NullaryExpr(faces, [&] { return unit(rng); });
  m.face_group = Eigen::VectorXi::NullaryExpr(faces, [&] { return vertex(rng) % 2; });
  m.group_names = {"body", "helper"};
  return m;
}

PointCloud random_cloud(int n, unsigned seed) {
  const TriangleMesh m = random_mesh(n, seed);
  PointCloud c;
  c.P = m.V;
  c.N = m.N;
  c.C = m.C;
  c.point_scalars = m.vertex_scalars;
  return c;
}

void expect_near(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double tolerance, const std::string& what) {
  ASSERT_EQ(a.rows(), b.rows()) << what;
  ASSERT_EQ(a.cols(), b.cols()) << what;
  if (tolerance == 0) EXPECT_TRUE(a == b) << what;
  else EXPECT_LE((a - b).cwiseAbs().maxCoeff(), tolerance) << what;
}

TEST(RoundTripProperty, EveryMeshFormatKeepsEveryFieldItCanHold) {
  test::TempDir dir;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const TriangleMesh m = random_mesh(40 + 17 * static_cast<int>(seed), seed);
    for (const std::string name : {"a.ply", "b.ply", "c.obj", "d.off", "e.stl", "f.stl", "g.ply", "h.ply"}) {
      const bool ascii = name == "b.ply" || name == "f.stl" || name == "h.ply";
      const bool wide = name == "g.ply" || name == "h.ply";  // double_precision: exact
      const std::string path = dir.file(std::to_string(seed) + name);
      MeshWriteOptions options;
      options.binary = !ascii;
      options.double_precision = wide;
      write_mesh(path, m, options);
      std::vector<std::string> warnings;
      const TriangleMesh r = read_mesh(path, {Unit::kMetre, MeshFormat::kAuto, &warnings});
      const std::string what = path;
      EXPECT_TRUE(warnings.empty()) << what << ": " << warnings.front();
      if (name.find(".stl") != std::string::npos) {
        // Geometry only, as float32, welded: every triangle's corners where they were.
        ASSERT_EQ(r.F.rows(), m.F.rows()) << what;
        for (Eigen::Index f = 0; f < m.F.rows(); ++f)
          for (int c = 0; c < 3; ++c) EXPECT_LE((r.V.row(r.F(f, c)) - m.V.row(m.F(f, c))).norm(), 1e-6) << what << " face " << f;
        continue;
      }
      // PLY stores float32 by default: coordinates within a micrometre, fields to float32's precision
      // (whole-number fields exactly); OBJ, OFF and a double_precision PLY keep doubles exactly.
      const bool float32 = name.find(".ply") != std::string::npos && !wide;
      expect_near(r.V, m.V, float32 ? 1e-6 : 0, what + " V");
      EXPECT_TRUE(r.F == m.F) << what;
      expect_near(r.N, m.N, float32 ? 1e-7 : 0, what + " N");
      EXPECT_TRUE(r.C == m.C) << what;
      if (name.find(".off") == std::string::npos) expect_near(r.UV, m.UV, float32 ? 1e-7 : 0, what + " UV");
      if (name.find(".ply") != std::string::npos && wide) {
        EXPECT_EQ(r.vertex_scalars, m.vertex_scalars) << what;
        EXPECT_EQ(r.face_scalars, m.face_scalars) << what;
      } else if (float32) {
        EXPECT_EQ(r.vertex_scalars.at("part"), m.vertex_scalars.at("part")) << what;
        expect_near(r.vertex_scalars.at("error_mm"), m.vertex_scalars.at("error_mm"), 30 * 1e-7, what + " error_mm");
        expect_near(r.face_scalars.at("quality"), m.face_scalars.at("quality"), 1e-7, what + " quality");
      }
      if (name.find(".obj") != std::string::npos) {
        // Groups are numbered in the order faces name them: compare each face's group name.
        ASSERT_EQ(r.face_group.size(), m.face_group.size()) << what;
        for (Eigen::Index f = 0; f < m.F.rows(); ++f)
          ASSERT_EQ(r.group_names.at(static_cast<size_t>(r.face_group[f])), m.group_names[static_cast<size_t>(m.face_group[f])])
              << what << " face " << f;
      }
    }
  }
}

TEST(RoundTripProperty, EveryCloudFormatKeepsEveryFieldItCanHold) {
  test::TempDir dir;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const PointCloud c = random_cloud(30 + 11 * static_cast<int>(seed), seed);
    for (const std::string name : {"a.pcd", "b.pcd", "c.ply", "d.ply", "e.xyz", "f.ply", "g.pcd"}) {
      const bool ascii = name == "b.pcd" || name == "d.ply";
      const bool wide = name == "f.ply" || name == "g.pcd";  // double_precision: exact
      const std::string path = dir.file(std::to_string(seed) + name);
      CloudWriteOptions options;
      options.binary = !ascii;
      options.double_precision = wide;
      write_point_cloud(path, c, options);
      std::vector<std::string> warnings;
      const PointCloud r = read_point_cloud(path, {Unit::kMetre, CloudFormat::kAuto, &warnings});
      const std::string what = path;
      EXPECT_TRUE(warnings.empty()) << what << ": " << warnings.front();
      // PLY and PCD store float32 where that moves no coordinate by over a micrometre and keeps a
      // field to float32's precision; XYZ and double_precision keep doubles exactly.
      const bool pcd = name.find(".xyz") == std::string::npos && !wide;
      expect_near(r.P, c.P, pcd ? 1e-6 : 0, what + " P");
      expect_near(r.N, c.N, pcd ? 1e-6 : 0, what + " N");
      EXPECT_TRUE(r.C == c.C) << what;
      ASSERT_EQ(r.point_scalars.size(), c.point_scalars.size()) << what;
      for (const auto& [field, values] : c.point_scalars) {
        ASSERT_EQ(r.point_scalars.count(field), 1u) << what << " " << field;
        expect_near(r.point_scalars.at(field), values, pcd ? 1e-6 * std::max(1.0, values.cwiseAbs().maxCoeff()) : 0, what + " " + field);
      }
    }
  }
}

}  // namespace
}  // namespace posekit
