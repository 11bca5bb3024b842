#pragma once
#include <Eigen/Core>
#include <map>
#include <string>

namespace posekit {

/// A point cloud in metres (a scan, a sampled surface).
struct PointCloud {
  Eigen::MatrixXd P;  ///< #P x 3 positions (m)
  Eigen::MatrixXd N;  ///< #P x 3 normals, or empty
  /// Named per-point scalar fields, each of length #P (e.g. "intensity").
  std::map<std::string, Eigen::VectorXd> point_scalars;

  Eigen::Index size() const { return P.rows(); }
  bool has_normals() const { return N.rows() == P.rows() && N.rows() > 0; }
};

}  // namespace posekit
