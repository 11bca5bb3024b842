#include "posekit/evaluation/scan_comparison.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "posekit/body/makehuman_model.h"
#include "posekit/body/subjects.h"
#include "posekit/core/closest_point.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/datasets/scanner.h"
#include "testing/makehuman_fixture.h"
#include "testing/test_meshes.h"

using namespace posekit;

namespace {

/// Points on the mesh (face samples), each with its face's outward normal.
void sample_surface(const TriangleMesh& m, int per_face, Eigen::MatrixXd* P, Eigen::MatrixXd* N) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  const Eigen::MatrixXd fn = face_normals(m.V, m.F);
  P->resize(m.F.rows() * per_face, 3);
  N->resize(m.F.rows() * per_face, 3);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < per_face; ++k) {
      double a = u(rng), b = u(rng);
      if (a + b > 1) a = 1 - a, b = 1 - b;
      P->row(f * per_face + k) = (1 - a - b) * m.V.row(m.F(f, 0)) + a * m.V.row(m.F(f, 1)) + b * m.V.row(m.F(f, 2));
      N->row(f * per_face + k) = fn.row(f);
    }
}

}  // namespace

TEST(ClosestPoint, MatchesABruteForceSearch) {
  const TriangleMesh s = test::icosphere(3, 0.5);
  const TriangleTree tree(s.V, s.F);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::MatrixXd P(500, 3);
  for (Eigen::Index i = 0; i < P.rows(); ++i) P.row(i) << u(rng), u(rng), u(rng);
  const ClosestPoints cp = tree.closest(P, 2);
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    double best = 1e300;
    for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
      const Eigen::Vector3d q = closest_point_on_triangle(P.row(i), s.V.row(s.F(f, 0)), s.V.row(s.F(f, 1)), s.V.row(s.F(f, 2)));
      best = std::min(best, (q - P.row(i).transpose()).norm());
    }
    ASSERT_NEAR(cp.distance[i], best, 1e-12) << i;
    ASSERT_NEAR((cp.point.row(i) - P.row(i)).norm(), best, 1e-12);
  }
  // Queries near the surface (as a scan's), in random order, on 1 and 2 threads: each query starts
  // from its Morton predecessor's triangle, and face, barycentrics and point must still agree.
  Eigen::MatrixXd Q(2000, 3);
  std::normal_distribution<double> noise(0, 0.003);
  for (Eigen::Index i = 0; i < Q.rows(); ++i) {
    const Eigen::Vector3d dir(u(rng), u(rng), u(rng));
    Q.row(i) = (dir.normalized() * (0.5 + noise(rng))).transpose();
  }
  for (const int threads : {1, 2}) {
    const ClosestPoints near = tree.closest(Q, threads);
    for (Eigen::Index i = 0; i < Q.rows(); ++i) {
      double best = 1e300;
      for (Eigen::Index f = 0; f < s.F.rows(); ++f)
        best = std::min(
            best, (closest_point_on_triangle(Q.row(i), s.V.row(s.F(f, 0)), s.V.row(s.F(f, 1)), s.V.row(s.F(f, 2))) - Q.row(i).transpose())
                      .norm());
      ASSERT_NEAR(near.distance[i], best, 1e-12) << i;
      const int f = near.face[i];
      const Eigen::RowVector3d from_bary =
          near.bary(i, 0) * s.V.row(s.F(f, 0)) + near.bary(i, 1) * s.V.row(s.F(f, 1)) + near.bary(i, 2) * s.V.row(s.F(f, 2));
      ASSERT_LT((from_bary - near.point.row(i)).norm(), 1e-12) << i;
    }
  }
  // Start faces (any face, or none) bound the search and leave the result exact.
  Eigen::VectorXi start(Q.rows());
  std::uniform_int_distribution<int> any_face(-1, static_cast<int>(s.F.rows()) - 1);
  for (Eigen::Index i = 0; i < Q.rows(); ++i) start[i] = any_face(rng);
  const ClosestPoints plain = tree.closest(Q, 1), started = tree.closest(Q, 2, &start);
  for (Eigen::Index i = 0; i < Q.rows(); ++i) ASSERT_NEAR(started.distance[i], plain.distance[i], 1e-15) << i;
  const Eigen::VectorXi too_few = start.head(10);
  EXPECT_THROW(tree.closest(Q, 1, &too_few), InvalidInput);
  // Triangles sharing one centroid (one Morton code) and a thin strip (a flat box): the build's
  // splits must still make a tree that answers exactly.
  TriangleMesh pile;
  pile.V.resize(3 * 40, 3);
  pile.F.resize(40, 3);
  for (int k = 0; k < 40; ++k) {
    const double r = 0.1 + 0.01 * k;
    pile.V.row(3 * k) << r, 0, 0;
    pile.V.row(3 * k + 1) << -r / 2, r * 0.866, 0;
    pile.V.row(3 * k + 2) << -r / 2, -r * 0.866, 0;
    pile.F.row(k) << 3 * k, 3 * k + 1, 3 * k + 2;
  }
  TriangleMesh strip;
  strip.V.resize(2 * 500, 3);
  strip.F.resize(2 * 499, 3);
  for (int k = 0; k < 500; ++k) {
    strip.V.row(2 * k) << 0.01 * k, 0, 0;
    strip.V.row(2 * k + 1) << 0.01 * k, 0.001, 1e-4 * (k % 3);
    if (k + 1 < 500) {
      strip.F.row(2 * k) << 2 * k, 2 * k + 2, 2 * k + 1;
      strip.F.row(2 * k + 1) << 2 * k + 1, 2 * k + 2, 2 * k + 3;
    }
  }
  for (const TriangleMesh* m : {&pile, &strip}) {
    const TriangleTree t(m->V, m->F);
    const ClosestPoints got = t.closest(P * 3, 1);
    for (Eigen::Index i = 0; i < P.rows(); ++i) {
      double best = 1e300;
      for (Eigen::Index f = 0; f < m->F.rows(); ++f)
        best = std::min(best, (closest_point_on_triangle(3 * P.row(i), m->V.row(m->F(f, 0)), m->V.row(m->F(f, 1)), m->V.row(m->F(f, 2))) -
                               3 * P.row(i).transpose())
                                  .norm());
      ASSERT_NEAR(got.distance[i], best, 1e-12) << i;
    }
  }
  // Vertex, edge and face regions of one triangle.
  const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_TRUE(closest_point_on_triangle({-1, -1, 2}, a, b, c).isApprox(a));
  EXPECT_TRUE(closest_point_on_triangle({0.5, -2, 0}, a, b, c).isApprox(Eigen::Vector3d(0.5, 0, 0)));
  EXPECT_TRUE(closest_point_on_triangle({1, 1, 0}, a, b, c).isApprox(Eigen::Vector3d(0.5, 0.5, 0)));
  EXPECT_TRUE(closest_point_on_triangle({0.2, 0.3, -4}, a, b, c).isApprox(Eigen::Vector3d(0.2, 0.3, 0)));
}

