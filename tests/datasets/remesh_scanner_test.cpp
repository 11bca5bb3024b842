#include <gtest/gtest.h>

#include <set>

#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/datasets/remesh.h"
#include "posekit/datasets/scanner.h"
#include "testing/makehuman_fixture.h"
#include "testing/test_meshes.h"

using namespace posekit;

TEST(Remesh, BodyGetsItsOwnTopologyOnTheSameSurface) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Body b = build_body(model, BodySpec{});
  SurfacePoints corr;
  const TriangleMesh r = remesh_body(b.mesh, 12400, &corr);
  EXPECT_NEAR(r.num_vertices(), 12400, 250);
  EXPECT_GE(r.num_faces(), 23000);
  EXPECT_LE(r.num_faces(), 25000);
  const MeshReport rep = validate_mesh(r);
  EXPECT_TRUE(rep.watertight);
  EXPECT_EQ(rep.components, 1);
  EXPECT_EQ(rep.degenerate_faces, 0);
  EXPECT_NEAR(rep.signed_volume, signed_volume(b.mesh.V, b.mesh.F), 0.01 * rep.signed_volume);
  // No shared connectivity: no triangle of the remesh is a triangle of the original.
  std::set<std::array<long, 9>> original;
  auto key = [](const Eigen::MatrixXd& V, const Eigen::RowVector3i& f) {
    std::array<std::array<long, 3>, 3> c;
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) c[k][d] = std::lround(V(f[k], d) * 1e6);
    std::sort(c.begin(), c.end());
    return std::array<long, 9>{c[0][0], c[0][1], c[0][2], c[1][0], c[1][1], c[1][2], c[2][0], c[2][1], c[2][2]};
  };
  for (Eigen::Index f = 0; f < b.mesh.F.rows(); ++f) original.insert(key(b.mesh.V, b.mesh.F.row(f)));
  int shared = 0;
  for (Eigen::Index f = 0; f < r.F.rows(); ++f) shared += original.count(key(r.V, r.F.row(f)));
  EXPECT_EQ(shared, 0);
  int near_original = 0;  // vertices that happen to sit on an original vertex
  for (Eigen::Index i = 0; i < r.V.rows(); ++i) near_original += (b.mesh.V.rowwise() - r.V.row(i)).rowwise().norm().minCoeff() < 5e-4;
  EXPECT_LT(near_original, r.V.rows() / 10);
  // The correspondence reproduces every vertex on the smooth surface, which lies a little outside
  // the flat triangles (measured: at most 2.1 mm).
  const Eigen::MatrixXd N = vertex_normals(b.mesh.V, b.mesh.F);
  EXPECT_LT((evaluate_smooth_surface_points(b.mesh.V, b.mesh.F, N, corr) - r.V).rowwise().norm().maxCoeff(), 1e-9);
  const Eigen::VectorXd lift = (evaluate_surface_points(b.mesh.V, b.mesh.F, corr) - r.V).rowwise().norm();
  EXPECT_GT(lift.maxCoeff(), 1e-4);
  EXPECT_LT(lift.maxCoeff(), 0.003);
  EXPECT_LT(corr.distance.maxCoeff(), 0.01);
}

