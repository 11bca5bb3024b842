#include "posekit/core/mesh_geometry.h"

#include <Eigen/Geometry>

#include "posekit/core/error.h"

namespace posekit {
namespace {
inline Eigen::Vector3d corner(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, Eigen::Index f, int c) {
  return V.row(F(f, c)).transpose();
}
inline Eigen::Vector3d face_cross(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, Eigen::Index f) {
  const Eigen::Vector3d a = corner(V, F, f, 0);
  return (corner(V, F, f, 1) - a).cross(corner(V, F, f, 2) - a);
}
}  // namespace

Eigen::MatrixXd face_normals(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  Eigen::MatrixXd N(F.rows(), 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d n = face_cross(V, F, f);
    const double len = n.norm();
    N.row(f) = len > 0 ? Eigen::RowVector3d(n.transpose() / len) : Eigen::RowVector3d::Zero();
  }
  return N;
}

Eigen::VectorXd face_areas(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  Eigen::VectorXd A(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) A[f] = 0.5 * face_cross(V, F, f).norm();
  return A;
}

Eigen::MatrixXd face_centroids(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  Eigen::MatrixXd C(F.rows(), 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f) C.row(f) = (V.row(F(f, 0)) + V.row(F(f, 1)) + V.row(F(f, 2))) / 3.0;
  return C;
}

Eigen::Vector3d phong_surface_point(const Eigen::MatrixXd& V, const Eigen::MatrixXd& N, const Eigen::Vector3i& corners,
                                    const Eigen::Vector3d& bary) {
  Eigen::Vector3d flat = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k)
    if (bary[k] != 0) flat += bary[k] * V.row(corners[k]).transpose();
  Eigen::Vector3d lift = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) {
    if (bary[k] == 0) continue;
    const Eigen::Vector3d n = N.row(corners[k]).transpose();
    lift -= bary[k] * (flat - V.row(corners[k]).transpose()).dot(n) * n;
  }
  return flat + 0.5 * lift;
}

Eigen::MatrixXd vertex_normals(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  Eigen::MatrixXd N = Eigen::MatrixXd::Zero(V.rows(), 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::RowVector3d n = face_cross(V, F, f).transpose();  // length = 2 * area
    for (int c = 0; c < 3; ++c) N.row(F(f, c)) += n;
  }
  for (Eigen::Index v = 0; v < N.rows(); ++v) {
    const double len = N.row(v).norm();
    if (len > 0) N.row(v) /= len;
  }
  return N;
}

Eigen::Vector3d clamped_barycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                    const Eigen::Vector3d& c) {
  const Eigen::Vector3d v0 = b - a, v1 = c - a, v2 = p - a;
  const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0), d21 = v2.dot(v1);
  const double den = d00 * d11 - d01 * d01;
  if (den <= 0) return Eigen::Vector3d(1, 0, 0);
  Eigen::Vector3d w(0, (d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den);
  w[0] = 1 - w[1] - w[2];
  w = w.cwiseMax(0.0);
  return w / w.sum();
}

BoundingBox bounding_box(const Eigen::MatrixXd& P) {
  if (P.rows() == 0) throw InvalidInput("bounding_box: no points");
  BoundingBox box;
  box.min = P.colwise().minCoeff().transpose();
  box.max = P.colwise().maxCoeff().transpose();
  return box;
}

double signed_volume(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  // Tetrahedra fan from the vertex mean rather than the origin: exact for any closed mesh and
  // free of cancellation when the body is far from the origin.
  const Eigen::Vector3d o = V.rows() > 0 ? Eigen::Vector3d(V.colwise().mean().transpose()) : Eigen::Vector3d::Zero();
  double six_volume = 0.0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = corner(V, F, f, 0) - o;
    six_volume += a.dot((corner(V, F, f, 1) - o).cross(corner(V, F, f, 2) - o));
  }
  return six_volume / 6.0;
}

double surface_area(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) { return face_areas(V, F).sum(); }

}  // namespace posekit
