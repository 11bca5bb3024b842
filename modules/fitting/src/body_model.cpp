#include "posekit/fitting/body_model.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <string>

#include "posekit/body/makehuman_model.h"
#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/core/parallel.h"

namespace posekit {

BodyModel::BodyModel(ShapeSpace space, const MakeHumanModel& makehuman) : space_(std::move(space)) {
  if (space_.vertices() != makehuman.num_body_vertices || space_.faces != makehuman.body_F)
    throw InvalidInput("body model: the shape space (" + std::to_string(space_.vertices()) +
                       " vertices) is not of the MakeHuman template's topology (" + std::to_string(makehuman.num_body_vertices) +
                       " vertices)");
  if (!space_.has_joints() || space_.joint_mean.rows() != kNumJoints)
    throw InvalidInput("body model: the shape space does not know the 15 joints (" + space_.population +
                       "); build it with posekit shape-space --ansur (version 2 .pks)");
  part_weights_ = vertex_part_weights(makehuman);
  vertex_part_.resize(static_cast<Eigen::Index>(part_weights_.size()));
  for (size_t v = 0; v < part_weights_.size(); ++v) {
    const auto& pw = part_weights_[v];
    vertex_part_[static_cast<Eigen::Index>(v)] =
        std::max_element(pw.begin(), pw.end(), [](const auto& a, const auto& b) { return a.second < b.second; })->first;
  }
}

ShapedBody::ShapedBody(const BodyModel& model, const Eigen::VectorXd& coefficients, int threads)
    : model_(model), c_(coefficients), V_(model.space().body(coefficients)), J_(model.space().joints(coefficients)), threads_(threads) {}

void ShapedBody::skin(const BodyModel& model, const Eigen::MatrixXd& V, const PartTransforms& T, const std::vector<int>& rows,
                      Eigen::MatrixXd* X, int threads) {
  // Dual quaternion skinning (Kavan et al. 2008) with the 16 parts' weights: joints keep their
  // volume where linear blending collapses them (a hip flexed 90 degrees). For a fixed pose it is
  // still affine in the vertices and joints, which the shape fit relies on.
  std::array<Eigen::Quaterniond, kNumParts> real, dual;
  for (int p = 0; p < kNumParts; ++p) {
    real[static_cast<size_t>(p)] = Eigen::Quaterniond(T.R[static_cast<size_t>(p)]).normalized();
    const Eigen::Vector3d& t = T.t[static_cast<size_t>(p)];
    const Eigen::Quaterniond tq(0, t.x(), t.y(), t.z());
    dual[static_cast<size_t>(p)].coeffs() = 0.5 * (tq * real[static_cast<size_t>(p)]).coeffs();
  }
  const auto n = static_cast<Eigen::Index>(rows.empty() ? V.rows() : static_cast<Eigen::Index>(rows.size()));
  X->resize(n, 3);
  parallel_for_ranges(
      n, threads,
      [&](long begin, long end) {
        for (Eigen::Index i = begin; i < end; ++i) {
          const int v = rows.empty() ? static_cast<int>(i) : rows[static_cast<size_t>(i)];
          const auto& weights = model.part_weights()[static_cast<size_t>(v)];
          const Eigen::Quaterniond& pivot = real[static_cast<size_t>(weights.front().first)];
          Eigen::Vector4d b0 = Eigen::Vector4d::Zero(), be = Eigen::Vector4d::Zero();
          for (const auto& [p, w] : weights) {
            const double sign = real[static_cast<size_t>(p)].coeffs().dot(pivot.coeffs()) < 0 ? -w : w;  // the same hemisphere
            b0 += sign * real[static_cast<size_t>(p)].coeffs();
            be += sign * dual[static_cast<size_t>(p)].coeffs();
          }
          const double norm = b0.norm();
          Eigen::Quaterniond q0, qe;
          q0.coeffs() = b0 / norm;
          qe.coeffs() = be / norm;
          const Eigen::Vector3d t = 2 * (qe * q0.conjugate()).vec();
          X->row(i) = (q0 * Eigen::Vector3d(V.row(v).transpose()) + t).transpose();
        }
      },
      2048);  // whole bodies (13,380 vertices) on two threads; the search's samples on one
}

void ShapedBody::pose(const PartPose& pose, Eigen::MatrixXd* X) const { skin(model_, V_, part_motions(pose), {}, X, threads_); }

PartTransforms ShapedBody::part_motions(const PartPose& pose) const { return part_transforms(pose, J_); }

Eigen::MatrixXd ShapedBody::posed_joints(const PartPose& pose) const {
  const PartTransforms T = part_motions(pose);
  Eigen::MatrixXd out(kNumJoints, 3);
  for (int j = 0; j < kNumJoints; ++j)
    out.row(j) = (T.R[static_cast<size_t>(j + 1)] * J_.row(j).transpose() + T.t[static_cast<size_t>(j + 1)]).transpose();
  return out;
}

}  // namespace posekit