TEST(Scanner, PointsLieOnTheSurfaceExceptDeclaredOutliersAndSolesAreUnseen) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Body b = build_body(model, BodySpec{});
  ScannerOptions o;
  o.width = 320;
  o.height = 480;
  o.focal_px = 345;
  o.outlier_fraction = 0.002;
  const SimulatedScan scan = simulate_scan(b.mesh, o);
  EXPECT_GE(scan.cloud.size(), 200000);
  EXPECT_LE(scan.cloud.size(), 1000000);
  EXPECT_EQ(scan.cameras.size(), 8u);
  const SurfacePoints sp = closest_surface_points(b.mesh, scan.cloud.P);
  const Eigen::VectorXd& outlier = scan.cloud.point_scalars.at("outlier");
  EXPECT_EQ(static_cast<int>(outlier.sum()), scan.outliers);
  int far_inliers = 0;
  double sum_sq = 0;
  for (Eigen::Index i = 0; i < scan.cloud.size(); ++i)
    if (outlier[i] == 0) {
      far_inliers += sp.distance[i] > 0.005;
      sum_sq += sp.distance[i] * sp.distance[i];
    }
  EXPECT_LT(far_inliers, scan.cloud.size() / 200);  // 3 sigma along the ray: ~0.3% beyond
  EXPECT_NEAR(std::sqrt(sum_sq / (scan.cloud.size() - scan.outliers)), 0.0015, 0.0004);
  // The soles face the floor: no camera sees them (a few grazing hits on their rims at most).
  const Eigen::MatrixXd FN = face_normals(b.mesh.V, b.mesh.F);
  const double floor = b.mesh.V.col(1).minCoeff();
  std::vector<int> hits(b.mesh.F.rows(), 0);
  for (Eigen::Index i = 0; i < sp.face.size(); ++i)
    if (outlier[i] == 0) ++hits[sp.face[i]];
  int sole_faces = 0, seen_sole_faces = 0;
  for (Eigen::Index f = 0; f < b.mesh.F.rows(); ++f) {
    const double y = (b.mesh.V(b.mesh.F(f, 0), 1) + b.mesh.V(b.mesh.F(f, 1), 1) + b.mesh.V(b.mesh.F(f, 2), 1)) / 3;
    if (y < floor + 0.01 && FN(f, 1) < -0.9) ++sole_faces, seen_sole_faces += hits[f] > 0;
  }
  ASSERT_GT(sole_faces, 20);
  EXPECT_LT(seen_sole_faces, sole_faces / 20) << seen_sole_faces << " of " << sole_faces << " sole triangles seen";
}

TEST(Scanner, InterpenetratingSpheresAreFusedIntoOneClosedSurface) {
  // Two spheres of radius 1 whose centres are 1.6 apart: each pokes 0.4 into the other, as
  // thighs pressed together do. The fused surface is the union's: closed, one piece, no vertex
  // inside either sphere, the volume of the union.
  TriangleMesh a = test::icosphere(4), b = test::icosphere(4);
  b.V.col(0).array() += 1.6;
  TriangleMesh both;
  both.V.resize(a.V.rows() + b.V.rows(), 3);
  both.V << a.V, b.V;
  both.F.resize(a.F.rows() + b.F.rows(), 3);
  both.F << a.F, (b.F.array() + static_cast<int>(a.V.rows())).matrix();
  std::vector<int> origin;
  const TriangleMesh fused =
      fuse_interpenetrating_surfaces(both, Eigen::AlignedBox3d(Eigen::Vector3d::Constant(-5), Eigen::Vector3d::Constant(5)), &origin);
  const MeshReport report = validate_mesh(fused);
  EXPECT_TRUE(report.watertight);
  EXPECT_EQ(report.components, 1);
  EXPECT_EQ(origin.size(), static_cast<size_t>(fused.F.rows()));
  // The caps inside reach 0.2 deep; what is left of them is within an edge (0.08) of the seam.
  for (Eigen::Index v = 0; v < fused.V.rows(); ++v) {
    EXPECT_GT(fused.V.row(v).norm(), 0.92);
    EXPECT_GT((fused.V.row(v) - Eigen::RowVector3d(1.6, 0, 0)).norm(), 0.92);
  }
  // Union of two unit spheres 1.6 apart: 2 (4/3 pi) - 2 caps of height 0.2.
  const double cap = M_PI * 0.2 * 0.2 * (3 - 0.2) / 3;
  EXPECT_NEAR(signed_volume(fused.V, fused.F), 2 * (4.0 / 3 * M_PI) - 2 * cap, 0.02);
  // Outside the region nothing is removed; spheres apart are left as they are.
  const TriangleMesh untouched =
      fuse_interpenetrating_surfaces(both, Eigen::AlignedBox3d(Eigen::Vector3d::Constant(10), Eigen::Vector3d::Constant(11)));
  EXPECT_EQ(untouched.F.rows(), both.F.rows());
}
