#pragma once
// Per-face and per-vertex geometric quantities of a triangle mesh.
#include <Eigen/Core>

#include "posekit/core/triangle_mesh.h"

namespace posekit {

/// Unit face normals, #F x 3 (zero rows for degenerate faces).
Eigen::MatrixXd face_normals(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

/// Face areas, #F (m^2 when V is in metres).
Eigen::VectorXd face_areas(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

/// Face centroids, #F x 3 (the c_k of Eq. (2b) of Zhu & Mok).
Eigen::MatrixXd face_centroids(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

/// Area-weighted unit vertex normals, #V x 3 (zero rows for unreferenced vertices).
Eigen::MatrixXd vertex_normals(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

/// The point with barycentric coordinates `bary` in the triangle of vertices `corners` on the smooth
/// surface through the mesh's vertices: Phong tessellation (Boubekeur & Alexa 2008) with shape
/// factor 1/2 and unit vertex normals N, i.e. the flat point moved halfway to the blend of its
/// projections onto the corners' tangent planes. On a sphere through the corners this cancels the
/// flat triangle's sagitta to second order. Corners with weight 0 do not contribute.
Eigen::Vector3d phong_surface_point(const Eigen::MatrixXd& V, const Eigen::MatrixXd& N, const Eigen::Vector3i& corners,
                                    const Eigen::Vector3d& bary);

/// Barycentric coordinates (sum 1, each >= 0) of the point of triangle (a, b, c) nearest to the
/// projection of p onto its plane, clamped into the triangle. (1, 0, 0) for a degenerate triangle.
Eigen::Vector3d clamped_barycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c);

/// Axis-aligned bounding box.
struct BoundingBox {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
  Eigen::Vector3d extent() const { return max - min; }
  Eigen::Vector3d center() const { return 0.5 * (min + max); }
};

/// Bounding box of the rows of P (#P x 3). Throws InvalidInput when P is empty.
BoundingBox bounding_box(const Eigen::MatrixXd& P);

/// Signed enclosed volume by the divergence theorem (m^3); positive for a closed mesh with
/// outward-facing (counter-clockwise) triangles.
double signed_volume(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

/// Total surface area (m^2).
double surface_area(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

}  // namespace posekit
