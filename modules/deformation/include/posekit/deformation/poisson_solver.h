#pragma once
// Vertex positions from per-triangle transformations (Eq. 5-6 of Zhu & Mok, deformation transfer
// of Sumner & Popovic 2004): min_x sum_k w_k area_k sum_edges |x_j - x_i - T_k (v_j - v_i)|^2, w_k = 1
// unless given. The matrix depends only on the mesh and w, so it is factorised once (sparse
// Cholesky); a solve is one forward and one backward sweep over the factor for x, y and z together.
#include <Eigen/Core>
#include <memory>

namespace posekit {

class PoissonSolver {
 public:
  /// #F x 12: per triangle, three 3-vectors each followed by a zero pad (see weighted_rest_edges()).
  using EdgeMatrix = Eigen::Matrix<double, Eigen::Dynamic, 12, Eigen::RowMajor>;
  using RowMatrixX3d = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

  /// Rest mesh V (#V x 3), F (#F x 3). `position_weight` (#V, optional) adds soft constraints
  /// w_v |x_v - target_v|^2 whose targets are given per solve. Throws InvalidInput on a degenerate or
  /// disconnected mesh. `triangle_weight` (#F, optional, > 0) multiplies each triangle's area in the
  /// least squares (a weighted Eq. 6).
  PoissonSolver(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXd& position_weight = {},
                const Eigen::VectorXd& triangle_weight = {});
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

  /// Row k: w_k area_k (v_{c+1} - v_c) for the corners c = 0, 1, 2 of triangle k: x y z and a 0 each.
  const EdgeMatrix& weighted_rest_edges() const;

  /// The fast form of the two solves above for callers that already have T_k applied to the
  /// weighted rest edges (row k: T_k e_0, 0, T_k e_1, 0, T_k e_2, 0 with e_c from
  /// weighted_rest_edges(); the pads must stay 0). `X` is resized
  /// to #V x 3 when needed; nothing else is allocated once the calling thread has solved before.
  void solve_transformed_edges(const EdgeMatrix& transformed_edges, const RowMatrixX3d& position_targets, Eigen::MatrixXd* X) const;
  void solve_transformed_edges(const EdgeMatrix& transformed_edges, const Eigen::VectorXd& anchor_weight, const Eigen::Matrix3d& R,
                               const Eigen::Vector3d& t, Eigen::MatrixXd* X) const;

  /// Low-level form for kernels that assemble the right-hand side themselves (posing): a zeroed
  /// per-thread buffer of #V rows of 4 doubles (x y z, then a pad left 0), 32-byte aligned, in the
  /// factor's row order. Corner c of triangle k is row factor_corners()[3 k + c] and receives
  /// e_{c-1} - e_c, the transformed edges as in solve_transformed_edges(). finish() then adds the
  /// position targets (or places the anchor), solves in place and writes X. The buffer is the
  /// thread's own and is reused by this thread's next solve with any PoissonSolver.
  double* start_right_hand_side() const;
  const int* factor_corners() const;
  void finish(double* right_hand_side, const RowMatrixX3d& position_targets, Eigen::MatrixXd* X) const;
  void finish(double* right_hand_side, const Eigen::VectorXd& anchor_weight, const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
              Eigen::MatrixXd* X) const;

  /// The lowest level: Y (from start_right_hand_side(), assembled) <- the solution, in the factor's
  /// row order (vertex v is row factor_rows()[v]); no anchor, no targets. The translation is then
  /// arbitrary: for callers that place the result themselves.
  void solve_in_place(double* right_hand_side) const;
  const int* factor_rows() const;

  bool has_position_weights() const;
  int num_vertices() const;
  int num_faces() const;
  /// Non-zeros of the factor's strictly lower triangle (the cost of one solve is about 12 flops each).
  long factor_nonzeros() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Whether the solver and posing kernels may use AVX2+FMA where the CPU has them (the default).
/// Off, they run the baseline x86-64 code (same results up to rounding); for tests and benchmarks.
/// Returns whether AVX2 kernels were in use before.
bool use_avx2_kernels(bool enabled);

}  // namespace posekit
