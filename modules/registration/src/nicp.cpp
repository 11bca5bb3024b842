#include "posekit/registration/nicp.h"

#include <Eigen/Geometry>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cmath>
#include <string>

#include "posekit/core/closest_point.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_topology.h"
#include "posekit/core/mesh_validation.h"
#include "target_surface.h"

namespace posekit {
namespace {

using SparseMatrix = Eigen::SparseMatrix<double>;
using Triplets = std::vector<Eigen::Triplet<double>>;

}  // namespace

NicpResult nonrigid_icp(const TriangleMesh& source, const TriangleMesh& target, const NicpOptions& o,
                        const std::vector<NicpLandmark>& landmarks, const Eigen::MatrixXd* start) {
  require_usable_mesh(source, "NICP source");
  require_usable_mesh(target, "NICP target");
  if (o.stiffness.empty() || o.max_iterations_per_stiffness < 1) throw InvalidInput("NICP: empty stiffness schedule");
  for (double a : o.stiffness)
    if (!(a > 0)) throw InvalidInput("NICP: every stiffness must be positive");
  if (start && (start->rows() != source.V.rows() || start->cols() != 3))
    throw InvalidInput("NICP: the start positions must be one row of x y z per source vertex");
  for (const NicpLandmark& l : landmarks)
    if (l.source_face < 0 || l.source_face >= source.F.rows())
      throw InvalidInput("NICP: a landmark names a triangle the source does not have");
  const Eigen::Index n = source.V.rows();
  Eigen::MatrixXd P = start ? *start : source.V;

  // Landmarks' source points, and the similarity that takes them onto their targets.
  const auto landmark_points = [&](const Eigen::MatrixXd& X) {
    Eigen::MatrixXd L(static_cast<Eigen::Index>(landmarks.size()), 3);
    for (size_t k = 0; k < landmarks.size(); ++k) {
      const NicpLandmark& l = landmarks[k];
      L.row(static_cast<Eigen::Index>(k)) = l.source_bary[0] * X.row(source.F(l.source_face, 0)) +
                                            l.source_bary[1] * X.row(source.F(l.source_face, 1)) +
                                            l.source_bary[2] * X.row(source.F(l.source_face, 2));
    }
    return L;
  };
  Eigen::MatrixXd landmark_targets(static_cast<Eigen::Index>(landmarks.size()), 3);
  for (size_t k = 0; k < landmarks.size(); ++k) landmark_targets.row(static_cast<Eigen::Index>(k)) = landmarks[k].target.transpose();
  if (o.align_landmarks_first && landmarks.size() >= 3) {
    const Eigen::Matrix4d T = similarity(landmark_points(P), landmark_targets);
    P = (P * T.topLeftCorner<3, 3>().transpose()).rowwise() + T.topRightCorner<3, 1>().transpose();
  }

  // The normalised frame: the source centred, unit RMS radius, the target with it.
  const Eigen::RowVector3d centre = P.colwise().mean();
  const double scale = std::sqrt((P.rowwise() - centre).rowwise().squaredNorm().mean());
  if (!(scale > 0)) throw InvalidInput("NICP: the source has no extent");
  const auto to_frame = [&](const Eigen::MatrixXd& X) -> Eigen::MatrixXd { return (X.rowwise() - centre) / scale; };
  const Eigen::MatrixXd D = to_frame(P);  // rows [x y z] of D; the 1 is implicit
  const Eigen::MatrixXd TV = to_frame(target.V);
  if (!landmarks.empty()) landmark_targets = to_frame(landmark_targets);
  const TriangleTree tree(TV, target.F);
  const Eigen::MatrixXd target_normals = vertex_normals(TV, target.F);
  const TargetBoundary boundary = find_boundary(target);

  // The stiffness matrix (M (x) G)^T (M (x) G) on the pattern every system shares: a full 4 x 4 block
  // per vertex and per edge (landmarks couple a triangle's corners), explicit zeros where empty.
  const Eigen::MatrixXi E = unique_edges(source.F);
  Triplets st;
  st.reserve(static_cast<size_t>(16 * (n + 2 * E.rows())));
  const double g2[4] = {1, 1, 1, o.gamma * o.gamma};
  for (Eigen::Index i = 0; i < n; ++i)
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) st.emplace_back(4 * i + r, 4 * i + c, 0.0);
  for (Eigen::Index e = 0; e < E.rows(); ++e) {
    const int a = E(e, 0), b = E(e, 1);
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) {
        const double v = r == c ? g2[r] : 0.0;
        st.emplace_back(4 * a + r, 4 * a + c, v);
        st.emplace_back(4 * b + r, 4 * b + c, v);
        st.emplace_back(4 * a + r, 4 * b + c, -v);
        st.emplace_back(4 * b + r, 4 * a + c, -v);
      }
  }
  SparseMatrix stiffness(4 * n, 4 * n);
  stiffness.setFromTriplets(st.begin(), st.end());
  st = Triplets();
  Eigen::SimplicialLLT<SparseMatrix> solver;
  solver.analyzePattern(stiffness);

  // Landmarks: each row of D_L mixes its triangle's three corners. Together they weigh
  // landmark_weight^2 times all data pairs at the first stiffness.
  const double landmark_scale = landmarks.empty() ? 0.0 : static_cast<double>(n) / static_cast<double>(landmarks.size());
  const double cos_limit = std::cos(o.max_normal_angle_deg * M_PI / 180);
  const double max_distance = o.max_distance / scale, convergence = o.convergence / scale;
  const auto homogeneous = [&](Eigen::Index i) { return Eigen::Vector4d(D(i, 0), D(i, 1), D(i, 2), 1.0); };

  NicpResult result;
  result.landmarks = static_cast<int>(landmarks.size());
  Eigen::MatrixXd V = D;
  Triplets data;
  for (double alpha : o.stiffness) {
    const double beta2 = landmark_scale * std::pow(o.landmark_weight * alpha / o.stiffness.front(), 2);
    int iterations = 0;
    for (int it = 0; it < o.max_iterations_per_stiffness; ++it) {
      ++iterations;
      const ClosestPoints cp = tree.closest(V, 1);
      const Eigen::MatrixXd source_normals = vertex_normals(V, source.F);
      data.clear();
      Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(4 * n, 3);
      double distance_sum = 0;
      int accepted = 0;
      for (Eigen::Index i = 0; i < n; ++i) {
        const int f = cp.face[i];
        const Eigen::Vector3d b = cp.bary.row(i).transpose();
        Eigen::Vector3d normal = (b[0] * target_normals.row(target.F(f, 0)) + b[1] * target_normals.row(target.F(f, 1)) +
                                  b[2] * target_normals.row(target.F(f, 2)))
                                     .transpose();
        if (normal.norm() > 0) normal.normalize();
        const bool ok = cp.distance[i] < max_distance && source_normals.row(i).dot(normal) > cos_limit &&
                        !(o.reject_boundary && boundary.contains(target.F, f, b));
        if (!ok) continue;
        const Eigen::Vector3d x = V.row(i).transpose(), p = cp.point.row(i).transpose();
        const Eigen::Vector3d on_plane = x - normal * normal.dot(x - p);
        const Eigen::Vector3d u = (1 - o.point_to_point) * on_plane + o.point_to_point * p;
        const Eigen::Vector4d h = homogeneous(i);
        for (int r = 0; r < 4; ++r)
          for (int c = 0; c < 4; ++c) data.emplace_back(4 * i + r, 4 * i + c, h[r] * h[c]);
        rhs.block(4 * i, 0, 4, 3) += h * u.transpose();
        distance_sum += cp.distance[i];
        ++accepted;
      }
      if (beta2 > 0)
        for (size_t k = 0; k < landmarks.size(); ++k) {
          const NicpLandmark& l = landmarks[k];
          for (int c = 0; c < 3; ++c) {
            const int vc = source.F(l.source_face, c);
            const Eigen::Vector4d hc = homogeneous(vc) * l.source_bary[c];
            rhs.block(4 * vc, 0, 4, 3) += beta2 * hc * landmark_targets.row(static_cast<Eigen::Index>(k));
            for (int d = 0; d < 3; ++d) {
              const int vd = source.F(l.source_face, d);
              const Eigen::Vector4d hd = homogeneous(vd) * l.source_bary[d];
              for (int r = 0; r < 4; ++r)
                for (int s = 0; s < 4; ++s) data.emplace_back(4 * vc + r, 4 * vd + s, beta2 * hc[r] * hd[s]);
            }
          }
        }
      for (Eigen::Index k = 0; k < 4 * n; ++k) data.emplace_back(k, k, 1e-9);  // vertices with no pair and no edge
      SparseMatrix A(4 * n, 4 * n);
      A.setFromTriplets(data.begin(), data.end());
      A += (alpha * alpha) * stiffness;
      solver.factorize(A);
      if (solver.info() != Eigen::Success)
        throw InvalidInput("NICP: the normal equations could not be factorised at stiffness " + std::to_string(alpha));
      const Eigen::MatrixXd X = solver.solve(rhs);
      ++result.solves;
      Eigen::MatrixXd next(n, 3);
      for (Eigen::Index i = 0; i < n; ++i) next.row(i) = homogeneous(i).transpose() * X.block(4 * i, 0, 4, 3);
      const double change = std::sqrt((next - V).rowwise().squaredNorm().mean());
      V = std::move(next);
      result.final_mean_distance = accepted ? scale * distance_sum / accepted : 0.0;
      result.accepted_fraction = static_cast<double>(accepted) / static_cast<double>(n);
      if (change < convergence) break;
    }
    result.stiffness.push_back(alpha);
    result.iterations.push_back(iterations);
  }
  result.V = (V * scale).rowwise() + centre;
  return result;
}

}  // namespace posekit
