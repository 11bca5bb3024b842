#pragma once
// Rigid part deformation T^R (Eq. 1, section 3.3.1 of Zhu & Mok): forward kinematics of the
// 16-part tree from joint rotations.
#include <Eigen/Core>
#include <array>

#include "posekit/body/parts.h"

namespace posekit {

/// Rigid motion of each part: a rest point x of part p goes to R[p] x + t[p].
struct PartTransforms {
  std::array<Eigen::Matrix3d, kNumParts> R;
  std::array<Eigen::Vector3d, kNumParts> t;
};

/// Throws InvalidInput naming the joint when a rotation is not finite or exceeds 2 pi.
void validate_part_pose(const PartPose& pose, const std::string& context);

/// World rotation of each part: R[child] = R[parent] * rotation(joint), R[pelvis] = root rotation.
std::array<Eigen::Matrix3d, kNumParts> part_rotations(const PartPose& pose);

/// Forward kinematics about the joint centres (#joints x 3, rest pose); the pelvis turns about the
/// mean of its three joints and then moves by the root translation.
PartTransforms part_transforms(const PartPose& pose, const Eigen::MatrixXd& joint_centres);

/// The 16-part pose realised by a pose of the 163-bone rig: each joint's rotation is the relative
/// world rotation of the bones that start its two parts (inverse of bone_pose_from_part_pose on the
/// part bones; rotations of bones inside a part are folded into their part).
PartPose part_pose_from_bone_pose(const Rig& rig, const BonePose& pose);

}  // namespace posekit
