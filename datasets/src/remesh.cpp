#include "posekit/datasets/remesh.h"

#include "posekit/core/mesh_geometry.h"
#include "posekit/core/plugin.h"

namespace posekit {

SurfacePoints closest_surface_points(const TriangleMesh& mesh, const Eigen::MatrixXd& P) {
  using Closest = void(const TriangleMesh&, const Eigen::MatrixXd&, SurfacePoints*);
  SurfacePoints s;
  plugin_function<Closest>("remesh", "posekit_closest_surface_points")(mesh, P, &s);
  return s;
}

Eigen::MatrixXd evaluate_surface_points(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const SurfacePoints& s) {
  Eigen::MatrixXd out(s.face.size(), 3);
  for (Eigen::Index i = 0; i < s.face.size(); ++i) {
    const int f = s.face[i];
    out.row(i) = s.bary(i, 0) * V.row(F(f, 0)) + s.bary(i, 1) * V.row(F(f, 1)) + s.bary(i, 2) * V.row(F(f, 2));
  }
  return out;
}

Eigen::MatrixXd evaluate_smooth_surface_points(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& N,
                                               const SurfacePoints& s) {
  Eigen::MatrixXd out(s.face.size(), 3);
  for (Eigen::Index i = 0; i < s.face.size(); ++i)
    out.row(i) = phong_surface_point(V, N, F.row(s.face[i]).transpose(), s.bary.row(i).transpose()).transpose();
  return out;
}

TriangleMesh remesh_body(const TriangleMesh& mesh, int target_vertices, SurfacePoints* correspondence) {
  using Remesh = void(const TriangleMesh&, int, SurfacePoints*, TriangleMesh*);
  TriangleMesh out;
  plugin_function<Remesh>("remesh", "posekit_remesh_body")(mesh, target_vertices, correspondence, &out);
  return out;
}

}  // namespace posekit
