#include "posekit/core/mesh_topology.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "testing/test_meshes.h"

using namespace posekit;

TEST(MeshTopology, CubeHasEighteenEdgesAndNoBoundary) {
  const TriangleMesh cube = test::unit_cube();
  EXPECT_EQ(unique_edges(cube.F).rows(), 18);
  EXPECT_TRUE(boundary_loops(cube.F).empty());
  const Eigen::MatrixXi TT = face_adjacency(cube.F);
  EXPECT_EQ((TT.array() < 0).count(), 0);
}

TEST(MeshTopology, FaceAdjacencyIsSymmetric) {
  const TriangleMesh sphere = test::icosphere(2);
  const Eigen::MatrixXi TT = face_adjacency(sphere.F);
  for (Eigen::Index f = 0; f < TT.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int g = TT(f, c);
      ASSERT_GE(g, 0);
      EXPECT_TRUE((TT.row(g).array() == f).any());
    }
}

TEST(MeshTopology, OpenGridHasOneBoundaryLoopAroundIt) {
  const int n = 5;
  const TriangleMesh g = test::grid(n);
  const auto loops = boundary_loops(g.F);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_EQ(loops[0].size(), static_cast<size_t>(4 * n));
  // Consecutive loop vertices are one grid step apart.
  for (size_t i = 0; i < loops[0].size(); ++i) {
    const int a = loops[0][i], b = loops[0][(i + 1) % loops[0].size()];
    EXPECT_NEAR((g.V.row(a) - g.V.row(b)).norm(), 1.0, 1e-12);
  }
}

TEST(MeshTopology, BorderEdgesAreTheBoundaryLoopsEdgesAndNoOthers) {
  const TriangleMesh g = test::grid(5);
  const std::vector<char> border = border_edges(g.F);
  const Eigen::MatrixXi TT = face_adjacency(g.F);
  ASSERT_EQ(border.size(), static_cast<size_t>(g.F.size()));
  for (Eigen::Index f = 0; f < g.F.rows(); ++f)
    for (int i = 0; i < 3; ++i) EXPECT_EQ(border[static_cast<size_t>(3 * f + i)] != 0, TT(f, i) < 0) << f << " " << i;
  EXPECT_EQ(std::count(border.begin(), border.end(), 1), 20);  // the loop's 4n edges
  for (char b : border_edges(test::icosphere(2).F)) EXPECT_EQ(b, 0);
  // An edge of three faces is no hole's border.
  Eigen::MatrixXi F(3, 3);
  F << 0, 1, 2, 1, 0, 3, 0, 1, 4;
  const std::vector<char> fan = border_edges(F);
  EXPECT_FALSE(fan[0] || fan[3] || fan[6]);
}

TEST(MeshTopology, ComponentsAreCountedAndLabelled) {
  const TriangleMesh a = test::unit_cube();
  Eigen::MatrixXi F(a.F.rows() * 2, 3);
  F << a.F, (a.F.array() + 8).matrix();
  Eigen::VectorXi labels;
  EXPECT_EQ(connected_components(F, 16, &labels), 2);
  EXPECT_EQ(labels[0], 0);
  EXPECT_EQ(labels[F.rows() - 1], 1);
}

TEST(MeshTopology, NonManifoldEdgeIsCounted) {
  Eigen::MatrixXi F(3, 3);
  F << 0, 1, 2, 1, 0, 3, 0, 1, 4;  // three faces on edge (0,1)
  int non_manifold = 0;
  face_adjacency(F, &non_manifold);
  EXPECT_EQ(non_manifold, 1);
}

TEST(MeshTopology, VertexFacesListsEveryIncidence) {
  const TriangleMesh cube = test::unit_cube();
  const VertexFaces vf = vertex_faces(cube.F, 8);
  EXPECT_EQ(vf.offsets.back(), 36);
  for (int v = 0; v < 8; ++v)
    for (int k = vf.offsets[v]; k < vf.offsets[v + 1]; ++k) EXPECT_TRUE((cube.F.row(vf.face_index[k]).array() == v).any());
}
