#include "posekit/core/mesh_slice.h"

#include <gtest/gtest.h>

#include <cmath>

#include "posekit/core/error.h"
#include "posekit/core/winding_number.h"
#include "testing/test_meshes.h"

using namespace posekit;

TEST(MeshSlice, SphereSectionIsAClosedCircleOfTheRightGirth) {
  const TriangleMesh s = test::icosphere(5, 1.0);
  for (double h : {0.0, 0.5, -0.8}) {
    const auto loops = slice_mesh(s.V, s.F, Eigen::Vector3d::UnitY(), h);
    ASSERT_EQ(loops.size(), 1u);
    EXPECT_TRUE(loops[0].closed);
    const double expected = 2 * M_PI * std::sqrt(1 - h * h);
    EXPECT_NEAR(polyline_length(loops[0].points, true), expected, 0.01 * expected);
    EXPECT_NEAR(convex_hull_perimeter(loops[0].points, Eigen::Vector3d::UnitY()), expected, 0.01 * expected);
    for (Eigen::Index i = 0; i < loops[0].points.rows(); ++i) EXPECT_NEAR(loops[0].points(i, 1), h, 1e-12);
  }
}

TEST(MeshSlice, TwoSpheresGiveTwoLoopsAndTheNearestIsFound) {
  TriangleMesh a = test::icosphere(3, 0.5), b = a;
  b.V.col(0).array() += 3.0;
  Eigen::MatrixXd V(a.V.rows() * 2, 3);
  V << a.V, b.V;
  Eigen::MatrixXi F(a.F.rows() * 2, 3);
  F << a.F, (a.F.array() + static_cast<int>(a.V.rows())).matrix();
  const auto loops = slice_mesh(V, F, Eigen::Vector3d(0, 2, 0), 0.2);  // y = 0.1, non-unit normal
  ASSERT_EQ(loops.size(), 2u);
  const int near = nearest_loop(loops, Eigen::Vector3d(3, 0, 0));
  EXPECT_GT(loops[near].points.col(0).mean(), 2.0);
}

TEST(MeshSlice, HullPerimeterBridgesConcavities) {
  Eigen::MatrixXd P(5, 3);  // a square with one point pushed inward
  P << 0, 0, 0, 1, 0, 0, 0.5, 0, 0.5, 1, 0, 1, 0, 0, 1;
  EXPECT_NEAR(convex_hull_perimeter(P, Eigen::Vector3d::UnitY()), 4.0, 1e-12);
}

TEST(MeshSlice, OpenMeshGivesOpenChain) {
  const TriangleMesh g = test::grid(4);  // XZ plane at y = 0
  const auto loops = slice_mesh(g.V, g.F, Eigen::Vector3d::UnitX(), 1.5);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_FALSE(loops[0].closed);
  EXPECT_NEAR(polyline_length(loops[0].points, false), 4.0, 1e-12);
}

TEST(WindingNumber, InsideIsOneOutsideIsZero) {
  const TriangleMesh s = test::icosphere(2, 1.0);
  EXPECT_NEAR(winding_number(s.V, s.F, Eigen::Vector3d(0.1, -0.2, 0.3)), 1.0, 1e-9);
  EXPECT_NEAR(winding_number(s.V, s.F, Eigen::Vector3d(1.5, 0, 0)), 0.0, 1e-9);
}

TEST(MeshSlice, StackEqualsOneSliceAtATime) {
  const TriangleMesh s = test::icosphere(4, 1.0);
  const std::vector<double> levels = {-0.9, -0.31, 0.0, 0.42, 0.77};
  const auto stack = slice_mesh_stack(s.V, s.F, Eigen::Vector3d(0, 1, 0), levels);
  for (size_t i = 0; i < levels.size(); ++i) {
    const auto one = slice_mesh(s.V, s.F, Eigen::Vector3d(0, 1, 0), levels[i]);
    ASSERT_EQ(stack[i].size(), one.size());
    EXPECT_NEAR(polyline_length(stack[i][0].points, true), polyline_length(one[0].points, true), 1e-12);
  }
}

TEST(MeshSlice, LoopDistanceIsTheGapBetweenThePolylines) {
  // Two unit squares 0.3 apart along x, and a vertex of one facing the middle of the other's edge.
  SectionLoop a, b;
  a.points.resize(4, 3);
  a.points << 0, 0, 0, 1, 0, 0, 1, 0, 1, 0, 0, 1;
  a.closed = true;
  b.points = a.points;
  b.points.col(0).array() += 1.3;
  EXPECT_NEAR(loop_distance(a, b), 0.3, 1e-12);
  b.points.row(0) << 1.2, 0, 0.5;  // nearer than any vertex of a: the gap is to a's edge
  EXPECT_NEAR(loop_distance(a, b), 0.2, 1e-12);
  EXPECT_NEAR(loop_distance(b, a), 0.2, 1e-12);
  b.points.row(0) << 1.0, 0, 0.5;  // touching
  EXPECT_NEAR(loop_distance(a, b), 0.0, 1e-12);
  EXPECT_THROW(loop_distance(a, SectionLoop{}), InvalidInput);
}
