#include "posekit/body/skinning.h"

#include <Eigen/Geometry>

#include "posekit/core/error.h"

namespace posekit {

BonePose BonePose::identity(int num_bones) {
  BonePose p;
  p.local.assign(num_bones, Eigen::Matrix3d::Identity());
  return p;
}

BoneTransforms pose_bone_transforms(const Rig& rig, const Eigen::MatrixXd& heads, const BonePose& pose) {
  const int nb = rig.num_bones();
  if (static_cast<int>(pose.local.size()) != nb || heads.rows() != nb)
    throw InvalidInput("pose_bone_transforms: the pose has " + std::to_string(pose.local.size()) + " bones and the heads " +
                       std::to_string(heads.rows()) + ", the rig " + std::to_string(nb));
  BoneTransforms out;
  out.R.resize(nb);
  out.t.resize(nb);
  std::vector<Eigen::Vector3d> posed_head(nb);
  for (int b = 0; b < nb; ++b) {  // parents precede children
    const int p = rig.parent[b];
    const Eigen::Vector3d h = heads.row(b).transpose();
    if (p < 0) {
      out.R[b] = pose.local[b];
      posed_head[b] = h + pose.root_translation;
    } else {
      out.R[b] = out.R[p] * pose.local[b];
      posed_head[b] = posed_head[p] + out.R[p] * (h - heads.row(p).transpose());
    }
    out.t[b] = posed_head[b] - out.R[b] * h;
  }
  return out;
}

Eigen::MatrixXd linear_blend_skinning(const Eigen::MatrixXd& V, const Eigen::SparseMatrix<double, Eigen::RowMajor>& W,
                                      const BoneTransforms& T) {
  if (W.rows() != V.rows() || W.cols() != static_cast<Eigen::Index>(T.R.size()))
    throw InvalidInput("linear_blend_skinning: W is " + std::to_string(W.rows()) + " x " + std::to_string(W.cols()) +
                       ", expected #V x #bones");
  Eigen::MatrixXd U(V.rows(), 3);
  for (Eigen::Index v = 0; v < V.rows(); ++v) {
    const Eigen::Vector3d x = V.row(v).transpose();
    Eigen::Vector3d acc = Eigen::Vector3d::Zero();
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(W, v); it; ++it)
      acc += it.value() * (T.R[it.col()] * x + T.t[it.col()]);
    U.row(v) = acc.transpose();
  }
  return U;
}

Eigen::MatrixXd dual_quaternion_skinning(const Eigen::MatrixXd& V, const Eigen::SparseMatrix<double, Eigen::RowMajor>& W,
                                         const BoneTransforms& T) {
  if (W.rows() != V.rows() || W.cols() != static_cast<Eigen::Index>(T.R.size()))
    throw InvalidInput("dual_quaternion_skinning: W is " + std::to_string(W.rows()) + " x " + std::to_string(W.cols()) +
                       ", expected #V x #bones");
  const size_t nb = T.R.size();
  std::vector<Eigen::Vector4d> real(nb), dual(nb);  // (w, x, y, z)
  for (size_t b = 0; b < nb; ++b) {
    const Eigen::Quaterniond q(T.R[b]);
    const Eigen::Quaterniond tq(0, T.t[b].x(), T.t[b].y(), T.t[b].z());
    const Eigen::Quaterniond d = tq * q;
    real[b] << q.w(), q.x(), q.y(), q.z();
    dual[b] = 0.5 * Eigen::Vector4d(d.w(), d.x(), d.y(), d.z());
  }
  Eigen::MatrixXd U(V.rows(), 3);
  for (Eigen::Index v = 0; v < V.rows(); ++v) {
    Eigen::Vector4d r = Eigen::Vector4d::Zero(), d = Eigen::Vector4d::Zero();
    Eigen::Vector4d pivot = Eigen::Vector4d::Zero();
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(W, v); it; ++it) {
      const auto b = static_cast<size_t>(it.col());
      if (pivot.isZero()) pivot = real[b];
      const double w = real[b].dot(pivot) < 0 ? -it.value() : it.value();  // shortest path
      r += w * real[b];
      d += w * dual[b];
    }
    const double norm = r.norm();
    r /= norm;
    d /= norm;
    const Eigen::Quaterniond q(r[0], r[1], r[2], r[3]);
    const Eigen::Quaterniond qd(d[0], d[1], d[2], d[3]);
    const Eigen::Vector3d t = 2.0 * (qd * q.conjugate()).vec();
    U.row(v) = (q * Eigen::Vector3d(V.row(v).transpose()) + t).transpose();
  }
  return U;
}

Body skin_body(const MakeHumanModel& model, const Body& body, const BonePose& pose) {
  const BoneTransforms T = pose_bone_transforms(model.rig, body.bone_heads, pose);
  Body posed = body;
  posed.mesh.V = dual_quaternion_skinning(body.mesh.V, model.weights, T);
  for (int b = 0; b < model.rig.num_bones(); ++b) {
    posed.bone_heads.row(b) = (T.R[b] * body.bone_heads.row(b).transpose() + T.t[b]).transpose();
    posed.bone_tails.row(b) = (T.R[b] * body.bone_tails.row(b).transpose() + T.t[b]).transpose();
  }
  return posed;
}

BonePose bone_pose_from_bvh(const Rig& rig, const BvhMotion& motion, int frame) {
  if (frame < 0 || frame >= motion.num_frames())
    throw InvalidInput("BVH frame " + std::to_string(frame) + " outside 0.." + std::to_string(motion.num_frames() - 1));
  // MakeHuman writes BVH Z-up: (x, y, z)_bvh = (x, -z, y)_posekit.
  Eigen::Matrix3d C;
  C << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  BonePose pose = BonePose::identity(rig.num_bones());
  int matched = 0;
  for (int j = 0; j < static_cast<int>(motion.joints.size()); ++j) {
    const int b = rig.find_bone(motion.joints[j].name);
    if (b < 0) continue;
    ++matched;
    pose.local[b] = C * motion.local_rotation(frame, j) * C.transpose();
  }
  if (matched * 2 < rig.num_bones())
    throw InvalidInput("the BVH skeleton (" + std::to_string(motion.joints.size()) + " joints, root '" +
                       (motion.joints.empty() ? std::string("-") : motion.joints[0].name) + "') shares only " + std::to_string(matched) +
                       " of " + std::to_string(rig.num_bones()) +
                       " bone names with the MakeHuman default rig: expected a BVH for this skeleton (poses/*.bvh)");
  return pose;
}

}  // namespace posekit
