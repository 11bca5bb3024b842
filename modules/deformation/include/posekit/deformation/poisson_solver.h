#pragma once
// Vertex positions from per-triangle transformations (Eq. 5-6 of Zhu & Mok, deformation transfer
// of Sumner & Popovic 2004): min_x sum_k area_k sum_edges |x_j - x_i - T_k (v_j - v_i)|^2. The
// matrix depends only on the mesh, so it is factorised once (sparse Cholesky).
#include <Eigen/Core>
#include <memory>

namespace posekit {

class PoissonSolver {
 public:
  /// Rest mesh V (#V x 3), F (#F x 3). `position_weight` (#V, optional) adds soft constraints
  /// w_v |x_v - target_v|^2 whose targets are given per solve. Throws InvalidInput on a degenerate or
  /// disconnected mesh.
  PoissonSolver(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXd& position_weight = {});
  ~PoissonSolver();
  PoissonSolver(PoissonSolver&&) noexcept;
  PoissonSolver& operator=(PoissonSolver&&) noexcept;

  /// T: #F x 9 row-major per-triangle transformations. Returns #V x 3 positions. The translation,
  /// which the transformations leave free, is fixed by an anchor: the centroid of the triangles
  /// weighted by `anchor_weight` (#F, >= 0, not all zero) goes where x -> R x + t takes it at rest.
  /// Only back-substitutions: no factorisation per call.
  Eigen::MatrixXd solve(const Eigen::MatrixXd& T, const Eigen::VectorXd& anchor_weight, const Eigen::Matrix3d& R,
                        const Eigen::Vector3d& t) const;

  /// With position weights: T as above and the targets of the soft constraints, #V x 3 (rows of
  /// zero-weight vertices are ignored).
  Eigen::MatrixXd solve(const Eigen::MatrixXd& T, const Eigen::MatrixXd& position_targets) const;

  bool has_position_weights() const;
  int num_vertices() const;
  int num_faces() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace posekit
