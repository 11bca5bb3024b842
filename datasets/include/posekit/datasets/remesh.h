#pragma once
// A body in a different topology (like a customized model from another pipeline), and the exact
// surface correspondence back to the mesh it came from.
#include <Eigen/Core>

#include "posekit/core/triangle_mesh.h"

namespace posekit {

/// Where a point lies on a mesh: its triangle and barycentric coordinates (sum 1).
struct SurfacePoints {
  Eigen::VectorXi face;      ///< #P triangle indices
  Eigen::MatrixXd bary;      ///< #P x 3 barycentric coordinates
  Eigen::VectorXd distance;  ///< #P distance from the query point to the surface (m)
};

/// Closest points on `mesh` (any triangle mesh) of the rows of P (#P x 3).
SurfacePoints closest_surface_points(const TriangleMesh& mesh, const Eigen::MatrixXd& P);

/// Positions of surface points on a mesh with the same triangles (e.g. the posed template), #P x 3.
Eigen::MatrixXd evaluate_surface_points(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const SurfacePoints& s);

/// The same points on the smooth surface through the mesh's vertices (phong_surface_point, unit
/// vertex normals N), #P x 3.
Eigen::MatrixXd evaluate_smooth_surface_points(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& N,
                                               const SurfacePoints& s);

/// Remeshes a closed body to about `target_vertices` vertices with none of its connectivity:
/// Loop subdivision, quadric decimation, then every vertex snapped back onto the original's
/// smooth surface (its closest point on the triangles, moved onto the Phong surface through the
/// original's vertices: evaluate_smooth_surface_points), so the shape is unchanged. Snapping onto
/// the flat triangles instead would cut every curve with chords of chords and shrink a thigh's
/// girth by about 1 mm; a scanner or another modeller samples the body, not its polygons (vertices whose snap would flatten a triangle keep
/// their decimated position, and where two surfaces touch, e.g. closed lips, coincident vertices move apart by at most 0.2 mm).
/// `correspondence` (optional) receives the snap: for each new vertex its triangle of `mesh` and barycentric coordinates. Throws
/// InvalidInput if the result is not a closed manifold.
TriangleMesh remesh_body(const TriangleMesh& mesh, int target_vertices, SurfacePoints* correspondence = nullptr);

}  // namespace posekit
