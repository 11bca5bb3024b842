#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <string>

namespace posekit {

/// Per-element RGB colours, 0..255.
using RowMatrixX3u8 = Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3>;

/// A point cloud in metres (a scan, a sampled surface).
struct PointCloud {
  Eigen::MatrixXd P;  ///< #P x 3 positions (m)
  Eigen::MatrixXd N;  ///< #P x 3 normals, or empty
  RowMatrixX3u8 C;    ///< #P x 3 RGB colours, or empty
  /// Named per-point scalar fields, each of length #P (e.g. "intensity").
  std::map<std::string, Eigen::VectorXd> point_scalars;

  Eigen::Index size() const { return P.rows(); }
  bool has_normals() const { return N.rows() == P.rows() && N.rows() > 0; }
  bool has_colors() const { return C.rows() == P.rows() && C.rows() > 0; }
};

}  // namespace posekit
