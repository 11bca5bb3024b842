#include "posekit/deformation/poisson_solver.h"

#include <Eigen/SparseCholesky>
#include <string>
#include <vector>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_topology.h"
#include "simd.h"

namespace posekit {

std::atomic<bool> simd::avx2_allowed{true};

bool use_avx2_kernels(bool enabled) { return simd::avx2_allowed.exchange(enabled) && simd::cpu_has_avx2(); }

namespace {

/// L D L^T of a permuted sparse matrix, solved for x, y and z together. The right-hand side is
/// #n x 4 row-major (x y z and a pad), so that one row is one AVX register where the CPU has AVX2.
class SparseLdlt {
 public:
  /// `lower`: L's strictly lower triangle (column-major, rows sorted); `diagonal`: D.
  void build(const Eigen::SparseMatrix<double>& lower, const Eigen::VectorXd& diagonal) {
    const int n = static_cast<int>(lower.cols());
    column_start_.assign(lower.outerIndexPtr(), lower.outerIndexPtr() + n + 1);
    row_.assign(lower.innerIndexPtr(), lower.innerIndexPtr() + lower.nonZeros());
    value_.assign(lower.valuePtr(), lower.valuePtr() + lower.nonZeros());
    inverse_diagonal_.resize(static_cast<size_t>(n));
    for (int j = 0; j < n; ++j) inverse_diagonal_[static_cast<size_t>(j)] = 1.0 / diagonal[j];
  }
  long nonzeros() const { return static_cast<long>(value_.size()); }
  /// Y (#n x 4 row-major, 32-byte aligned) <- (L D L^T)^-1 Y.
  void solve_in_place(double* Y) const;

 private:
  std::vector<int> column_start_, row_;
  std::vector<double> value_, inverse_diagonal_;
};

// The two sweeps: forward L z = y (column j scattered into the rows below it), scaling by D^-1,
// backward L^T x = z (gathered), two accumulators to shorten the dependency chain.
#define POSEKIT_LDLT_SWEEPS(Row, load, store)                                                 \
  for (int j = 0; j < n; ++j) {                                                               \
    const Row y = load(j);                                                                    \
    for (int p = start[j]; p < start[j + 1]; ++p) store(row[p], load(row[p]) - value[p] * y); \
  }                                                                                           \
  for (int j = 0; j < n; ++j) store(j, load(j) * inverse_diagonal[j]);                        \
  for (int j = n - 1; j >= 0; --j) {                                                          \
    Row a = load(j), b = a * 0.0;                                                             \
    int p = start[j];                                                                         \
    for (; p + 1 < start[j + 1]; p += 2) {                                                    \
      a -= value[p] * load(row[p]);                                                           \
      b -= value[p + 1] * load(row[p + 1]);                                                   \
    }                                                                                         \
    if (p < start[j + 1]) a -= value[p] * load(row[p]);                                       \
    store(j, a + b);                                                                          \
  }

using simd::Double4;

POSEKIT_TARGET_AVX2 void sweeps_avx2(int n, const int* start, const int* row, const double* value, const double* inverse_diagonal,
                                     double* Y) {
  Double4* rows = reinterpret_cast<Double4*>(Y);
#define POSEKIT_LOAD(i) rows[i]
#define POSEKIT_STORE(i, v) rows[i] = (v)
  POSEKIT_LDLT_SWEEPS(Double4, POSEKIT_LOAD, POSEKIT_STORE)
#undef POSEKIT_LOAD
#undef POSEKIT_STORE
}

struct Triple {
  double x, y, z;
  Triple operator-(const Triple& o) const { return {x - o.x, y - o.y, z - o.z}; }
  Triple operator+(const Triple& o) const { return {x + o.x, y + o.y, z + o.z}; }
  Triple operator*(double s) const { return {x * s, y * s, z * s}; }
  Triple& operator-=(const Triple& o) { return *this = *this - o; }
};
Triple operator*(double s, const Triple& t) { return t * s; }

void sweeps_portable(int n, const int* start, const int* row, const double* value, const double* inverse_diagonal, double* Y) {
  auto load = [Y](int i) { return Triple{Y[4 * i], Y[4 * i + 1], Y[4 * i + 2]}; };
  auto store = [Y](int i, const Triple& v) {
    Y[4 * i] = v.x;
    Y[4 * i + 1] = v.y;
    Y[4 * i + 2] = v.z;
  };
  POSEKIT_LDLT_SWEEPS(Triple, load, store)
}
#undef POSEKIT_LDLT_SWEEPS

void SparseLdlt::solve_in_place(double* Y) const {
  const int n = static_cast<int>(inverse_diagonal_.size());
  (simd::has_avx2() ? sweeps_avx2 : sweeps_portable)(n, column_start_.data(), row_.data(), value_.data(), inverse_diagonal_.data(), Y);
}

/// The divergence of the transformed edges (the right-hand side of Eq. 6) added to Y in factor
/// order: corner c of a triangle gets e_{c-1} - e_c.
inline __attribute__((always_inline)) void scatter_edges_body(long triangles, const int* corner, const double* E, double* Y) {
  Double4* rows = reinterpret_cast<Double4*>(Y);
  const simd::Double4u* e = reinterpret_cast<const simd::Double4u*>(E);
  for (long k = 0; k < triangles; ++k, corner += 3, e += 3) {
    rows[corner[0]] += e[2] - e[0];
    rows[corner[1]] += e[0] - e[1];
    rows[corner[2]] += e[1] - e[2];
  }
}
POSEKIT_TARGET_AVX2 void scatter_edges_avx2(long triangles, const int* corner, const double* E, double* Y) {
  scatter_edges_body(triangles, corner, E, Y);
}
void scatter_edges_portable(long triangles, const int* corner, const double* E, double* Y) { scatter_edges_body(triangles, corner, E, Y); }

/// Per-thread scratch for the permuted right-hand side (#n x 4, 32-byte aligned), so that repeated
/// solves do not allocate.
double* scratch(size_t rows) {
  struct alignas(32) Row4 {
    double v[4];
  };
  thread_local std::vector<Row4> buffer;
  if (buffer.size() < rows) buffer.resize(rows);
  return buffer.front().v;
}

}  // namespace

struct PoissonSolver::Impl {
  int num_vertices = 0;
  Eigen::MatrixXi F;
  std::vector<int> permuted_corners;  // 3 per triangle: the corners' rows in the factor
  std::vector<int> row_of_vertex;     // the fill-reducing permutation
  EdgeMatrix weighted_edges;
  Eigen::MatrixXd rest_centroids;
  Eigen::VectorXd position_weight;  // empty: translation fixed by a pin and the anchor
  SparseLdlt factor;

