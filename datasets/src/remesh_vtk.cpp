// The VTK half of remeshing (the "remesh" plugin, see posekit/core/plugin.h): closest points by a
// cell locator, Loop subdivision and quadric decimation.
#include "posekit/datasets/remesh.h"

#include <vtkCellArray.h>
#include <vtkCellLocator.h>
#include <vtkGenericCell.h>
#include <vtkIdList.h>
#include <vtkLoopSubdivisionFilter.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkQuadricDecimation.h>
#include <vtkSmartPointer.h>

#include <Eigen/Geometry>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_topology.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/core/plugin.h"

namespace posekit {
namespace {

vtkSmartPointer<vtkPolyData> to_vtk(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(V.rows());
  for (Eigen::Index i = 0; i < V.rows(); ++i) points->SetPoint(i, V(i, 0), V(i, 1), V(i, 2));
  vtkNew<vtkCellArray> cells;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const vtkIdType ids[3] = {F(f, 0), F(f, 1), F(f, 2)};
    cells->InsertNextCell(3, ids);
  }
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetPolys(cells);
  return poly;
}

TriangleMesh from_vtk(vtkPolyData* poly) {
  TriangleMesh m;
  m.V.resize(poly->GetNumberOfPoints(), 3);
  for (vtkIdType i = 0; i < poly->GetNumberOfPoints(); ++i) {
    double p[3];
    poly->GetPoint(i, p);
    m.V.row(i) << p[0], p[1], p[2];
  }
  std::vector<int> tris;
  vtkNew<vtkIdList> ids;
  vtkCellArray* polys = poly->GetPolys();
  polys->InitTraversal();
  while (polys->GetNextCell(ids)) {
    if (ids->GetNumberOfIds() != 3) continue;
    for (int k = 0; k < 3; ++k) tris.push_back(static_cast<int>(ids->GetId(k)));
  }
  m.F = Eigen::Map<Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>>(tris.data(), static_cast<Eigen::Index>(tris.size() / 3), 3);
  return m;
}

}  // namespace

SurfacePoints closest_surface_points_vtk(const TriangleMesh& mesh, const Eigen::MatrixXd& P) {
  require_usable_mesh(mesh, "closest_surface_points");
  auto poly = to_vtk(mesh.V, mesh.F);
  vtkNew<vtkCellLocator> locator;  // built serially: ties resolve the same way in every run
  locator->SetDataSet(poly);
  locator->BuildLocator();
  vtkNew<vtkGenericCell> cell;
  SurfacePoints s;
  s.face.resize(P.rows());
  s.bary.resize(P.rows(), 3);
  s.distance.resize(P.rows());
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    double q[3] = {P(i, 0), P(i, 1), P(i, 2)}, closest[3], d2 = 0;
    vtkIdType cell_id = -1;
    int sub_id = 0;
    locator->FindClosestPoint(q, closest, cell, cell_id, sub_id, d2);
    if (cell_id < 0) throw InvalidInput("closest_surface_points: no closest triangle found for point " + std::to_string(i));
    const Eigen::Vector3d c(closest[0], closest[1], closest[2]);
    const auto f = static_cast<Eigen::Index>(cell_id);
    const Eigen::Vector3d b = clamped_barycentric(c, mesh.V.row(mesh.F(f, 0)), mesh.V.row(mesh.F(f, 1)), mesh.V.row(mesh.F(f, 2)));
    s.face[i] = static_cast<int>(f);
    s.bary.row(i) = b.transpose();
    s.distance[i] = std::sqrt(d2);
  }
  return s;
}

