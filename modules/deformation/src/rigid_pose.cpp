#include "posekit/deformation/rigid_pose.h"

#include <Eigen/Geometry>
#include <cmath>
#include <string>

#include "posekit/core/error.h"

namespace posekit {

void validate_part_pose(const PartPose& pose, const std::string& context) {
  auto check = [&](const Eigen::Vector3d& r, const std::string& what) {
    if (!r.allFinite()) throw InvalidInput(context + ": " + what + " is not a finite number");
  };
  for (int j = 0; j < kNumJoints; ++j) {
    check(pose.joint(j), "rotation of joint '" + joint_name(j) + "'");
    if (pose.joint(j).norm() > 2 * M_PI + 1e-9)
      throw InvalidInput(context + ": rotation of joint '" + joint_name(j) + "' exceeds 2 pi radians (degrees given?)");
  }
  check(pose.root_rotation, "root_rotation");
  check(pose.root_translation, "root_translation");
}

std::array<Eigen::Matrix3d, kNumParts> part_rotations(const PartPose& pose) {
  std::array<Eigen::Matrix3d, kNumParts> R;
  R[kPelvis] = rotation_from_axis_angle(pose.root_rotation);
  for (int p = 1; p < kNumParts; ++p)  // parents precede children in the Part order
    R[static_cast<size_t>(p)] = R[static_cast<size_t>(part_parent(p))] * rotation_from_axis_angle(pose.joint(p - 1));
  return R;
}

Eigen::Matrix3d cross_product_matrix(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

void apply_pose_increment(PartPose* pose, const Eigen::Ref<const Eigen::VectorXd>& step) {
  if (step.size() != kPoseIncrementSize)
    throw InvalidInput("apply_pose_increment: expected " + std::to_string(kPoseIncrementSize) + " unknowns, got " +
                       std::to_string(step.size()));
  const auto R = part_rotations(*pose);
  std::array<Eigen::Matrix3d, kNumParts> W;
  std::array<Eigen::Vector3d, kNumParts> increment;
  increment[kPelvis] = step.segment<3>(3);
  W[kPelvis] = rotation_from_axis_angle(increment[kPelvis]) * R[kPelvis];
  for (int c = 1; c < kNumParts; ++c) {
    increment[static_cast<size_t>(c)] = increment[static_cast<size_t>(part_parent(c))] + step.segment<3>(6 + 3 * (c - 1));
    W[static_cast<size_t>(c)] = rotation_from_axis_angle(increment[static_cast<size_t>(c)]) * R[static_cast<size_t>(c)];
  }
  pose->root_rotation = axis_angle_from_rotation(W[kPelvis]);
  pose->root_translation += step.head<3>();
  for (int c = 1; c < kNumParts; ++c)
    pose->joint(c - 1) = axis_angle_from_rotation(W[static_cast<size_t>(part_parent(c))].transpose() * W[static_cast<size_t>(c)]);
}

Eigen::Matrix<double, kOffsetFeatures, 1> joint_offset_features(const PartPose& pose, int joint) {
  const Eigen::Vector3d& r = pose.joint(joint);
  Eigen::Matrix<double, kOffsetFeatures, 1> f;
  f << r.x(), r.y(), r.z(), r.x() * r.x(), r.y() * r.y(), r.z() * r.z(), r.x() * r.y(), r.y() * r.z(), r.z() * r.x();
  return f;
}

Eigen::Matrix<double, 3, kOffsetFeatures> pivot_offset_coefficients(const Eigen::Vector3d& D) {
  // (I - R) D = D x r - (r (r.D) - |r|^2 D) / 2 + O(|r|^3); rows: components, columns: features.
  Eigen::Matrix<double, 3, kOffsetFeatures> A = Eigen::Matrix<double, 3, kOffsetFeatures>::Zero();
  A(1, 0) = D.z(), A(2, 0) = -D.y();  // D x r
  A(0, 1) = -D.z(), A(2, 1) = D.x();
  A(0, 2) = D.y(), A(1, 2) = -D.x();
  for (int k = 0; k < 3; ++k) {
    for (int a = 0; a < 3; ++a) A(k, 3 + a) = 0.5 * D[k] - (k == a ? 0.5 * D[a] : 0.0);  // x^2, y^2, z^2
    A(k, 6) = -0.5 * ((k == 0 ? D.y() : 0.0) + (k == 1 ? D.x() : 0.0));                  // xy
    A(k, 7) = -0.5 * ((k == 1 ? D.z() : 0.0) + (k == 2 ? D.y() : 0.0));                  // yz
    A(k, 8) = -0.5 * ((k == 2 ? D.x() : 0.0) + (k == 0 ? D.z() : 0.0));                  // zx
  }
  return A;
}

PartTransforms part_transforms(const PartPose& pose, const Eigen::MatrixXd& joints, const Eigen::MatrixXd& offsets, double scale) {
  if (offsets.size() == 0) return part_transforms(pose, joints);
  if (offsets.rows() != kNumJoints || offsets.cols() != 3 * kOffsetFeatures)
    throw InvalidInput("part_transforms: expected " + std::to_string(kNumJoints) + " x " + std::to_string(3 * kOffsetFeatures) +
                       " joint offsets");
  PartTransforms T = part_transforms(pose, joints);
  for (int p = 1; p < kNumParts; ++p) {
    const size_t q = static_cast<size_t>(part_parent(p)), c = static_cast<size_t>(p);
    const Eigen::Vector3d j = joints.row(p - 1).transpose();
    const Eigen::Matrix<double, kOffsetFeatures, 1> phi = joint_offset_features(pose, p - 1);
    // A row of a column-major matrix is strided: copied before it is read as 3 x 9.
    const Eigen::Matrix<double, 1, 3 * kOffsetFeatures> row = offsets.row(p - 1);
    const Eigen::Map<const Eigen::Matrix<double, 3, kOffsetFeatures, Eigen::RowMajor>> A(row.data());
    const Eigen::Vector3d posed_joint = T.R[q] * j + T.t[q] + scale * (T.R[q] * (A * phi));
    T.t[c] = posed_joint - T.R[c] * j;
  }
  return T;
}

PartTransforms part_transforms(const PartPose& pose, const Eigen::MatrixXd& joints) {
  if (joints.rows() != kNumJoints || joints.cols() != 3)
    throw InvalidInput("part_transforms: expected " + std::to_string(kNumJoints) + " x 3 joint centres");
  PartTransforms T;
  T.R = part_rotations(pose);
  // Pelvis pivot: the mean of lower back and hips.
  const Eigen::Vector3d pivot = (joints.row(kAbdomen - 1) + joints.row(kLeftThigh - 1) + joints.row(kRightThigh - 1)).transpose() / 3;
  T.t[kPelvis] = pivot + pose.root_translation - T.R[kPelvis] * pivot;
  for (int p = 1; p < kNumParts; ++p) {
    const size_t q = static_cast<size_t>(part_parent(p)), c = static_cast<size_t>(p);
    const Eigen::Vector3d j = joints.row(p - 1).transpose();
    const Eigen::Vector3d posed_joint = T.R[q] * j + T.t[q];
    T.t[c] = posed_joint - T.R[c] * j;
  }
  return T;
}

PartPose part_pose_from_bone_pose(const Rig& rig, const BonePose& pose) {
  if (static_cast<int>(pose.local.size()) != rig.num_bones())
    throw InvalidInput("part_pose_from_bone_pose: the pose has " + std::to_string(pose.local.size()) + " bones, the rig " +
                       std::to_string(rig.num_bones()));
  std::vector<Eigen::Matrix3d> world(static_cast<size_t>(rig.num_bones()));
  for (int b = 0; b < rig.num_bones(); ++b) {
    const int p = rig.parent[static_cast<size_t>(b)];
    world[static_cast<size_t>(b)] =
        p < 0 ? pose.local[static_cast<size_t>(b)] : Eigen::Matrix3d(world[static_cast<size_t>(p)] * pose.local[static_cast<size_t>(b)]);
  }
  const auto roots = part_root_bones(rig);
  auto axis_angle = [](const Eigen::Matrix3d& R) -> Eigen::Vector3d {
    const Eigen::AngleAxisd aa(R);
    return aa.angle() * aa.axis();
  };
  PartPose out;
  out.root_rotation = axis_angle(world[static_cast<size_t>(roots[kPelvis])]);
  out.root_translation = pose.root_translation;
  for (int p = 1; p < kNumParts; ++p) {
    const Eigen::Matrix3d& child = world[static_cast<size_t>(roots[static_cast<size_t>(p)])];
    const Eigen::Matrix3d& parent = world[static_cast<size_t>(roots[static_cast<size_t>(part_parent(p))])];
    out.joint(p - 1) = axis_angle(parent.transpose() * child);
  }
  return out;
}

}  // namespace posekit