  /// Adds the divergence of the transformed edges to the right-hand side Y (factor order).
  void scatter(const EdgeMatrix& transformed_edges, double* Y) const;
  /// X (#V x 3) from the solution in factor order.
  void copy_out(const double* Y, Eigen::MatrixXd* X) const {
    X->resize(num_vertices, 3);
    for (int v = 0; v < num_vertices; ++v) {
      const double* y = Y + 4 * row_of_vertex[static_cast<size_t>(v)];
      for (int d = 0; d < 3; ++d) (*X)(v, d) = y[d];
    }
  }
  Eigen::MatrixXd edges_from_transformations(const Eigen::MatrixXd& T) const;
};

PoissonSolver::PoissonSolver(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXd& position_weight,
                             const Eigen::VectorXd& triangle_weight)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  if (V.rows() < 3 || F.rows() < 1 || V.cols() != 3 || F.cols() != 3)
    throw InvalidInput("PoissonSolver: the mesh needs vertices (#V x 3) and triangles (#F x 3)");
  if (F.minCoeff() < 0 || F.maxCoeff() >= V.rows())
    throw InvalidInput("PoissonSolver: a triangle index is outside the " + std::to_string(V.rows()) + " vertices");
  Eigen::VectorXi components;
  const int count = connected_components(F, static_cast<int>(V.rows()), &components);
  if (count != 1)
    throw InvalidInput("PoissonSolver: the mesh has " + std::to_string(count) + " connected components; posing needs one connected body");
  s.F = F;
  s.num_vertices = static_cast<int>(V.rows());
  const Eigen::VectorXd area = face_areas(V, F);
  const double mean_area = area.mean();
  if (!(mean_area > 0)) throw InvalidInput("PoissonSolver: all triangles are degenerate");
  Eigen::VectorXd weight = (area.array() + 1e-6 * mean_area).matrix();
  if (triangle_weight.size()) {
    if (triangle_weight.size() != F.rows() || !(triangle_weight.minCoeff() > 0) || !triangle_weight.allFinite())
      throw InvalidInput("PoissonSolver: expected " + std::to_string(F.rows()) + " positive finite triangle weights");
    weight.array() *= triangle_weight.array();
  }
  s.rest_centroids = face_centroids(V, F);
  s.weighted_edges = EdgeMatrix::Zero(F.rows(), 12);
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(static_cast<size_t>(12 * F.rows() + V.rows()));
  std::vector<char> used(static_cast<size_t>(V.rows()), 0);
  for (Eigen::Index k = 0; k < F.rows(); ++k) {
    for (int c = 0; c < 3; ++c) {
      const int i = F(k, c), j = F(k, (c + 1) % 3);
      used[static_cast<size_t>(i)] = 1;
      const double w = weight[k];
      s.weighted_edges.row(k).segment<3>(4 * c) = w * (V.row(j) - V.row(i));
      triplets.emplace_back(i, i, w);
      triplets.emplace_back(j, j, w);
      triplets.emplace_back(i, j, -w);
      triplets.emplace_back(j, i, -w);
    }
  }
  for (size_t v = 0; v < used.size(); ++v)
    if (!used[v]) throw InvalidInput("PoissonSolver: vertex " + std::to_string(v) + " is in no triangle");
  if (position_weight.size()) {
    if (position_weight.size() != V.rows() || !(position_weight.minCoeff() >= 0) || !(position_weight.sum() > 0))
      throw InvalidInput("PoissonSolver: expected " + std::to_string(V.rows()) + " non-negative position weights, not all zero");
    s.position_weight = position_weight;
    for (Eigen::Index v = 0; v < V.rows(); ++v)
      if (position_weight[v] > 0) triplets.emplace_back(v, v, position_weight[v]);
  } else {
    // Translation is free: pin vertex 0 softly; solve() moves the result to its anchor afterwards.
    triplets.emplace_back(0, 0, mean_area);
  }
  Eigen::SparseMatrix<double> L(V.rows(), V.rows());
  L.setFromTriplets(triplets.begin(), triplets.end());
  // Eigen factorises with an AMD ordering (on body meshes as good as METIS nested dissection);
  // the factor is then kept in plain arrays for a solve that sweeps it once for x, y and z.
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(L);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0))
    throw InvalidInput("PoissonSolver: the mesh's system could not be factorised");
  s.factor.build(ldlt.matrixL().nestedExpression(), ldlt.vectorD());
  const int n = s.num_vertices;
  const auto& P = ldlt.permutationP().indices();
  s.row_of_vertex.assign(P.data(), P.data() + n);
  s.permuted_corners.resize(static_cast<size_t>(3 * F.rows()));
  for (Eigen::Index k = 0; k < F.rows(); ++k)
    for (int c = 0; c < 3; ++c) s.permuted_corners[static_cast<size_t>(3 * k + c)] = s.row_of_vertex[static_cast<size_t>(F(k, c))];
}

