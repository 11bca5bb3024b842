#include "posekit/core/mesh_slice.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>

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
  // The tape's path: the four corners in order round the square, in its plane, the inner point left out.
  P.col(1).setConstant(0.7);
  const Eigen::MatrixXd tape = convex_hull_loop(P, Eigen::Vector3d::UnitY());
  ASSERT_EQ(tape.rows(), 4);
  EXPECT_NEAR(polyline_length(tape, true), 4.0, 1e-12);
  EXPECT_NEAR(tape.col(1).minCoeff(), 0.7, 1e-12);
  EXPECT_NEAR(tape.col(1).maxCoeff(), 0.7, 1e-12);
  for (Eigen::Index k = 0; k < 4; ++k) EXPECT_NE(tape.row(k), Eigen::RowVector3d(0.5, 0.7, 0.5));
}

TEST(MeshSlice, HullPerimeterDoesNotDependOnThePointsOrderToTheBit) {
  // Loops in loop order (a few monotone runs, merged), with repeated points and ties in x, a jagged
  // loop (many runs: sorted outright), each against the same points shuffled, and against a gift
  // wrap of the hull.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.02, 0.02);
  for (int kind = 0; kind < 3; ++kind) {
    const int n = 600;
    Eigen::MatrixXd P(n, 3);
    for (int i = 0; i < n; ++i) {
      const double a = 2 * M_PI * i / n;
      const double r = kind == 2 ? 1 + jitter(rng) * 10 : 1 + 0.3 * std::cos(3 * a);  // a trefoil-like bulge or jagged
      P.row(i) << r * std::cos(a), 0.5, 0.7 * r * std::sin(a);
      if (kind == 1 && i % 50 == 0 && i > 0) P.row(i) = P.row(i - 1);         // repeated points
      if (kind == 1 && i % 75 == 0) P(i, 0) = std::round(P(i, 0) * 10) / 10;  // ties in x
    }
    const double in_order = convex_hull_perimeter(P, Eigen::Vector3d::UnitY());
    std::vector<Eigen::Index> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    const Eigen::MatrixXd Q = P(order, Eigen::all);
    const double shuffled = convex_hull_perimeter(Q, Eigen::Vector3d::UnitY());
    EXPECT_EQ(std::memcmp(&in_order, &shuffled, sizeof(double)), 0) << kind << ": " << in_order << " against " << shuffled;
    // Gift wrapping in the XZ plane.
    int start = 0;
    for (int i = 1; i < n; ++i)
      if (P(i, 0) < P(start, 0) || (P(i, 0) == P(start, 0) && P(i, 2) < P(start, 2))) start = i;
    double length = 0;
    int at = start;
    do {
      int next = at == 0 ? 1 : 0;
      for (int i = 0; i < n; ++i) {
        const double cross = (P(next, 0) - P(at, 0)) * (P(i, 2) - P(at, 2)) - (P(next, 2) - P(at, 2)) * (P(i, 0) - P(at, 0));
        const double d_next = (P.row(next) - P.row(at)).squaredNorm(), d_i = (P.row(i) - P.row(at)).squaredNorm();
        if (cross < 0 || (cross == 0 && d_i > d_next)) next = i;
      }
      length += (P.row(next) - P.row(at)).norm();
      at = next;
    } while (at != start && length < 100);
    EXPECT_NEAR(in_order, length, 1e-9) << kind;
  }
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

TEST(MeshSlice, EvenAndClusteredStacksEqualOneSliceAtATimeToTheBit) {
  // Each face meets the same planes in a stack as alone, whether the levels are even (a body's
  // 5 mm stack) or cluster (refinement heights beside far ones).
  const TriangleMesh s = test::icosphere(5, 1.0);
  std::vector<double> even, clustered;
  for (int k = 0; k < 200; ++k) even.push_back(-0.995 + 0.01 * k);     // as a body's 5 mm stack
  for (int k = 0; k < 40; ++k) clustered.push_back(0.3 + 0.0005 * k);  // 40 levels within 2 cm
  clustered.push_back(-0.8);
  clustered.push_back(0.95);
  const Eigen::Vector3d normal(0.1, 1, 0);
  for (const std::vector<double>* levels : {&even, &clustered}) {
    const auto stack = slice_mesh_stack(s.V, s.F, normal, *levels);
    for (size_t i = 0; i < levels->size(); ++i) {
      const auto one = slice_mesh(s.V, s.F, normal, (*levels)[i]);
      ASSERT_EQ(stack[i].size(), one.size()) << "level " << (*levels)[i];
      for (size_t l = 0; l < one.size(); ++l) EXPECT_TRUE(stack[i][l].points == one[l].points) << "level " << (*levels)[i];
    }
  }
}

TEST(MeshSlice, AStackOnSeveralThreadsHasTheSameLoopsToTheBit) {
  // Over 80k faces (several ranges of faces per thread): two spheres, one of them cut open at its
  // top (open chains there), sliced at 300 levels given out of order.
  const TriangleMesh a = test::icosphere(6, 1.0);
  TriangleMesh b = test::icosphere(4, 0.5);
  b.V.col(0).array() += 2.5;
  std::vector<int> kept;
  for (Eigen::Index f = 0; f < b.F.rows(); ++f)
    if (b.V(b.F(f, 0), 1) < 0.3 || b.V(b.F(f, 1), 1) < 0.3 || b.V(b.F(f, 2), 1) < 0.3) kept.push_back(static_cast<int>(f));
  Eigen::MatrixXd V(a.V.rows() + b.V.rows(), 3);
  V << a.V, b.V;
  Eigen::MatrixXi F(a.F.rows() + static_cast<Eigen::Index>(kept.size()), 3);
  F.topRows(a.F.rows()) = a.F;
  for (size_t k = 0; k < kept.size(); ++k)
    F.row(a.F.rows() + static_cast<Eigen::Index>(k)) = b.F.row(kept[k]).array() + static_cast<int>(a.V.rows());
  ASSERT_GT(F.rows(), 3 * 16384);
  std::vector<double> levels;
  for (int k = 0; k < 300; ++k) levels.push_back(-1.05 + 2.1 * ((k * 7) % 300) / 300.0);
  const auto one = slice_mesh_stack(V, F, Eigen::Vector3d(0, 1, 0.1), levels, 1);
  int open = 0;
  for (int threads : {2, 3, 0}) {
    const auto many = slice_mesh_stack(V, F, Eigen::Vector3d(0, 1, 0.1), levels, threads);
    ASSERT_EQ(many.size(), one.size());
    for (size_t i = 0; i < one.size(); ++i) {
      ASSERT_EQ(many[i].size(), one[i].size()) << threads << " threads, level " << i;
      for (size_t l = 0; l < one[i].size(); ++l) {
        EXPECT_EQ(many[i][l].closed, one[i][l].closed);
        EXPECT_TRUE(many[i][l].points == one[i][l].points) << threads << " threads, level " << i << ", loop " << l;
        open += !one[i][l].closed;
      }
    }
  }
  EXPECT_GT(open, 0);  // the cut sphere's open chains were among them
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

TEST(MeshSlice, LoopDistanceOfLongLoopsIsTheBruteForceMinimum) {
  // A torso-like ellipse of 500 points and arm-like circles of 120 beside it (many blocks of
  // segments, most far from the other loop); open and closed.
  const auto ellipse = [](int n, double cx, double cz, double rx, double rz, double phase, bool closed) {
    SectionLoop l;
    l.points.resize(n, 3);
    for (int i = 0; i < n; ++i) {
      const double t = phase + 2 * M_PI * i / n;
      l.points.row(i) << cx + rx * std::cos(t), 0.01 * std::sin(7 * t), cz + rz * std::sin(t);
    }
    l.closed = closed;
    return l;
  };
  const auto brute = [](const SectionLoop& a, const SectionLoop& b) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& [from, to] : {std::pair{&a, &b}, std::pair{&b, &a}}) {
      const Eigen::Index n = to->points.rows(), segments = to->closed ? n : n - 1;
      for (Eigen::Index i = 0; i < from->points.rows(); ++i)
        for (Eigen::Index s = 0; s < segments; ++s) {
          const Eigen::Vector3d p = from->points.row(i).transpose(), q0 = to->points.row(s).transpose(),
                                d = to->points.row((s + 1) % n).transpose() - q0;
          const double t = std::clamp((p - q0).dot(d) / d.squaredNorm(), 0.0, 1.0);
          best = std::min(best, (p - q0 - t * d).norm());
        }
    }
    return best;
  };
  const SectionLoop torso = ellipse(500, 0, 0, 0.17, 0.11, 0.3, true);
  for (double gap : {0.0, 0.004, 0.03, 0.2})
    for (bool closed : {true, false}) {
      const SectionLoop arm = ellipse(120, 0.17 + 0.045 + gap, 0.01, 0.045, 0.04, 1.0, closed);
      EXPECT_NEAR(loop_distance(torso, arm), brute(torso, arm), 1e-15) << gap;
      EXPECT_NEAR(loop_distance(arm, torso), brute(torso, arm), 1e-15) << gap;
    }
}
