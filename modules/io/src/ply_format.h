#pragma once
// Internal: PLY reading/writing shared by meshes and point clouds.
#include <Eigen/Core>
#include <map>
#include <string>

#include "posekit/core/triangle_mesh.h"

namespace posekit::io_detail {

struct PlyContent {
  Eigen::MatrixXd V;  ///< #V x 3 (already scaled to metres)
  Eigen::MatrixXd N;
  RowMatrixX3u8 C;
  std::map<std::string, Eigen::VectorXd> scalars;
  Eigen::MatrixXi F;  ///< triangulated faces, empty when the file has none
};

/// `scale` multiplies coordinates (file unit -> metres).
PlyContent read_ply(const std::string& path, double scale);

/// `scale` multiplies coordinates (metres -> file unit). F may be empty (point cloud).
void write_ply(const std::string& path, const PlyContent& content, bool binary, double scale);

}  // namespace posekit::io_detail
