#include "posekit/core/mesh_validation.h"

#include <gtest/gtest.h>

#include <cmath>

#include "posekit/core/error.h"
#include "testing/test_meshes.h"

using namespace posekit;

TEST(MeshValidation, CleanCubeIsWatertightAndUsable) {
  const MeshReport r = validate_mesh(test::unit_cube());
  EXPECT_TRUE(r.usable());
  EXPECT_TRUE(r.watertight);
  EXPECT_EQ(r.components, 1);
  EXPECT_EQ(r.degenerate_faces + r.duplicate_faces + r.unreferenced_vertices + r.boundary_edges, 0);
  EXPECT_NEAR(r.signed_volume, 1.0, 1e-12);
}

TEST(MeshValidation, CountsEveryKindOfDefect) {
  TriangleMesh m = test::unit_cube();
  m.V.conservativeResize(10, 3);
  m.V.row(8) << 0.5, 0.5, 0.5;       // unreferenced
  m.V.row(9) << std::nan(""), 0, 0;  // non-finite
  m.F.conservativeResize(16, 3);
  m.F.row(12) << 0, 2, 1;   // duplicate of face 0
  m.F.row(13) << 0, 0, 1;   // degenerate (repeated index)
  m.F.row(14) << 0, 1, 12;  // out of range
  m.F.row(15) << -1, 1, 2;  // negative
  const MeshReport r = validate_mesh(m);
  EXPECT_EQ(r.out_of_range_indices, 2);
  EXPECT_EQ(r.non_finite_vertices, 1);
  EXPECT_EQ(r.duplicate_faces, 1);
  EXPECT_EQ(r.degenerate_faces, 1);
  EXPECT_EQ(r.unreferenced_vertices, 2);
  EXPECT_FALSE(r.usable());
  EXPECT_FALSE(r.watertight);
}

TEST(MeshValidation, OpenGridReportsItsBoundary) {
  const MeshReport r = validate_mesh(test::grid(3));
  EXPECT_EQ(r.boundary_loops, 1);
  EXPECT_EQ(r.boundary_edges, 12);
  EXPECT_FALSE(r.watertight);
}

TEST(MeshValidation, RequireUsableNamesTheBadElement) {
  TriangleMesh m = test::unit_cube();
  m.F(5, 1) = 99;
  try {
    require_usable_mesh(m, "subject.ply");
    FAIL() << "no exception";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("subject.ply: face 5"), std::string::npos) << e.what();
  }
}

TEST(MeshValidation, ExtractGroupKeepsOnlyThatGroupReindexed) {
  TriangleMesh m = test::unit_cube();
  m.group_names = {"bottom", "rest"};
  m.face_group = Eigen::VectorXi::Ones(12);
  m.face_group[0] = m.face_group[1] = 0;
  m.vertex_scalars["id"] = Eigen::VectorXd::LinSpaced(8, 0, 7);
  std::vector<int> map;
  const TriangleMesh bottom = extract_group(m, "bottom", &map);
  EXPECT_EQ(bottom.num_faces(), 2);
  EXPECT_EQ(bottom.num_vertices(), 4);
  for (int v = 0; v < 4; ++v) {
    EXPECT_EQ(bottom.V.row(v), m.V.row(map[v]));
    EXPECT_EQ(bottom.vertex_scalars.at("id")[v], map[v]);
  }
  EXPECT_THROW(extract_group(m, "missing"), InvalidInput);
}
