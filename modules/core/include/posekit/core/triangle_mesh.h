#pragma once
// Triangle mesh: geometry letters follow libigl (V #V x 3, F #F x 3).
#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "posekit/core/point_cloud.h"

namespace posekit {

/// A triangle mesh in metres, Y up, subject facing +Z.
struct TriangleMesh {
  Eigen::MatrixXd V;   ///< #V x 3 vertex positions (m)
  Eigen::MatrixXi F;   ///< #F x 3 vertex indices, counter-clockwise seen from outside
  Eigen::MatrixXd N;   ///< #V x 3 per-vertex normals, or empty
  RowMatrixX3u8 C;     ///< #V x 3 per-vertex RGB colours, or empty
  Eigen::MatrixXd UV;  ///< #V x 2 per-vertex texture coordinates, or empty
  /// Named per-vertex scalar fields, each of length #V (e.g. "error_mm", "part").
  std::map<std::string, Eigen::VectorXd> vertex_scalars;
  /// Named per-face scalar fields, each of length #F (PLY face properties such as a face colour;
  /// a polygon's value is repeated on each of its triangles).
  std::map<std::string, Eigen::VectorXd> face_scalars;
  /// Per-face group index into group_names (OBJ `g`), or empty when the mesh has no groups.
  Eigen::VectorXi face_group;
  std::vector<std::string> group_names;

  Eigen::Index num_vertices() const { return V.rows(); }
  Eigen::Index num_faces() const { return F.rows(); }
  bool has_normals() const { return N.rows() == V.rows() && N.rows() > 0; }
  bool has_colors() const { return C.rows() == V.rows() && C.rows() > 0; }
  bool has_uv() const { return UV.rows() == V.rows() && UV.rows() > 0 && UV.cols() == 2; }
};

/// The faces of one group with only the vertices they use, re-indexed; per-vertex attributes follow.
/// `vertex_map` (optional out) receives, for each new vertex, its index in `mesh`.
/// Throws InvalidInput when the group does not exist.
TriangleMesh extract_group(const TriangleMesh& mesh, const std::string& group, std::vector<int>* vertex_map = nullptr);

/// Keeps the faces whose flag is true and the vertices they use (attributes follow).
TriangleMesh extract_faces(const TriangleMesh& mesh, const std::vector<bool>& keep_face, std::vector<int>* vertex_map = nullptr);

}  // namespace posekit
