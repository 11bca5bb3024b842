#include "posekit/registration/nicp.h"

#include <flann/flann.hpp>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cmath>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_topology.h"
#include "posekit/core/mesh_validation.h"

namespace posekit {

NicpResult nonrigid_icp(const TriangleMesh& source, const TriangleMesh& target, const NicpOptions& o) {
  require_usable_mesh(source, "NICP source");
  require_usable_mesh(target, "NICP target");
  if (o.stiffness.empty() || o.iterations_per_stiffness < 1) throw InvalidInput("NICP: empty stiffness schedule");
  const Eigen::Index n = source.V.rows();
  const Eigen::MatrixXi E = unique_edges(source.F);
  const Eigen::MatrixXd target_normals = vertex_normals(target.V, target.F);
  // KD-tree over the target vertices (built once).
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> tv = target.V;
  flann::Index<flann::L2_Simple<double>> index(flann::Matrix<double>(tv.data(), static_cast<size_t>(tv.rows()), 3),
                                                flann::KDTreeSingleIndexParams(16));
  index.buildIndex();
  // Stiffness block: (M (x) G)^T (M (x) G), constant; the data block D^T W^2 D is block diagonal.
  std::vector<Eigen::Triplet<double>> st;
  const double g[4] = {1, 1, 1, o.gamma * o.gamma};
  for (Eigen::Index e = 0; e < E.rows(); ++e) {
    const int a = E(e, 0), b = E(e, 1);
    for (int k = 0; k < 4; ++k) {
      st.emplace_back(4 * a + k, 4 * a + k, g[k]);
      st.emplace_back(4 * b + k, 4 * b + k, g[k]);
      st.emplace_back(4 * a + k, 4 * b + k, -g[k]);
      st.emplace_back(4 * b + k, 4 * a + k, -g[k]);
    }
  }
  Eigen::SparseMatrix<double> stiff(4 * n, 4 * n);
  stiff.setFromTriplets(st.begin(), st.end());
  // The pattern of the normal matrix never changes: analyse it once.
  std::vector<Eigen::Triplet<double>> dt;
  for (Eigen::Index i = 0; i < n; ++i)
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) dt.emplace_back(4 * i + r, 4 * i + c, 1.0);
  Eigen::SparseMatrix<double> pattern(4 * n, 4 * n);
  pattern.setFromTriplets(dt.begin(), dt.end());
  pattern = stiff + pattern;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver;
  solver.analyzePattern(pattern);

  Eigen::MatrixXd X(4 * n, 3);  // identity affine maps
  X.setZero();
  for (Eigen::Index i = 0; i < n; ++i) X.block(4 * i, 0, 3, 3).setIdentity();
  NicpResult result;
  Eigen::MatrixXd V = source.V;
  const double cos_limit = std::cos(o.max_normal_angle_deg * M_PI / 180);
  for (double alpha : o.stiffness)
    for (int it = 0; it < o.iterations_per_stiffness; ++it) {
      // Correspondences: nearest target vertex of each deformed source vertex, with rejection.
      Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> q = V;
      std::vector<size_t> idx(static_cast<size_t>(n));
      std::vector<double> d2(static_cast<size_t>(n));
      flann::Matrix<size_t> im(idx.data(), static_cast<size_t>(n), 1);
      flann::Matrix<double> dm(d2.data(), static_cast<size_t>(n), 1);
      flann::SearchParams sp(flann::FLANN_CHECKS_UNLIMITED, 0, false);
      sp.cores = 1;
      index.knnSearch(flann::Matrix<double>(q.data(), static_cast<size_t>(n), 3), im, dm, 1, sp);
      const Eigen::MatrixXd VN = vertex_normals(V, source.F);
      std::vector<Eigen::Triplet<double>> data = st;  // rebuilt with this iteration's weights
      for (auto& t : data) t = Eigen::Triplet<double>(t.row(), t.col(), t.value() * alpha * alpha);
      Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(4 * n, 3);
      double sum = 0;
      int accepted = 0;
      for (Eigen::Index i = 0; i < n; ++i) {
        const Eigen::Index j = static_cast<Eigen::Index>(idx[i]);
        const bool ok = std::sqrt(d2[i]) < o.max_distance && VN.row(i).dot(target_normals.row(j)) > cos_limit;
        const double w = ok ? 1.0 : 0.0;
        const Eigen::Vector4d x(source.V(i, 0), source.V(i, 1), source.V(i, 2), 1.0);
        for (int r = 0; r < 4; ++r)
          for (int c = 0; c < 4; ++c) data.emplace_back(4 * i + r, 4 * i + c, w * x[r] * x[c] + (r == c ? 1e-9 : 0.0));
        if (ok) {
          rhs.block(4 * i, 0, 4, 3) += x * target.V.row(j);
          sum += std::sqrt(d2[i]);
          ++accepted;
        }
      }
      Eigen::SparseMatrix<double> A(4 * n, 4 * n);
      A.setFromTriplets(data.begin(), data.end());
      solver.factorize(A);
      if (solver.info() != Eigen::Success) throw InvalidInput("NICP: the normal equations could not be factorised");
      X = solver.solve(rhs);
      ++result.solves;
      for (Eigen::Index i = 0; i < n; ++i) {
        const Eigen::RowVector4d x(source.V(i, 0), source.V(i, 1), source.V(i, 2), 1.0);
        V.row(i) = x * X.block(4 * i, 0, 4, 3);
      }
      result.final_mean_distance = accepted ? sum / accepted : 0.0;
    }
  result.V = V;
  return result;
}

}  // namespace posekit