TEST(ScanComparison, PointsOnTheSurfaceAreAtZeroAndOffsetPointsAtTheirOffset) {
  TriangleMesh body = test::icosphere(4, 0.3);
  Eigen::MatrixXd P, N;
  sample_surface(body, 4, &P, &N);
  PointCloud on;
  on.P = P;
  const ScanComparison zero = compare_with_scan(body, on);
  EXPECT_LT(zero.scan_to_model.cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_EQ(zero.uncovered_vertices, 0);
  EXPECT_NEAR(zero.coverage, 1.0, 1e-12);
  for (double d : {0.004, -0.003}) {  // 4 mm outside, 3 mm inside
    PointCloud offset;
    offset.P = P + d * N;
    const ScanComparison r = compare_with_scan(body, offset);
    for (Eigen::Index i = 0; i < P.rows(); ++i) ASSERT_NEAR(r.scan_to_model[i], d, 1e-4) << i;
    EXPECT_NEAR(r.scan_stats.signed_mean_mm, 1000 * d, 0.1);
    EXPECT_NEAR(r.scan_stats.mean_mm, 1000 * std::abs(d), 0.1);
    EXPECT_NEAR(r.scan_stats.p95_mm, 1000 * std::abs(d), 0.1);
    EXPECT_GT(r.model_stats.signed_mean_mm * d, 0) << "model-to-scan has the same sign";
  }
  // Outliers are counted apart and do not enter the mean.
  PointCloud noisy = on;
  noisy.P.conservativeResize(P.rows() + 3, 3);
  noisy.P.bottomRows(3) << 0, 0.5, 0, 0, -0.5, 0, 0.5, 0, 0;
  const ScanComparison o = compare_with_scan(body, noisy);
  EXPECT_EQ(o.scan_stats.outliers, 3);
  EXPECT_LT(o.scan_stats.mean_mm, 1e-6);
  EXPECT_NEAR(o.hausdorff_mm, 200, 1.0);  // (0, 0.5, 0) is 0.2 m off the 0.3 m sphere
}

TEST(ScanComparison, VerticesUnderAHoleAreUncoveredNotErrors) {
  TriangleMesh body = test::icosphere(4, 0.3);
  Eigen::MatrixXd P, N;
  sample_surface(body, 4, &P, &N);
  PointCloud holed;
  std::vector<int> keep;
  for (Eigen::Index i = 0; i < P.rows(); ++i)
    if (P(i, 1) < 0.22) keep.push_back(static_cast<int>(i));  // the top cap is not scanned
  holed.P.resize(static_cast<Eigen::Index>(keep.size()), 3);
  for (size_t k = 0; k < keep.size(); ++k) holed.P.row(static_cast<Eigen::Index>(k)) = P.row(keep[k]);
  const ScanComparison r = compare_with_scan(body, holed);
  EXPECT_GT(r.uncovered_vertices, 50);
  EXPECT_LT(r.coverage, 0.97);
  for (Eigen::Index v = 0; v < body.V.rows(); ++v) {
    if (body.V(v, 1) > 0.26) {
      EXPECT_TRUE(std::isnan(r.model_to_scan[v])) << v;
    } else if (body.V(v, 1) < 0.2) {
      EXPECT_TRUE(std::isfinite(r.model_to_scan[v])) << v;
    }
  }
  EXPECT_LT(r.model_stats.max_mm, 1000 * r.coverage_radius + 1e-9);
}

TEST(ScanComparison, RejectsEmptyScansNaNMeshesAndUnitMixUps) {
  const TriangleMesh body = test::icosphere(3, 0.9);
  EXPECT_THROW(compare_with_scan(body, PointCloud{}), InvalidInput);
  PointCloud mm;
  mm.P = body.V * 1000;  // the same body in mm, read as metres
  try {
    compare_with_scan(body, mm);
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean mm"), std::string::npos) << e.what();
  }
  TriangleMesh nan = body;
  nan.V(3, 1) = std::nan("");
  PointCloud ok;
  ok.P = body.V;
  EXPECT_THROW(compare_with_scan(nan, ok), InvalidInput);
}

TEST(ScanComparison, ReadInPiecesGivesTheWholeScansResultsToTheBit) {
  // A scan with a hole, noise and outliers, shuffled so that a piece's points lie all over the body:
  // read 700 points at a time, every distance, statistic and the coverage equal the whole scan's.
  const TriangleMesh body = test::icosphere(4, 0.3);
  Eigen::MatrixXd P, N;
  sample_surface(body, 3, &P, &N);
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0, 0.002);
  std::vector<Eigen::Index> order;
  for (Eigen::Index i = 0; i < P.rows(); ++i)
    if (P(i, 1) < 0.22) order.push_back(i);
  std::shuffle(order.begin(), order.end(), rng);
  PointCloud scan;
  scan.P.resize(static_cast<Eigen::Index>(order.size()) + 2, 3);
  for (size_t k = 0; k < order.size(); ++k) scan.P.row(static_cast<Eigen::Index>(k)) = P.row(order[k]) + noise(rng) * N.row(order[k]);
  scan.P.bottomRows(2) << 0, -0.5, 0, 0.4, 0, 0;
  for (double radius : {0.0, 0.012}) {
    ScanComparisonOptions o;
    o.coverage_radius = radius;
    const ScanComparison whole = compare_with_scan(body, scan, o);
    ScanPieces pieces;
    pieces.size = scan.P.rows();
    pieces.piece = 700;
    int passes = 0;
    pieces.read = [&](Eigen::Index first, Eigen::Index count, Eigen::MatrixXd* points) {
      *points = scan.P.middleRows(first, count);
      passes += first == 0 && count == 700;
    };
    const ScanComparison r = compare_with_scan(body, pieces, o);
    EXPECT_EQ(passes, 2) << "passes over the points";
    EXPECT_EQ(r.coverage_radius, whole.coverage_radius);
    EXPECT_GT(whole.uncovered_vertices, 50);
    EXPECT_EQ(r.uncovered_vertices, whole.uncovered_vertices);
    ASSERT_EQ(r.scan_to_model.size(), whole.scan_to_model.size());
    EXPECT_TRUE((r.scan_to_model.array() == whole.scan_to_model.array()).all());
    for (Eigen::Index v = 0; v < body.V.rows(); ++v)
      ASSERT_TRUE(r.model_to_scan[v] == whole.model_to_scan[v] || (std::isnan(r.model_to_scan[v]) && std::isnan(whole.model_to_scan[v])))
          << v;
    for (auto [a, b] : {std::pair{&r.scan_stats, &whole.scan_stats}, std::pair{&r.model_stats, &whole.model_stats}}) {
      EXPECT_EQ(a->mean_mm, b->mean_mm);
      EXPECT_EQ(a->rms_mm, b->rms_mm);
      EXPECT_EQ(a->p95_mm, b->p95_mm);
      EXPECT_EQ(a->max_mm, b->max_mm);
      EXPECT_EQ(a->outliers, b->outliers);
    }
    EXPECT_EQ(r.hausdorff_mm, whole.hausdorff_mm);
  }
  // The same checks as the whole scan's: the unit mix-up is named.
  ScanPieces mm;
  mm.size = scan.P.rows();
  mm.read = [&](Eigen::Index first, Eigen::Index count, Eigen::MatrixXd* points) { *points = 1000 * scan.P.middleRows(first, count); };
  try {
    compare_with_scan(body, mm);
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean mm"), std::string::npos) << e.what();
  }
}

TEST(ScanComparison, GirthsOfABodyAgreeWithThoseOfItsSimulatedScan) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Body b = build_body(model, make_subject_spec(model, 1, 0).spec);
  PointCloud scan;
  scan.P = simulate_scan(b.mesh).cloud.P;
  const auto girths = girth_discrepancies(b.mesh, scan);
  int measured = 0;
  for (const auto& g : girths) {
    if (!g.measured) continue;
    ++measured;
    if (g.name == "bust" || g.name == "waist" || g.name == "hip") {
      EXPECT_LT(std::abs(g.difference_cm), 1.0) << g.name << " " << g.model_cm << " vs " << g.scan_cm;
    }
    // The scan's floor is its lowest seen point and the soles are not seen: stature comes out short.
    if (g.name == "stature") {
      EXPECT_LT(std::abs(g.difference_cm), 1.5) << g.model_cm << " vs " << g.scan_cm;
    }
  }
  EXPECT_GE(measured, 8);
  const ScanComparison r = compare_with_scan(b.mesh, scan);
  EXPECT_LT(r.scan_stats.rms_mm, 2.5);  // the scanner's noise is 1.5 mm
  EXPECT_GT(r.coverage, 0.85);          // soles and occluded folds are not seen
}
