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

/// [v]x: the matrix whose product with u is v x u.
Eigen::Matrix3d cross_product_matrix(const Eigen::Vector3d& v);

/// Unknowns of a pose increment: root translation, root rotation, each joint's rotation.
constexpr int kPoseIncrementSize = 6 + 3 * kNumJoints;

/// Applies a Gauss-Newton pose increment `step` (kPoseIncrementSize): the root translation (3), then
/// world-frame rotation increments of the pelvis and of each joint (3 each, joint order). A joint's
/// increment turns its whole subtree, so increments accumulate down the tree; the relative rotations
/// follow from the new world rotations.
void apply_pose_increment(PartPose* pose, const Eigen::Ref<const Eigen::VectorXd>& step);

/// Forward kinematics about the joint centres (#joints x 3, rest pose); the pelvis turns about the
/// mean of its three joints and then moves by the root translation.
PartTransforms part_transforms(const PartPose& pose, const Eigen::MatrixXd& joint_centres);

/// Features of a learned joint offset: the joint's twist r and its quadratic terms,
/// [r, r_x^2, r_y^2, r_z^2, r_x r_y, r_y r_z, r_z r_x]. (Adding the twist of the joint above the
/// parent part over-fitted: 2.88 against 2.32 mm on the cross-generator test.)
constexpr int kOffsetFeatures = 9;
Eigen::Matrix<double, kOffsetFeatures, 1> joint_offset_features(const PartPose& pose, int joint);

/// The offset coefficients (3 x 9, as a row of joint offsets read 3 x 9) of a joint that turns about
/// the point D (parent's frame, from its centre) instead of its centre: the offset (I - R(r)) D to
/// second order in its twist r, D x r - (r (r.D) - |r|^2 D) / 2.
Eigen::Matrix<double, 3, kOffsetFeatures> pivot_offset_coefficients(const Eigen::Vector3d& D);

/// T^R with pose-dependent joint placement (issue 18, part 5): joint j's centre as the child
/// carries it sits `scale` * A_j phi_j from where the parent carries it, in the parent's frame (a
/// shoulder that rises with the arm, a head turning over its neck bones). `joint_offsets` is
/// #joints x 27, entry (d, f) at d * 9 + f; empty: part_transforms above.
PartTransforms part_transforms(const PartPose& pose, const Eigen::MatrixXd& joint_centres, const Eigen::MatrixXd& joint_offsets,
                               double scale);

/// The 16-part pose realised by a pose of the 163-bone rig: each joint's rotation is the relative
/// world rotation of the bones that start its two parts (inverse of bone_pose_from_part_pose on the
/// part bones; rotations of bones inside a part are folded into their part).
PartPose part_pose_from_bone_pose(const Rig& rig, const BonePose& pose);

}  // namespace posekit
