#pragma once
// Internal: PLY reading/writing shared by meshes and point clouds.
#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>

#include "posekit/core/triangle_mesh.h"

namespace posekit::io_detail {

struct PlyContent {
  Eigen::MatrixXd V;  ///< #V x 3 (already scaled to metres)
  Eigen::MatrixXd N;
  RowMatrixX3u8 C;
  Eigen::MatrixXd UV;  ///< #V x 2 texture coordinates, or empty
  std::map<std::string, Eigen::VectorXd> scalars;
  Eigen::MatrixXi F;  ///< triangulated faces, empty when the file has none
  /// Per-triangle values of the face element's scalar properties (a polygon's on each of its triangles).
  std::map<std::string, Eigen::VectorXd> face_scalars;
};

/// `scale` multiplies coordinates (file unit -> metres). With `finite_only` a vertex with a NaN or
/// infinite coordinate is an error (meshes); otherwise it is returned for the caller to drop.
PlyContent read_ply(const std::string& path, double scale, bool finite_only, std::vector<std::string>* warnings);

/// `scale` multiplies coordinates (metres -> file unit). F may be empty (point cloud). Each column is
/// float32 where that keeps its values (parse_util.h), or float64 everywhere with `all_double`.
/// Vertex scalars are written as `scalar_<name>` (CloudCompare keeps only those), alpha as itself.
void write_ply(const std::string& path, const PlyContent& content, bool binary, double scale, bool all_double);

/// The name a vertex scalar field is written under, and the one it is read back as.
std::string ply_scalar_property(const std::string& field);
std::string ply_scalar_field(const std::string& property);

}  // namespace posekit::io_detail
