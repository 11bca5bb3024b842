#include "posekit/core/mesh_geometry.h"

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <algorithm>
#include <string>
#include <vector>

#include "posekit/core/error.h"
#include "testing/test_meshes.h"

using namespace posekit;

TEST(MeshGeometry, UnitCubeHasVolumeOneAndAreaSix) {
  const TriangleMesh cube = test::unit_cube();
  EXPECT_NEAR(signed_volume(cube.V, cube.F), 1.0, 1e-12);
  EXPECT_NEAR(surface_area(cube.V, cube.F), 6.0, 1e-12);
}

TEST(MeshGeometry, VolumeIsRigidMotionInvariantAndScalesCubically) {
  const TriangleMesh sphere = test::icosphere(3);
  const double v0 = signed_volume(sphere.V, sphere.F);
  EXPECT_GT(v0, 0.0);
  EXPECT_NEAR(v0, 4.0 / 3.0 * M_PI, 0.03 * 4.0);  // subdivided icosphere underestimates slightly
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  for (double s : {1e-3, 1.0, 1e3}) {
    Eigen::MatrixXd V = (s * sphere.V * R.transpose()).rowwise() + Eigen::RowVector3d(5, -2, 1);
    EXPECT_NEAR(signed_volume(V, sphere.F) / (s * s * s), v0, 1e-9 * v0);
    EXPECT_NEAR(surface_area(V, sphere.F) / (s * s), surface_area(sphere.V, sphere.F), 1e-9);
  }
}

TEST(MeshGeometry, FaceNormalsOfCubePointOutward) {
  const TriangleMesh cube = test::unit_cube();
  const Eigen::MatrixXd N = face_normals(cube.V, cube.F);
  const Eigen::MatrixXd C = face_centroids(cube.V, cube.F);
  for (Eigen::Index f = 0; f < cube.F.rows(); ++f) {
    EXPECT_NEAR(N.row(f).norm(), 1.0, 1e-12);
    EXPECT_GT(N.row(f).dot(C.row(f) - Eigen::RowVector3d(0.5, 0.5, 0.5)), 0.0) << "face " << f;
  }
}

TEST(MeshGeometry, VertexNormalsOfSpherePointAlongRadius) {
  const TriangleMesh sphere = test::icosphere(2);
  const Eigen::MatrixXd N = vertex_normals(sphere.V, sphere.F);
  for (Eigen::Index v = 0; v < sphere.V.rows(); ++v) EXPECT_GT(N.row(v).dot(sphere.V.row(v).normalized()), 0.99);
}

TEST(MeshGeometry, AreasAndCentroidsOfOneTriangle) {
  Eigen::MatrixXd V(3, 3);
  V << 0, 0, 0, 2, 0, 0, 0, 3, 0;
  Eigen::MatrixXi F(1, 3);
  F << 0, 1, 2;
  EXPECT_NEAR(face_areas(V, F)[0], 3.0, 1e-12);
  EXPECT_TRUE(face_centroids(V, F).row(0).isApprox(Eigen::RowVector3d(2.0 / 3, 1.0, 0)));
  EXPECT_TRUE(face_normals(V, F).row(0).isApprox(Eigen::RowVector3d(0, 0, 1)));
}

TEST(MeshGeometry, BoundingBoxOfEmptySetThrows) {
  EXPECT_THROW(bounding_box(Eigen::MatrixXd(0, 3)), InvalidInput);
  const BoundingBox b = bounding_box(test::unit_cube().V);
  EXPECT_TRUE(b.extent().isApprox(Eigen::Vector3d(1, 1, 1)));
  EXPECT_TRUE(b.center().isApprox(Eigen::Vector3d(0.5, 0.5, 0.5)));
}
