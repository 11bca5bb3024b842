#pragma once
// Connectivity of a triangle mesh: edges, face adjacency, boundary loops, components.
#include <Eigen/Core>
#include <vector>

#include "posekit/core/triangle_mesh.h"

namespace posekit {

/// Unique undirected edges, #E x 2 with E(e,0) < E(e,1), sorted.
Eigen::MatrixXi unique_edges(const Eigen::MatrixXi& F);

/// Face adjacency across edges: TT(f,i) is the face sharing edge (F(f,i), F(f,(i+1)%3)) with f,
/// or -1 on a boundary. On a non-manifold edge (more than two faces) one neighbour is chosen and
/// `non_manifold_edges` (optional) counts such edges.
Eigen::MatrixXi face_adjacency(const Eigen::MatrixXi& F, int* non_manifold_edges = nullptr);

/// Whether edge i of face f (F(f,i) to F(f,(i+1)%3)) is on a boundary, no other face having it:
/// entry 3f + i. Linear time. (An edge of three or more faces is not a boundary.)
std::vector<char> border_edges(const Eigen::MatrixXi& F);

/// Closed boundary loops, each an ordered list of vertex indices following the boundary edges.
std::vector<std::vector<int>> boundary_loops(const Eigen::MatrixXi& F);

/// Connected components of faces (through shared edges or vertices): a label per face in
/// [0, count), components numbered by first face. Returns count.
int connected_components(const Eigen::MatrixXi& F, int num_vertices, Eigen::VectorXi* face_labels);

/// For each vertex, the faces that use it (CSR: faces of v are
/// face_index[offsets[v] .. offsets[v+1]) ).
struct VertexFaces {
  std::vector<int> offsets;
  std::vector<int> face_index;
};
VertexFaces vertex_faces(const Eigen::MatrixXi& F, int num_vertices);

/// Midpoint subdivision: every triangle split into four by its edge midpoints, the surface unchanged
/// (a finer tessellation of the same polygons). Triangle f becomes triangles 4f .. 4f+3. Only V and F
/// are carried over.
TriangleMesh subdivide_midpoints(const TriangleMesh& mesh);

}  // namespace posekit
