#include "posekit/deformation/poisson_solver.h"

#include <Eigen/SparseCholesky>
#include <string>
#include <vector>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_topology.h"

namespace posekit {

struct PoissonSolver::Impl {
  Eigen::MatrixXi F;
  int num_vertices = 0;
  Eigen::MatrixXd rest_edges;   // 3F x 3: edge c of face k at row 3k + c, v[(c+1)%3] - v[c]
  Eigen::VectorXd weight;       // #F, the face's area
  Eigen::MatrixXd rest_centroids;
  Eigen::VectorXd position_weight;  // empty: translation fixed by a pin and the anchor
  Eigen::MatrixXd rhs_from(const Eigen::MatrixXd& T) const;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
};

PoissonSolver::PoissonSolver(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXd& position_weight)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  if (V.rows() < 3 || F.rows() < 1 || V.cols() != 3 || F.cols() != 3)
    throw InvalidInput("PoissonSolver: the mesh needs vertices (#V x 3) and triangles (#F x 3)");
  if (F.minCoeff() < 0 || F.maxCoeff() >= V.rows())
    throw InvalidInput("PoissonSolver: a triangle index is outside the " + std::to_string(V.rows()) + " vertices");
  Eigen::VectorXi components;
  const int count = connected_components(F, static_cast<int>(V.rows()), &components);
  if (count != 1)
    throw InvalidInput("PoissonSolver: the mesh has " + std::to_string(count) +
                       " connected components; posing needs one connected body");
  s.F = F;
  s.num_vertices = static_cast<int>(V.rows());
  const Eigen::VectorXd area = face_areas(V, F);
  const double mean_area = area.mean();
  if (!(mean_area > 0)) throw InvalidInput("PoissonSolver: all triangles are degenerate");
  s.weight = (area.array() + 1e-6 * mean_area).matrix();
  s.rest_centroids = face_centroids(V, F);
  s.rest_edges.resize(3 * F.rows(), 3);
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(static_cast<size_t>(12 * F.rows() + 1));
  std::vector<char> used(static_cast<size_t>(V.rows()), 0);
  for (Eigen::Index k = 0; k < F.rows(); ++k) {
    for (int c = 0; c < 3; ++c) {
      const int i = F(k, c), j = F(k, (c + 1) % 3);
      used[static_cast<size_t>(i)] = 1;
      s.rest_edges.row(3 * k + c) = V.row(j) - V.row(i);
      const double w = s.weight[k];
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
  s.ldlt.compute(L);
  if (s.ldlt.info() != Eigen::Success) throw InvalidInput("PoissonSolver: the mesh's system could not be factorised");
}

PoissonSolver::~PoissonSolver() = default;
PoissonSolver::PoissonSolver(PoissonSolver&&) noexcept = default;
PoissonSolver& PoissonSolver::operator=(PoissonSolver&&) noexcept = default;

int PoissonSolver::num_vertices() const { return impl_->num_vertices; }
int PoissonSolver::num_faces() const { return static_cast<int>(impl_->F.rows()); }

bool PoissonSolver::has_position_weights() const { return impl_->position_weight.size() > 0; }

Eigen::MatrixXd PoissonSolver::Impl::rhs_from(const Eigen::MatrixXd& T) const {
  if (T.rows() != F.rows() || T.cols() != 9)
    throw InvalidInput("PoissonSolver::solve: expected " + std::to_string(F.rows()) + " x 9 transformations, got " +
                       std::to_string(T.rows()) + " x " + std::to_string(T.cols()));
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(num_vertices, 3);
  for (Eigen::Index k = 0; k < F.rows(); ++k) {
    Eigen::Matrix3d Tk;
    Tk << T(k, 0), T(k, 1), T(k, 2), T(k, 3), T(k, 4), T(k, 5), T(k, 6), T(k, 7), T(k, 8);
    for (int c = 0; c < 3; ++c) {
      const int i = F(k, c), j = F(k, (c + 1) % 3);
      const Eigen::RowVector3d d = weight[k] * (Tk * rest_edges.row(3 * k + c).transpose()).transpose();
      rhs.row(j) += d;
      rhs.row(i) -= d;
    }
  }
  return rhs;
}

Eigen::MatrixXd PoissonSolver::solve(const Eigen::MatrixXd& T, const Eigen::MatrixXd& targets) const {
  const Impl& s = *impl_;
  if (!has_position_weights()) throw InvalidInput("PoissonSolver::solve: this solver has no position constraints");
  if (targets.rows() != s.num_vertices || targets.cols() != 3)
    throw InvalidInput("PoissonSolver::solve: expected " + std::to_string(s.num_vertices) + " x 3 position targets");
  Eigen::MatrixXd rhs = s.rhs_from(T);
  rhs += (targets.array().colwise() * s.position_weight.array()).matrix();
  return s.ldlt.solve(rhs);
}

Eigen::MatrixXd PoissonSolver::solve(const Eigen::MatrixXd& T, const Eigen::VectorXd& anchor_weight,
                                     const Eigen::Matrix3d& R, const Eigen::Vector3d& t) const {
  const Impl& s = *impl_;
  if (has_position_weights()) throw InvalidInput("PoissonSolver::solve: this solver needs position targets");
  const Eigen::MatrixXd rhs = s.rhs_from(T);
  Eigen::MatrixXd X = s.ldlt.solve(rhs);
  if (anchor_weight.size() != s.F.rows() || !(anchor_weight.minCoeff() >= 0) || !(anchor_weight.sum() > 0))
    throw InvalidInput("PoissonSolver::solve: expected " + std::to_string(s.F.rows()) +
                       " non-negative anchor weights, not all zero");
  Eigen::Vector3d posed = Eigen::Vector3d::Zero(), rest = Eigen::Vector3d::Zero();
  for (Eigen::Index k = 0; k < s.F.rows(); ++k) {
    if (anchor_weight[k] == 0) continue;
    posed += anchor_weight[k] * (X.row(s.F(k, 0)) + X.row(s.F(k, 1)) + X.row(s.F(k, 2))).transpose() / 3;
    rest += anchor_weight[k] * s.rest_centroids.row(k).transpose();
  }
  const double total = anchor_weight.sum();
  X.rowwise() += (R * rest / total + t - posed / total).transpose();
  return X;
}

}  // namespace posekit