namespace {

/// One decimation and snap; `report` tells whether the result is a closed, non-degenerate manifold.
TriangleMesh decimate_and_snap(const TriangleMesh& mesh, vtkPolyData* fine, int target_vertices, SurfacePoints* snap_out,
                               MeshReport* report) {
  vtkNew<vtkQuadricDecimation> decimate;
  decimate->SetInputData(fine);
  decimate->SetTargetReduction(std::clamp(1.0 - target_vertices / static_cast<double>(fine->GetNumberOfPoints()), 0.0, 0.99));
  decimate->VolumePreservationOn();
  decimate->Update();
  TriangleMesh out = from_vtk(decimate->GetOutput());
  out = extract_faces(out, std::vector<bool>(out.num_faces(), true));  // drop unused points
  const Eigen::MatrixXd decimated = out.V;
  SurfacePoints snap = closest_surface_points_vtk(mesh, out.V);
  out.V = evaluate_smooth_surface_points(mesh.V, mesh.F, vertex_normals(mesh.V, mesh.F), snap);
  // Two vertices snapped onto one point (at a crease) flatten their triangles: those vertices keep
  // their decimated positions, a fraction of a millimetre off the surface.
  auto flat_triangle_vertices = [&] {
    std::vector<int> flat;
    for (Eigen::Index f = 0; f < out.F.rows(); ++f) {
      const Eigen::Vector3d a = out.V.row(out.F(f, 0)), b = out.V.row(out.F(f, 1)), c = out.V.row(out.F(f, 2));
      if ((b - a).cross(c - a).norm() < 1e-12)
        for (int k = 0; k < 3; ++k) flat.push_back(out.F(f, k));
    }
    return flat;
  };
  std::vector<int> revert = flat_triangle_vertices();
  if (!revert.empty()) {
    for (int v : revert) out.V.row(v) = decimated.row(v);
    // Where two surfaces touch (closed lips) decimation can put two vertices on one point: move the
    // vertices of still-flat triangles a little (at most 0.2 mm) toward their one-ring centroid.
    const std::vector<int> still_flat = flat_triangle_vertices();
    if (!still_flat.empty()) {
      const VertexFaces vf = vertex_faces(out.F, static_cast<int>(out.V.rows()));
      for (int v : still_flat) {
        Eigen::Vector3d ring = Eigen::Vector3d::Zero();
        int n = 0;
        for (int k = vf.offsets[v]; k < vf.offsets[v + 1]; ++k)
          for (int c = 0; c < 3; ++c) ring += out.V.row(out.F(vf.face_index[k], c)).transpose(), ++n;
        const Eigen::Vector3d step = (ring / n - out.V.row(v).transpose()) * 0.2;
        out.V.row(v) += (step.norm() > 2e-4 ? Eigen::Vector3d(step.normalized() * 2e-4) : step).transpose();
      }
      revert.insert(revert.end(), still_flat.begin(), still_flat.end());
    }
    const SurfacePoints again = closest_surface_points_vtk(mesh, out.V);
    for (int v : revert) {
      snap.face[v] = again.face[v];
      snap.bary.row(v) = again.bary.row(v);
      snap.distance[v] = again.distance[v];
    }
  }
  *report = validate_mesh(out);
  *snap_out = std::move(snap);
  return out;
}

}  // namespace

TriangleMesh remesh_body_vtk(const TriangleMesh& mesh, int target_vertices, SurfacePoints* correspondence) {
  require_usable_mesh(mesh, "remesh_body");
  if (target_vertices < 100) throw InvalidInput("remesh_body: target_vertices must be at least 100");
  // Loop subdivision moves every vertex, so decimation cannot fall back onto the original vertices
  // and triangles (a midpoint subdivision decimates straight back to the original mesh).
  vtkNew<vtkLoopSubdivisionFilter> subdivide;
  subdivide->SetInputData(to_vtk(mesh.V, mesh.F));
  subdivide->SetNumberOfSubdivisions(1);
  subdivide->Update();
  MeshReport r;
  SurfacePoints snap;
  TriangleMesh out = decimate_and_snap(mesh, subdivide->GetOutput(), target_vertices, &snap, &r);
  if (r.watertight && r.components == 1 && r.degenerate_faces == 0 && r.duplicate_faces == 0) {
    if (correspondence) *correspondence = std::move(snap);
    return out;
  }
  throw InvalidInput("remesh_body: the remeshed body is not a closed manifold (" + std::to_string(r.boundary_edges) + " boundary edges, " +
                     std::to_string(r.non_manifold_edges) + " non-manifold edges, " + std::to_string(r.degenerate_faces) +
                     " degenerate faces)");
}

}  // namespace posekit

POSEKIT_PLUGIN_EXPORT void posekit_closest_surface_points(const posekit::TriangleMesh& mesh, const Eigen::MatrixXd& P,
                                                          posekit::SurfacePoints* out) {
  *out = posekit::closest_surface_points_vtk(mesh, P);
}

POSEKIT_PLUGIN_EXPORT void posekit_remesh_body(const posekit::TriangleMesh& mesh, int target_vertices,
                                               posekit::SurfacePoints* correspondence, posekit::TriangleMesh* out) {
  *out = posekit::remesh_body_vtk(mesh, target_vertices, correspondence);
}
