#pragma once
// Posing the 163-bone rig: per-bone rotations -> bone transforms -> linear blend or dual
// quaternion skinning.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

#include "posekit/body/makehuman_model.h"
#include "posekit/io/bvh.h"

namespace posekit {

/// Rotations of every bone relative to its parent, expressed in the rest (world) frame:
/// a bone's global rotation is G_b = G_parent(b) * local[b]. Identity everywhere = rest pose.
struct BonePose {
  std::vector<Eigen::Matrix3d> local;
  Eigen::Vector3d root_translation = Eigen::Vector3d::Zero();  ///< m
  static BonePose identity(int num_bones);
};

/// Rigid transform of each bone: a rest point x of bone b goes to R[b] x + t[b].
struct BoneTransforms {
  std::vector<Eigen::Matrix3d> R;
  std::vector<Eigen::Vector3d> t;
};

/// Forward kinematics: rotates each bone about its rest head (bone_heads, #bones x 3).
BoneTransforms pose_bone_transforms(const Rig& rig, const Eigen::MatrixXd& bone_heads, const BonePose& pose);

/// Linear blend skinning U = sum_b W(v,b) (R_b v + t_b). V #V x 3, W #V x #bones (rows sum to 1).
Eigen::MatrixXd linear_blend_skinning(const Eigen::MatrixXd& V, const Eigen::SparseMatrix<double, Eigen::RowMajor>& W,
                                      const BoneTransforms& transforms);

/// Dual quaternion skinning (Kavan et al. 2008, ref. [8] of Zhu & Mok): blends unit dual
/// quaternions, so joints keep their volume where LBS collapses them.
Eigen::MatrixXd dual_quaternion_skinning(const Eigen::MatrixXd& V, const Eigen::SparseMatrix<double, Eigen::RowMajor>& W,
                                         const BoneTransforms& transforms);

/// The body in a bone pose: its mesh by dual quaternion skinning with the rig's weights, and its bone
/// heads and tails moved with their bones.
Body skin_body(const MakeHumanModel& model, const Body& body, const BonePose& pose);

/// Bone rotations from a BVH frame of the MakeHuman default skeleton (its BVH files are Z-up with an
/// A-pose rest; rotations are converted to this Y-up frame). Joints are matched by name; a BVH that
/// shares fewer than half of the rig's bones throws InvalidInput naming the file's skeleton.
BonePose bone_pose_from_bvh(const Rig& rig, const BvhMotion& motion, int frame);

}  // namespace posekit