PoissonSolver::~PoissonSolver() = default;
PoissonSolver::PoissonSolver(PoissonSolver&&) noexcept = default;
PoissonSolver& PoissonSolver::operator=(PoissonSolver&&) noexcept = default;

int PoissonSolver::num_vertices() const { return impl_->num_vertices; }
int PoissonSolver::num_faces() const { return static_cast<int>(impl_->F.rows()); }
long PoissonSolver::factor_nonzeros() const { return impl_->factor.nonzeros(); }
bool PoissonSolver::has_position_weights() const { return impl_->position_weight.size() > 0; }
const PoissonSolver::EdgeMatrix& PoissonSolver::weighted_rest_edges() const { return impl_->weighted_edges; }

Eigen::MatrixXd PoissonSolver::Impl::edges_from_transformations(const Eigen::MatrixXd& T) const {
  if (T.rows() != F.rows() || T.cols() != 9)
    throw InvalidInput("PoissonSolver::solve: expected " + std::to_string(F.rows()) + " x 9 transformations, got " +
                       std::to_string(T.rows()) + " x " + std::to_string(T.cols()));
  EdgeMatrix E = EdgeMatrix::Zero(F.rows(), 12);
  for (Eigen::Index k = 0; k < F.rows(); ++k) {
    Eigen::Matrix3d Tk;
    Tk << T(k, 0), T(k, 1), T(k, 2), T(k, 3), T(k, 4), T(k, 5), T(k, 6), T(k, 7), T(k, 8);
    for (int c = 0; c < 3; ++c) E.row(k).segment<3>(4 * c) = (Tk * weighted_edges.row(k).segment<3>(4 * c).transpose()).transpose();
  }
  return E;
}

double* PoissonSolver::start_right_hand_side() const {
  double* Y = scratch(static_cast<size_t>(impl_->num_vertices));
  std::fill(Y, Y + 4 * static_cast<size_t>(impl_->num_vertices), 0.0);
  return Y;
}

