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
