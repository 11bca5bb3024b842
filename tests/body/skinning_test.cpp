#include "posekit/body/skinning.h"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/io/bvh.h"
#include "testing/makehuman_fixture.h"

using namespace posekit;

namespace {
Eigen::MatrixXd pose_mesh(const MakeHumanModel& model, const Body& b, const BonePose& pose, bool dqs = false) {
  const BoneTransforms T = pose_bone_transforms(model.rig, b.bone_heads, pose);
  return dqs ? dual_quaternion_skinning(b.mesh.V, model.weights, T) : linear_blend_skinning(b.mesh.V, model.weights, T);
}

/// Mean of the skin vertices of one part (by label).
Eigen::RowVector3d part_centroid(const Eigen::MatrixXd& V, const Eigen::VectorXi& labels, int part) {
  Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
  int n = 0;
  for (Eigen::Index v = 0; v < V.rows(); ++v)
    if (labels[v] == part) c += V.row(v), ++n;
  return c / n;
}
}  // namespace

TEST(Skinning, ZeroRotationsReproduceTheRestMeshExactly) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Body b = build_body(model, BodySpec{});
  const BonePose rest = BonePose::identity(model.rig.num_bones());
  EXPECT_LE((pose_mesh(model, b, rest) - b.mesh.V).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE((pose_mesh(model, b, rest, true) - b.mesh.V).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Skinning, RootMotionMovesEverythingRigidlyInBothSkinnings) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Body b = build_body(model, BodySpec{});
  BonePose p = BonePose::identity(model.rig.num_bones());
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.8, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  p.local[0] = R;
  p.root_translation = Eigen::Vector3d(0.3, -0.1, 2.0);
  const Eigen::Vector3d h = b.bone_heads.row(0).transpose();
  Eigen::MatrixXd expected = ((b.mesh.V.rowwise() - h.transpose()) * R.transpose()).rowwise() + (h + p.root_translation).transpose();
  EXPECT_LE((pose_mesh(model, b, p) - expected).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LE((pose_mesh(model, b, p, true) - expected).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(Skinning, NinetyDegreeElbowFlexionKeepsForearmLengthAndMovesTheWrist) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Body b = build_body(model, BodySpec{});
  const Eigen::MatrixXd J = joint_centres(model.rig, b);
  const Eigen::Vector3d shoulder = J.row(find_joint_index("left_shoulder")), elbow = J.row(find_joint_index("left_elbow"));
  const Eigen::Vector3d wrist = J.row(find_joint_index("left_wrist"));
  // Flex about the axis normal to the upper arm and the forward direction.
  const Eigen::Vector3d axis = (elbow - shoulder).cross(Eigen::Vector3d::UnitZ()).normalized();
  PartPose pose;
  pose.joint_rotation[find_joint_index("left_elbow")] = M_PI / 2 * axis;
  const Eigen::Matrix3d R = rotation_from_axis_angle(pose.joint_rotation[find_joint_index("left_elbow")]);
  const Eigen::VectorXi labels = vertex_part_labels(model);
  for (bool dqs : {false, true}) {
    const Eigen::MatrixXd U = pose_mesh(model, b, bone_pose_from_part_pose(model.rig, pose), dqs);
    // Skin vertices around the wrist (within 3 cm of its centre) move rigidly with the forearm.
    Eigen::RowVector3d rest_ring = Eigen::RowVector3d::Zero(), posed_ring = Eigen::RowVector3d::Zero();
    int n = 0;
    for (Eigen::Index v = 0; v < U.rows(); ++v)
      if ((b.mesh.V.row(v).transpose() - wrist).norm() < 0.03) rest_ring += b.mesh.V.row(v), posed_ring += U.row(v), ++n;
    ASSERT_GT(n, 10);
    rest_ring /= n;
    posed_ring /= n;
    const Eigen::Vector3d predicted = elbow + R * (rest_ring.transpose() - elbow);
    EXPECT_LT((posed_ring.transpose() - predicted).norm(), 0.002) << (dqs ? "dqs" : "lbs");
    const double rest_len = (rest_ring.transpose() - elbow).norm(), posed_len = (posed_ring.transpose() - elbow).norm();
    EXPECT_NEAR(posed_len, rest_len, 0.01 * rest_len);
    // The other arm does not move.
    EXPECT_LT((part_centroid(U, labels, kRightHand) - part_centroid(b.mesh.V, labels, kRightHand)).norm(), 1e-12);
  }
}

TEST(Skinning, BvhPosesMoveTheLimbs) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Body b = build_body(model, BodySpec{});
  const Eigen::VectorXi labels = vertex_part_labels(model);
  const Eigen::MatrixXd J = joint_centres(model.rig, b);
  // tpose.bvh raises the arms to the horizontal: the hands come up to shoulder height.
  const BvhMotion t = read_bvh(model.data_root + "/poses/tpose.bvh", Unit::kDecimetre);
  const Eigen::MatrixXd T = pose_mesh(model, b, bone_pose_from_bvh(model.rig, t, 0));
  for (int hand : {kLeftHand, kRightHand}) {
    const Eigen::RowVector3d c = part_centroid(T, labels, hand);
    EXPECT_NEAR(c.y(), J(find_joint_index("left_shoulder"), 1), 0.06);
    EXPECT_GT(std::abs(c.x()), 0.7);
  }
  // benchmark.bvh moves every limb by more than 10 cm.
  const BvhMotion m = read_bvh(model.data_root + "/poses/benchmark.bvh", Unit::kDecimetre);
  const Eigen::MatrixXd U = pose_mesh(model, b, bone_pose_from_bvh(model.rig, m, 0));
  for (int part : {kLeftHand, kRightHand, kLeftFoot, kRightFoot})
    EXPECT_GT((part_centroid(U, labels, part) - part_centroid(b.mesh.V, labels, part)).norm(), 0.10) << part_name(part);
}

TEST(Skinning, BvhOfAnotherSkeletonIsRejected) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const BvhMotion walk = read_bvh(model.data_root + "/animations/walks/walk1.bvh", Unit::kCentimetre);
  try {
    bone_pose_from_bvh(model.rig, walk, 0);
    FAIL() << "no exception";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("MakeHuman default rig"), std::string::npos) << e.what();
  }
}
