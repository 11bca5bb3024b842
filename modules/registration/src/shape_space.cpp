#include "posekit/registration/shape_space.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "posekit/core/closest_point.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "target_surface.h"

namespace posekit {
namespace {

/// Rows x0 y0 z0 x1 ... of a #V x 3 matrix.
Eigen::VectorXd flatten(const Eigen::MatrixXd& V) {
  const Eigen::MatrixXd t = V.transpose();
  return Eigen::Map<const Eigen::VectorXd>(t.data(), t.size());
}

Eigen::MatrixXd unflatten(const Eigen::VectorXd& x) {
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(x.data(), x.size() / 3, 3);
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

double far_share(const std::vector<double>& d, double limit) {
  if (d.empty()) return 0;
  return static_cast<double>(std::count_if(d.begin(), d.end(), [&](double x) { return x > limit; })) / static_cast<double>(d.size());
}

/// mean + basis * c read as rows of 3 (c may be shorter than the basis: the rest are 0).
Eigen::MatrixXd add_components(const Eigen::MatrixXd& mean, const Eigen::MatrixXd& basis, const Eigen::VectorXd& c) {
  if (c.size() > basis.cols())
    throw InvalidInput("shape space: " + std::to_string(c.size()) + " coefficients for " + std::to_string(basis.cols()) + " components");
  const Eigen::VectorXd flat = basis.leftCols(c.size()) * c;
  Eigen::MatrixXd out = mean;
  for (Eigen::Index i = 0; i < out.rows(); ++i) out.row(i) += flat.segment<3>(3 * i).transpose();
  return out;
}

}  // namespace

Eigen::MatrixXd ShapeSpace::body(const Eigen::VectorXd& c) const { return add_components(mean, basis, c); }

Eigen::MatrixXd ShapeSpace::joints(const Eigen::VectorXd& c) const {
  if (!has_joints()) throw InvalidInput("shape space: it does not know the joints (" + population + ")");
  return add_components(joint_mean, joint_basis, c);
}

ShapeSpace learn_shape_space(const std::vector<Eigen::MatrixXd>& bodies, double variance_kept, int max_components, std::string population) {
  if (bodies.size() < 2) throw InvalidInput("shape space: at least 2 bodies are needed, got " + std::to_string(bodies.size()));
  if (!(variance_kept > 0 && variance_kept <= 1) || max_components < 1)
    throw InvalidInput("shape space: variance_kept must be in (0, 1] and max_components at least 1");
  const Eigen::Index nv = bodies.front().rows();
  for (size_t b = 0; b < bodies.size(); ++b)
    if (bodies[b].rows() != nv || bodies[b].cols() != 3 || !bodies[b].allFinite())
      throw InvalidInput("shape space: body " + std::to_string(b) + " has " + std::to_string(bodies[b].rows()) + " x " +
                         std::to_string(bodies[b].cols()) + " finite coordinates, the first " + std::to_string(nv) + " x 3");
  const Eigen::Index n = static_cast<Eigen::Index>(bodies.size());
  ShapeSpace s;
  s.bodies = static_cast<int>(n);
  s.population = std::move(population);
  s.mean = Eigen::MatrixXd::Zero(nv, 3);
  for (const Eigen::MatrixXd& b : bodies) s.mean += b / static_cast<double>(n);
  Eigen::MatrixXd X(3 * nv, n);  // centred bodies as columns
  for (Eigen::Index b = 0; b < n; ++b) X.col(b) = flatten(bodies[static_cast<size_t>(b)] - s.mean);
  // Components from the n x n Gram matrix (n is far below 3#V).
  const Eigen::MatrixXd gram = X.transpose() * X;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(gram);
  const double total = std::max(gram.trace(), 1e-300);
  double kept = 0;
  std::vector<Eigen::VectorXd> columns;
  for (Eigen::Index k = n - 1; k >= 0 && static_cast<int>(columns.size()) < max_components && kept < variance_kept; --k) {
    const double lambda = eig.eigenvalues()[k];
    if (!(lambda > 1e-12 * total)) break;
    // u sigma = X v / sqrt(lambda) * sqrt(lambda / (n - 1)); the sign makes the largest entry positive.
    Eigen::VectorXd col = X * eig.eigenvectors().col(k) / std::sqrt(static_cast<double>(n - 1));
    Eigen::Index at = 0;
    col.cwiseAbs().maxCoeff(&at);
    if (col[at] < 0) col = -col;
    columns.push_back(std::move(col));
    s.variance_share.push_back(lambda / total);
    kept += lambda / total;
  }
  s.basis.resize(3 * nv, static_cast<Eigen::Index>(columns.size()));
  for (size_t k = 0; k < columns.size(); ++k) s.basis.col(static_cast<Eigen::Index>(k)) = columns[k];
  return s;
}

void align_bodies_rigidly(std::vector<Eigen::MatrixXd>& bodies, int rounds) {
  if (bodies.empty()) return;
  const Eigen::Index nv = bodies.front().rows();
  for (size_t b = 0; b < bodies.size(); ++b)
    if (bodies[b].rows() != nv || bodies[b].cols() != 3)
      throw InvalidInput("rigid alignment: body " + std::to_string(b) + " has " + std::to_string(bodies[b].rows()) +
                         " vertices, the first " + std::to_string(nv));
  Eigen::MatrixXd reference = bodies.front();
  for (int round = 0; round < rounds; ++round) {
    Eigen::MatrixXd mean = Eigen::MatrixXd::Zero(nv, 3);
    for (Eigen::MatrixXd& b : bodies) {
      const Eigen::Matrix4d T = similarity(b, reference, false);
      b = (b * T.topLeftCorner<3, 3>().transpose()).rowwise() + T.topRightCorner<3, 1>().transpose();
      mean += b / static_cast<double>(bodies.size());
    }
    reference = mean;
  }
}

struct ShapeFitTarget::Impl {
  const TriangleMesh& mesh;
  TriangleTree tree;
  Eigen::MatrixXd normals;
  TargetBoundary boundary;
  explicit Impl(const TriangleMesh& m) : mesh(m), tree(m.V, m.F), normals(vertex_normals(m.V, m.F)), boundary(find_boundary(m)) {}
};

ShapeFitTarget::ShapeFitTarget(const TriangleMesh& target) : impl_(std::make_unique<Impl>(target)) {}
ShapeFitTarget::~ShapeFitTarget() = default;
ShapeFitTarget::ShapeFitTarget(ShapeFitTarget&&) noexcept = default;
ShapeFitTarget& ShapeFitTarget::operator=(ShapeFitTarget&&) noexcept = default;
const TriangleMesh& ShapeFitTarget::mesh() const { return impl_->mesh; }

ShapeFitResult fit_shape_space(const ShapeSpace& space, const Eigen::MatrixXi& F, const Eigen::MatrixXd& start, const TriangleMesh& target,
                               const ShapeFitOptions& o) {
  return fit_shape_space(space, F, start, ShapeFitTarget(target), o);
}

ShapeFitResult fit_shape_space(const ShapeSpace& space, const Eigen::MatrixXi& F, const Eigen::MatrixXd& start,
                               const ShapeFitTarget& prepared, const ShapeFitOptions& o) {
  const TriangleMesh& target = prepared.mesh();
  const Eigen::Index nv = space.mean.rows(), K = space.basis.cols();
  if (start.rows() != nv || start.cols() != 3)
    throw InvalidInput("shape-space fit: the space has " + std::to_string(nv) + " vertices, the start " + std::to_string(start.rows()));
  if (F.size() > 0 && F.maxCoeff() >= nv) throw InvalidInput("shape-space fit: a triangle names a vertex the space does not have");
  if (o.iterations < 0 || o.vertex_stride < 1 || !(o.max_distance > 0) || !(o.prior_distance > 0))
    throw InvalidInput("shape-space fit: iterations >= 0, vertex_stride >= 1, max_distance > 0 and prior_distance > 0 expected");
  ShapeFitResult r;
  const double prior = o.prior_distance * o.prior_distance;
  // The columns' Gram matrix: diagonal for principal components alone, not with components added to
  // them (the body model's limb segments).
  Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(K, K);
  gram.selfadjointView<Eigen::Lower>().rankUpdate(space.basis.transpose());
  const auto body = [&](const Eigen::VectorXd& c) -> Eigen::MatrixXd { return space.mean + unflatten(space.basis * c); };
  const auto placed = [&](const Eigen::MatrixXd& X) -> Eigen::MatrixXd {
    return (X * r.rotation.transpose()).rowwise() + r.translation.transpose();
  };

  // The space's projection of the start: rigid motion and coefficients in turn.
  r.coefficients = Eigen::VectorXd::Zero(K);
  for (int round = 0; round < 3; ++round) {
    const Eigen::Matrix4d T = similarity(body(r.coefficients), start, false);
    r.rotation = T.topLeftCorner<3, 3>();
    r.translation = T.topRightCorner<3, 1>();
    const Eigen::MatrixXd local = ((start.rowwise() - r.translation.transpose()) * r.rotation) - space.mean;
    // Each vertex weighs as a pair; the prior as in the surface fit, scaled to the whole body.
    const double w = prior * static_cast<double>(nv) / static_cast<double>((nv + o.vertex_stride - 1) / o.vertex_stride);
    Eigen::MatrixXd regularised = gram;
    regularised.diagonal().array() += w;
    r.coefficients = regularised.selfadjointView<Eigen::Lower>().ldlt().solve(space.basis.transpose() * flatten(local));
  }

  std::vector<Eigen::Index> sample;
  for (Eigen::Index i = 0; i < nv; i += o.vertex_stride) sample.push_back(i);
  const Eigen::Index m = static_cast<Eigen::Index>(sample.size());
  const TriangleTree& tree = prepared.impl().tree;
  const Eigen::MatrixXd& target_normals = prepared.impl().normals;
  const TargetBoundary& boundary = prepared.impl().boundary;
  const double cos_limit = std::cos(o.max_normal_angle_deg * M_PI / 180);
  const auto rows_of = [&](const Eigen::MatrixXd& X) {
    Eigen::MatrixXd S(m, 3);
    for (Eigen::Index k = 0; k < m; ++k) S.row(k) = X.row(sample[static_cast<size_t>(k)]);
    return S;
  };
  const auto distances = [&](const ClosestPoints& cp) {
    return std::vector<double>(cp.distance.data(), cp.distance.data() + cp.distance.size());
  };
  // The target's normal at a closest point, or zero when the pair is rejected.
  const auto pair_normal = [&](const ClosestPoints& cp, Eigen::Index k, const Eigen::RowVector3d& source_normal) -> Eigen::Vector3d {
    const int f = cp.face[k];
    const Eigen::Vector3d b = cp.bary.row(k).transpose();
    Eigen::Vector3d normal =
        (b[0] * target_normals.row(target.F(f, 0)) + b[1] * target_normals.row(target.F(f, 1)) + b[2] * target_normals.row(target.F(f, 2)))
            .transpose();
    if (!(normal.norm() > 0)) return Eigen::Vector3d::Zero();
    normal.normalize();
    if (cp.distance[k] > o.max_distance || source_normal.dot(normal) < cos_limit || boundary.contains(target.F, f, b))
      return Eigen::Vector3d::Zero();
    return normal;
  };

  // The sampled rows of the space, and the source's normals for the facing test (from the start,
  // which the fit hardly turns).
  Eigen::MatrixXd sample_basis(3 * m, K);
  for (Eigen::Index k = 0; k < m; ++k) sample_basis.middleRows(3 * k, 3) = space.basis.middleRows(3 * sample[static_cast<size_t>(k)], 3);
  const Eigen::MatrixXd sample_mean = rows_of(space.mean);
  const Eigen::MatrixXd normals = rows_of(vertex_normals(start, F));
  // Gauss-Newton on point-to-plane pairs; unknowns: coefficients, translation, rotation about the
  // sample's centroid.
  Eigen::MatrixXd J(m, K + 6);
  Eigen::VectorXd residual(m);
  Eigen::VectorXi last_faces;  // each sample's closest face in the last iteration: where to search from
  for (int it = 0; it < o.iterations; ++it) {
    const Eigen::MatrixXd XS = placed(sample_mean + unflatten(sample_basis * r.coefficients));
    const ClosestPoints cp = tree.closest(XS, o.threads, it > 0 ? &last_faces : nullptr);
    last_faces = cp.face;
    const Eigen::RowVector3d centroid = XS.colwise().mean();
    Eigen::Index used = 0;
    for (Eigen::Index k = 0; k < m; ++k) {
      const Eigen::Vector3d n = pair_normal(cp, k, normals.row(k));
      if (n.isZero()) continue;
      const Eigen::Vector3d x = XS.row(k).transpose();
      const Eigen::RowVector3d a = (r.rotation.transpose() * n).transpose();
      J.row(used).head(K) = a * sample_basis.middleRows(3 * k, 3);
      J.row(used).segment<3>(K) = n.transpose();
      J.row(used).tail<3>() = (x - centroid.transpose()).cross(n).transpose();
      residual[used] = n.dot(x - cp.point.row(k).transpose());
      ++used;
    }
    r.iterations = it + 1;
    r.accepted_fraction = static_cast<double>(used) / static_cast<double>(m);
    if (used < K + 6) break;  // too few pairs to say anything
    const auto Ju = J.topRows(used);
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(K + 6, K + 6);
    H.selfadjointView<Eigen::Lower>().rankUpdate(Ju.transpose());  // J^T J's lower half: all the LDLT reads
    Eigen::VectorXd g = Ju.transpose() * residual.head(used);
    H.diagonal().head(K).array() += prior;
    g.head(K) += prior * r.coefficients;
    const Eigen::VectorXd step = -H.ldlt().solve(g);
    if (!step.allFinite()) break;
    r.coefficients += step.head(K);
    const Eigen::Vector3d omega = step.tail<3>();
    const Eigen::Matrix3d turn =
        omega.norm() > 0 ? Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
    r.rotation = turn * r.rotation;
    r.translation = turn * (r.translation - centroid.transpose()) + centroid.transpose() + step.segment<3>(K);
    if (step.head(K).norm() < o.convergence && step.tail<6>().norm() < 1e-4) break;
  }

  r.V = placed(body(r.coefficients));
  const std::vector<double> fit_distances =
      distances(tree.closest(rows_of(r.V), o.threads, last_faces.size() == m ? &last_faces : nullptr));
  r.median_distance = median(fit_distances);
  // The other way: target points the body leaves uncovered. A limb held otherwise is seen only from
  // here (the space's straight forearm lies near the hip's surface, the target's bent one is bare).
  const Eigen::Index target_stride = std::max<Eigen::Index>(1, target.V.rows() / 2000);
  Eigen::MatrixXd target_sample((target.V.rows() + target_stride - 1) / target_stride, 3);
  for (Eigen::Index k = 0; k < target_sample.rows(); ++k) target_sample.row(k) = target.V.row(k * target_stride);
  const auto uncovered = [&](const Eigen::MatrixXd& X) {
    return far_share(distances(TriangleTree(X, F).closest(target_sample, o.threads)), o.far_distance);
  };
  r.far_share = far_share(fit_distances, o.far_distance);
  r.uncovered_share = uncovered(r.V);
  // The start's shares only when the fit's own exceed what is allowed beyond them.
  if (r.far_share > o.max_extra_far_share)
    r.start_far_share = far_share(distances(tree.closest(rows_of(start), o.threads)), o.far_distance);
  if (r.uncovered_share > o.max_extra_far_share) r.start_uncovered_share = uncovered(start);
  r.plausible = r.median_distance <= o.max_median_distance && r.far_share <= std::max(r.start_far_share, 0.0) + o.max_extra_far_share &&
                r.uncovered_share <= std::max(r.start_uncovered_share, 0.0) + o.max_extra_far_share;
  return r;
}

}  // namespace posekit
