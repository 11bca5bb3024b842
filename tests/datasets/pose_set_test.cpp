#include "posekit/datasets/pose_set.h"

#include <gtest/gtest.h>

#include <set>

#include "posekit/body/parts.h"
#include "testing/makehuman_fixture.h"

using namespace posekit;

namespace {
double max_angle_deg(const std::vector<NamedPose>& poses, const char* joint) {
  double best = 0;
  for (const auto& p : poses) best = std::max(best, p.pose.joint_rotation[find_joint_index(joint)].norm() * 180 / M_PI);
  return best;
}
}  // namespace

TEST(PoseSet, SeventyPlusDistinctPosesCoveringTheJointRanges) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Eigen::MatrixXd J = joint_centres(model.rig, build_body(model, BodySpec{}));
  const auto poses = standard_pose_set(J, 1);
  EXPECT_GE(poses.size(), 70u);
  std::set<std::string> names;
  int test = 0;
  for (const auto& p : poses) names.insert(p.name), test += p.test;
  EXPECT_EQ(names.size(), poses.size());
  EXPECT_GE(test * 5, static_cast<int>(poses.size()));  // at least 20% held out
  EXPECT_NEAR(max_angle_deg(poses, "left_shoulder"), 150, 1e-9);
  EXPECT_NEAR(max_angle_deg(poses, "right_elbow"), 140, 1e-9);
  EXPECT_NEAR(max_angle_deg(poses, "left_hip"), 100, 1e-9);
  EXPECT_NEAR(max_angle_deg(poses, "right_knee"), 130, 1e-9);
  for (const char* j : {"lower_back", "upper_back", "neck", "left_wrist", "right_ankle"}) EXPECT_GT(max_angle_deg(poses, j), 14) << j;
  for (const char* combo : {"walk_phase_0", "reach_forward", "squat_deep", "sitting"}) EXPECT_TRUE(names.count(combo)) << combo;
}

TEST(PoseSet, ElbowFlexionBringsTheForearmForward) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Eigen::MatrixXd J = joint_centres(model.rig, build_body(model, BodySpec{}));
  const JointAxes ax = joint_axes(J);
  for (bool left : {true, false}) {
    const Eigen::Vector3d elbow = J.row(find_joint_index(left ? "left_elbow" : "right_elbow"));
    const Eigen::Vector3d wrist = J.row(find_joint_index(left ? "left_wrist" : "right_wrist"));
    const Eigen::Matrix3d R = rotation_from_axis_angle(M_PI / 2 * (left ? ax.left_elbow_flex : ax.right_elbow_flex));
    const Eigen::Vector3d moved = elbow + R * (wrist - elbow);
    EXPECT_GT(moved.z(), elbow.z() + 0.15) << (left ? "left" : "right");
  }
}

TEST(PoseSet, SeedChangesOnlyTheRandomPoses) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Eigen::MatrixXd J = joint_centres(model.rig, build_body(model, BodySpec{}));
  const auto a = standard_pose_set(J, 1), b = standard_pose_set(J, 2), c = standard_pose_set(J, 1);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    const bool same = a[i].pose.joint_rotation == b[i].pose.joint_rotation;
    EXPECT_EQ(same, a[i].name.rfind("random_", 0) != 0) << a[i].name;
    EXPECT_EQ(a[i].pose.joint_rotation, c[i].pose.joint_rotation);
  }
}

TEST(PoseSet, PoseFromARestTurnsEachPartAfterItsRestTurn) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Eigen::MatrixXd J = joint_centres(model.rig, build_body(model, BodySpec{}));
  const PartPose rest = natural_rest_pose(J);
  // The arms 25 degrees closer to the body, the elbows bent 25 degrees; nothing else moves.
  for (const char* joint : {"left_shoulder", "right_shoulder", "left_elbow", "right_elbow"})
    EXPECT_NEAR(rest.joint(find_joint_index(joint)).norm() * 180 / M_PI, 25, 1e-9) << joint;
  const Eigen::Vector3d shoulder = J.row(find_joint_index("left_shoulder")), elbow = J.row(find_joint_index("left_elbow"));
  const Eigen::Vector3d arm = (elbow - shoulder).normalized();
  const Eigen::Vector3d lowered = rotation_from_axis_angle(rest.joint(find_joint_index("left_shoulder"))) * arm;
  const Eigen::Vector3d down = -Eigen::Vector3d::UnitY();
  EXPECT_NEAR(std::acos(arm.dot(down)) * 180 / M_PI - std::acos(lowered.dot(down)) * 180 / M_PI, 25, 0.5);
  // World rotations compose: each part as the rest turns it, then as the pose does.
  const auto poses = standard_pose_set(J, 1);
  auto world = [](const PartPose& p) {
    std::array<Eigen::Matrix3d, kNumParts> g;
    g[kPelvis] = rotation_from_axis_angle(p.root_rotation);
    for (int part = 1; part < kNumParts; ++part) g[part] = g[part_parent(part)] * rotation_from_axis_angle(p.joint(part - 1));
    return g;
  };
  for (const NamedPose& p : poses) {
    const auto both = world(pose_from_rest(p.pose, rest)), by_pose = world(p.pose), at_rest = world(rest);
    for (int part = 0; part < kNumParts; ++part) EXPECT_LT((both[part] - by_pose[part] * at_rest[part]).norm(), 1e-9) << p.name << part;
  }
  // From the template's own rest a pose is itself.
  const PartPose same = pose_from_rest(poses[7].pose, PartPose{});
  for (int j = 0; j < kNumJoints; ++j) EXPECT_LT((same.joint(j) - poses[7].pose.joint(j)).norm(), 1e-12);
}
