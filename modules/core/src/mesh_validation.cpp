#include "posekit/core/mesh_validation.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_topology.h"

namespace posekit {

MeshReport validate_mesh(const TriangleMesh& mesh) {
  MeshReport r;
  r.num_vertices = mesh.num_vertices();
  r.num_faces = mesh.num_faces();
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v)
    if (!mesh.V.row(v).allFinite()) ++r.non_finite_vertices;
  // Faces with a bad index are left out of every other count.
  std::vector<bool> good(mesh.num_faces(), true);
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c)
      if (mesh.F(f, c) < 0 || mesh.F(f, c) >= mesh.num_vertices()) {
        ++r.out_of_range_indices;
        good[f] = false;
      }
  TriangleMesh clean;
  {
    long n = std::count(good.begin(), good.end(), true);
    clean.F.resize(n, 3);
    long row = 0;
    for (Eigen::Index f = 0; f < mesh.num_faces(); ++f)
      if (good[f]) clean.F.row(row++) = mesh.F.row(f);
  }
  const Eigen::MatrixXi& F = clean.F;
  std::vector<std::array<int, 3>> sorted_faces;
  sorted_faces.reserve(F.rows());
  std::vector<bool> used(mesh.num_vertices(), false);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    std::array<int, 3> t{F(f, 0), F(f, 1), F(f, 2)};
    for (int v : t) used[v] = true;
    std::sort(t.begin(), t.end());
    sorted_faces.push_back(t);
    bool degenerate = t[0] == t[1] || t[1] == t[2];
    if (!degenerate) {
      const Eigen::Vector3d a = mesh.V.row(t[0]), b = mesh.V.row(t[1]), c = mesh.V.row(t[2]);
      degenerate = (b - a).cross(c - a).norm() == 0.0;
    }
    if (degenerate) ++r.degenerate_faces;
  }
  std::sort(sorted_faces.begin(), sorted_faces.end());
  for (size_t i = 1; i < sorted_faces.size(); ++i)
    if (sorted_faces[i] == sorted_faces[i - 1]) ++r.duplicate_faces;
  r.unreferenced_vertices = std::count(used.begin(), used.end(), false);

  int non_manifold = 0;
  const Eigen::MatrixXi TT = face_adjacency(F, &non_manifold);
  r.non_manifold_edges = non_manifold;
  r.boundary_edges = (TT.array() < 0).count();
  r.boundary_loops = static_cast<long>(boundary_loops(F).size());
  r.components = connected_components(F, static_cast<int>(mesh.num_vertices()), nullptr);
  r.watertight = F.rows() > 0 && r.boundary_edges == 0 && r.non_manifold_edges == 0;
  if (r.non_finite_vertices == 0) {
    r.surface_area = surface_area(mesh.V, F);
    r.signed_volume = signed_volume(mesh.V, F);
  }
  return r;
}

void require_usable_mesh(const TriangleMesh& mesh, const std::string& what) {
  if (mesh.V.cols() != 3 || (mesh.F.rows() > 0 && mesh.F.cols() != 3)) throw InvalidInput(what + ": expected V #V x 3 and F #F x 3");
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v)
    if (!mesh.V.row(v).allFinite()) throw InvalidInput(what + ": vertex " + std::to_string(v) + " has a non-finite coordinate");
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      if (mesh.F(f, c) < 0 || mesh.F(f, c) >= mesh.V.rows())
        throw InvalidInput(what + ": face " + std::to_string(f) + " has vertex index " + std::to_string(mesh.F(f, c)) + ", expected 0.." +
                           std::to_string(mesh.V.rows() - 1));
}

FloatingBits find_floating_bits(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double min_area_fraction) {
  FloatingBits r;
  r.keep_face.assign(static_cast<size_t>(F.rows()), true);
  if (F.rows() == 0) return r;
  Eigen::VectorXi component;
  const int count = connected_components(F, static_cast<int>(V.rows()), &component);
  if (count < 2) return r;
  const Eigen::VectorXd face_area = face_areas(V, F);
  std::vector<double> area(static_cast<size_t>(count), 0.0);
  for (Eigen::Index f = 0; f < F.rows(); ++f) area[static_cast<size_t>(component[f])] += face_area[f];
  const double largest = *std::max_element(area.begin(), area.end());
  for (int c = 0; c < count; ++c)
    if (area[static_cast<size_t>(c)] < min_area_fraction * largest) ++r.bits, r.area += area[static_cast<size_t>(c)];
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    r.keep_face[static_cast<size_t>(f)] = !(area[static_cast<size_t>(component[f])] < min_area_fraction * largest);
  return r;
}

std::string FloatingBits::describe() const {
  char text[160];
  std::snprintf(text, sizeof text, "left out %d floating piece%s (%.4g m^2 in all) apart from the body", bits, bits == 1 ? "" : "s", area);
  return text;
}

}  // namespace posekit
