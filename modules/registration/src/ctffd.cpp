#include "posekit/registration/ctffd.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <vector>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/registration/correspondence.h"

namespace posekit {
namespace {

/// The band frame of a representation triangle at barycentric b: axis point (interpolated layer
/// centres), band normal, and the representation surface point.
struct BandFrame {
  Eigen::Vector3d axis, normal, surface;
};

BandFrame band_frame(const LayeredRepresentation& rep, int tri, const Eigen::Vector3d& b) {
  const int n = rep.points_per_layer;
  BandFrame f;
  f.surface = Eigen::Vector3d::Zero();
  f.axis = Eigen::Vector3d::Zero();
  f.normal = Eigen::Vector3d::Zero();
  for (int c = 0; c < 3; ++c) {
    const int v = rep.mesh.F(tri, c);
    const RepresentationLayer& L = rep.layers[static_cast<size_t>(v / n)];
    f.surface += b[c] * rep.mesh.V.row(v).transpose();
    f.axis += b[c] * L.centre;
    f.normal += b[c] * L.normal;
  }
  f.normal.normalize();
  return f;
}

}  // namespace

CtffdParametrization ctffd_parametrize(const Eigen::MatrixXd& V, const LayeredRepresentation& rep) {
  // Each vertex goes to the representation triangle whose centroid is nearest among those facing
  // the same way (the same test as Eq. 2b/2c), with normals from the vertex's radial direction.
  const CentroidIndex index(rep.mesh.V, rep.mesh.F);
  // Radial directions need an axis: use the nearest triangle's band axis, found unconditionally first.
  const Eigen::VectorXi nearest = index.match(V, Eigen::MatrixXd::Zero(V.rows(), 3), 1);
  Eigen::MatrixXd radial(V.rows(), 3);
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    const BandFrame f = band_frame(rep, nearest[i], Eigen::Vector3d::Constant(1.0 / 3));
    Eigen::Vector3d d = V.row(i).transpose() - f.axis;
    d -= d.dot(f.normal) * f.normal;
    radial.row(i) = d.norm() > 1e-12 ? Eigen::RowVector3d(d.normalized().transpose()) : Eigen::RowVector3d(1, 0, 0);
  }
  // Where that nearest triangle already faces the radial direction it is the answer; only the rest
  // search further.
  const Eigen::MatrixXd rep_normals = face_normals(rep.mesh.V, rep.mesh.F);
  Eigen::VectorXi tri = nearest;
  std::vector<Eigen::Index> disagree;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (!(rep_normals.row(nearest[i]).dot(radial.row(i)) > 0)) disagree.push_back(i);
  if (!disagree.empty()) {
    Eigen::MatrixXd C(static_cast<Eigen::Index>(disagree.size()), 3), N(static_cast<Eigen::Index>(disagree.size()), 3);
    for (size_t k = 0; k < disagree.size(); ++k) {
      C.row(static_cast<Eigen::Index>(k)) = V.row(disagree[k]);
      N.row(static_cast<Eigen::Index>(k)) = radial.row(disagree[k]);
    }
    const Eigen::VectorXi further = index.match(C, N, 16);
    for (size_t k = 0; k < disagree.size(); ++k) tri[disagree[k]] = further[static_cast<Eigen::Index>(k)];
  }
  CtffdParametrization p;
  p.triangle = tri;
  p.bary.resize(V.rows(), 3);
  p.offset.resize(V.rows(), 3);
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    const int t = tri[i];
    const Eigen::Vector3d v = V.row(i).transpose();
    const Eigen::Vector3d b =
        clamped_barycentric(v, rep.mesh.V.row(rep.mesh.F(t, 0)), rep.mesh.V.row(rep.mesh.F(t, 1)), rep.mesh.V.row(rep.mesh.F(t, 2)));
    const BandFrame f = band_frame(rep, t, b);
    const Eigen::Vector3d r = f.surface - f.axis;
    const double radius = std::max(r.norm(), 1e-6);
    const Eigen::Vector3d e1 = r / radius, e3 = f.normal.cross(e1).normalized(), e2 = e3.cross(e1);
    const Eigen::Vector3d d = v - f.axis;
    p.bary.row(i) = b.transpose();
    // Radial: a fraction of the band radius inside the representation surface; outside it, 1 plus
    // the distance beyond the surface in metres, which is not rescaled (a chin far outside a thin
    // neck band would otherwise be thrown forward by the ratio of the two bodies' neck radii).
    const double radial = d.dot(e1);
    p.offset.row(i) << (radial <= radius ? radial / radius : 1.0 + (radial - radius)), d.dot(e2) / radius, d.dot(e3) / radius;
  }
  return p;
}

BodyFeatures torso_levels_in_proportion(BodyFeatures target, const BodyFeatures& source) {
  const auto low = [](const BodyFeatures& f) { return 0.5 * (f.hip[0].y() + f.hip[1].y()); };
  const auto high = [](const BodyFeatures& f) { return 0.5 * (f.shoulder[0].y() + f.shoulder[1].y()); };
  const double ss = high(source) - low(source), ts = high(target) - low(target);
  if (!(ss > 0) || !(ts > 0)) return target;
  const double bottom = target.crotch_y + 0.02, top = std::min(target.armpit[0].y(), target.armpit[1].y()) - 0.02;
  if (!(top > bottom)) return target;
  for (auto [t, s] : {std::pair{&target.hip_y, source.hip_y},
                      {&target.waist_y, source.waist_y},
                      {&target.underbust_y, source.underbust_y},
                      {&target.bust_y, source.bust_y}})
    *t = std::clamp(low(target) + ts * (s - low(source)) / ss, bottom, top);
  return target;
}

Eigen::MatrixXd ctffd_evaluate(const CtffdParametrization& p, const LayeredRepresentation& target) {
  if (target.mesh.F.rows() <= p.triangle.maxCoeff())
    throw InvalidInput("ctffd_evaluate: the target representation has another topology (" + std::to_string(target.mesh.F.rows()) +
                       " triangles)");
  Eigen::MatrixXd out(p.triangle.size(), 3);
  for (Eigen::Index i = 0; i < p.triangle.size(); ++i) {
    const BandFrame f = band_frame(target, p.triangle[i], p.bary.row(i).transpose());
    const Eigen::Vector3d r = f.surface - f.axis;
    const double radius = std::max(r.norm(), 1e-6);
    const Eigen::Vector3d e1 = r / radius, e3 = f.normal.cross(e1).normalized(), e2 = e3.cross(e1);
    const double rho = p.offset(i, 0);
    const double radial = rho <= 1 ? rho * radius : radius + (rho - 1.0);
    out.row(i) = (f.axis + radial * e1 + radius * (p.offset(i, 1) * e2 + p.offset(i, 2) * e3)).transpose();
  }
  return out;
}

}  // namespace posekit