const int* PoissonSolver::factor_corners() const { return impl_->permuted_corners.data(); }
const int* PoissonSolver::factor_rows() const { return impl_->row_of_vertex.data(); }
void PoissonSolver::solve_in_place(double* Y) const { impl_->factor.solve_in_place(Y); }

void PoissonSolver::finish(double* Y, const RowMatrixX3d& targets, Eigen::MatrixXd* X) const {
  const Impl& s = *impl_;
  if (!has_position_weights()) throw InvalidInput("PoissonSolver::solve: this solver has no position constraints");
  if (targets.rows() != s.num_vertices)
    throw InvalidInput("PoissonSolver::solve: expected " + std::to_string(s.num_vertices) + " x 3 position targets");
  for (int v = 0; v < s.num_vertices; ++v) {
    const double w = s.position_weight[v];
    double* y = Y + 4 * s.row_of_vertex[static_cast<size_t>(v)];
    for (int d = 0; d < 3; ++d) y[d] += w * targets(v, d);
  }
  s.factor.solve_in_place(Y);
  s.copy_out(Y, X);
}

void PoissonSolver::finish(double* Y, const Eigen::VectorXd& anchor_weight, const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                           Eigen::MatrixXd* X) const {
  const Impl& s = *impl_;
  if (has_position_weights()) throw InvalidInput("PoissonSolver::solve: this solver needs position targets");
  if (anchor_weight.size() != s.F.rows() || !(anchor_weight.minCoeff() >= 0) || !(anchor_weight.sum() > 0))
    throw InvalidInput("PoissonSolver::solve: expected " + std::to_string(s.F.rows()) + " non-negative anchor weights, not all zero");
  s.factor.solve_in_place(Y);
  s.copy_out(Y, X);
  Eigen::Vector3d posed = Eigen::Vector3d::Zero(), rest = Eigen::Vector3d::Zero();
  for (Eigen::Index k = 0; k < s.F.rows(); ++k) {
    if (anchor_weight[k] == 0) continue;
    posed += anchor_weight[k] * (X->row(s.F(k, 0)) + X->row(s.F(k, 1)) + X->row(s.F(k, 2))).transpose() / 3;
    rest += anchor_weight[k] * s.rest_centroids.row(k).transpose();
  }
  const double total = anchor_weight.sum();
  X->rowwise() += (R * rest / total + t - posed / total).transpose();
}

void PoissonSolver::Impl::scatter(const EdgeMatrix& E, double* Y) const {
  if (E.rows() != F.rows())
    throw InvalidInput("PoissonSolver::solve: expected " + std::to_string(F.rows()) + " x 12 transformed edges, got " +
                       std::to_string(E.rows()) + " rows");
  (simd::has_avx2() ? scatter_edges_avx2 : scatter_edges_portable)(E.rows(), permuted_corners.data(), E.data(), Y);
}

void PoissonSolver::solve_transformed_edges(const EdgeMatrix& transformed_edges, const RowMatrixX3d& targets, Eigen::MatrixXd* X) const {
  double* Y = start_right_hand_side();
  impl_->scatter(transformed_edges, Y);
  finish(Y, targets, X);
}

void PoissonSolver::solve_transformed_edges(const EdgeMatrix& transformed_edges, const Eigen::VectorXd& anchor_weight,
                                            const Eigen::Matrix3d& R, const Eigen::Vector3d& t, Eigen::MatrixXd* X) const {
  double* Y = start_right_hand_side();
  impl_->scatter(transformed_edges, Y);
  finish(Y, anchor_weight, R, t, X);
}

Eigen::MatrixXd PoissonSolver::solve(const Eigen::MatrixXd& T, const Eigen::MatrixXd& targets) const {
  const Impl& s = *impl_;
  if (!has_position_weights()) throw InvalidInput("PoissonSolver::solve: this solver has no position constraints");
  if (targets.rows() != s.num_vertices || targets.cols() != 3)
    throw InvalidInput("PoissonSolver::solve: expected " + std::to_string(s.num_vertices) + " x 3 position targets");
  Eigen::MatrixXd X;
  solve_transformed_edges(s.edges_from_transformations(T), RowMatrixX3d(targets), &X);
  return X;
}

Eigen::MatrixXd PoissonSolver::solve(const Eigen::MatrixXd& T, const Eigen::VectorXd& anchor_weight, const Eigen::Matrix3d& R,
                                     const Eigen::Vector3d& t) const {
  Eigen::MatrixXd X;
  solve_transformed_edges(impl_->edges_from_transformations(T), anchor_weight, R, t, &X);
  return X;
}

}  // namespace posekit
