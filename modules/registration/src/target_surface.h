#pragma once
// Helpers the surface-fitting registrations share (non-rigid ICP, the shape-space fit).
#include <Eigen/Core>
#include <Eigen/SVD>
#include <vector>

#include "posekit/core/mesh_topology.h"
#include "posekit/core/triangle_mesh.h"

namespace posekit {

/// Which target vertices lie on a hole's border, and which triangle edges do.
struct TargetBoundary {
  std::vector<char> vertex;
  std::vector<char> edge;  // border_edges: 3f + i for edge i of face f

  /// Whether the surface point (face f, barycentric b) lies on the border.
  bool contains(const Eigen::MatrixXi& F, int f, const Eigen::Vector3d& b) const {
    constexpr double kOn = 1e-9;
    for (int c = 0; c < 3; ++c)
      if (b[c] > 1 - kOn) return vertex[static_cast<size_t>(F(f, c))] != 0;
    for (int i = 0; i < 3; ++i)  // edge i joins corners i and i+1 and is opposite corner i+2
      if (edge[static_cast<size_t>(3 * f + i)] && b[(i + 2) % 3] < kOn) return true;
    return false;
  }
};

inline TargetBoundary find_boundary(const TriangleMesh& m) {
  TargetBoundary b;
  b.vertex.assign(static_cast<size_t>(m.V.rows()), 0);
  b.edge = border_edges(m.F);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int i = 0; i < 3; ++i)
      if (b.edge[static_cast<size_t>(3 * f + i)])
        b.vertex[static_cast<size_t>(m.F(f, i))] = b.vertex[static_cast<size_t>(m.F(f, (i + 1) % 3))] = 1;
  return b;
}

/// Least-squares similarity (Umeyama 1991) taking the rows of P onto the rows of Q; rigid without scale.
inline Eigen::Matrix4d similarity(const Eigen::MatrixXd& P, const Eigen::MatrixXd& Q, bool with_scale = true) {
  const Eigen::RowVector3d cp = P.colwise().mean(), cq = Q.colwise().mean();
  const Eigen::MatrixXd A = P.rowwise() - cp, B = Q.rowwise() - cq;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(B.transpose() * A / static_cast<double>(P.rows()), Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) S(2, 2) = -1;
  const Eigen::Matrix3d R = svd.matrixU() * S * svd.matrixV().transpose();
  const double var = A.squaredNorm() / static_cast<double>(P.rows());
  const double scale = !with_scale ? 1.0 : var > 0 ? (svd.singularValues().asDiagonal() * S).trace() / var : 1.0;
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = scale * R;
  T.topRightCorner<3, 1>() = cq.transpose() - scale * R * cp.transpose();
  return T;
}

}  // namespace posekit
