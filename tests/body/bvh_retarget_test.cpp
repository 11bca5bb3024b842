#include "posekit/body/bvh_retarget.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>

#include "posekit/core/error.h"
#include "testing/makehuman_fixture.h"

using namespace posekit;

namespace {

std::string motion_file(const std::string& name) {
  return (std::filesystem::path(test::test_data_root()).parent_path() / "motions" / "cmu" / name).string();
}

/// Joint centres of a 16-part pose by forward kinematics (the pelvis turns about the mean of its
/// three joints), #joints x 3.
Eigen::MatrixXd posed_joints(const PartPose& pose, const Eigen::MatrixXd& rest) {
  std::array<Eigen::Matrix3d, kNumParts> R;
  Eigen::MatrixXd out(kNumJoints, 3);
  const Eigen::Vector3d centre = (rest.row(kAbdomen - 1) + rest.row(kLeftThigh - 1) + rest.row(kRightThigh - 1)).transpose() / 3;
  R[kPelvis] = rotation_from_axis_angle(pose.root_rotation);
  for (int p = 1; p < kNumParts; ++p) {
    const int parent = part_parent(p);
    R[p] = R[parent] * rotation_from_axis_angle(pose.joint(p - 1));
    const Eigen::Vector3d x = rest.row(p - 1).transpose();
    if (parent == kPelvis) {
      out.row(p - 1) = (centre + R[kPelvis] * (x - centre) + pose.root_translation).transpose();
    } else {
      const Eigen::Vector3d xp = rest.row(parent - 1).transpose();
      out.row(p - 1) = out.row(parent - 1) + (R[parent] * (x - xp)).transpose();
    }
  }
  return out;
}

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI;
}

}  // namespace

TEST(BvhRetarget, BothCmuNamingsAreMappedByNameAndStructure) {
  ASSERT_FALSE(test::test_data_root().empty());
  // "LeftShoulder" is a clavicle in one conversion and the upper arm in the other.
  const BvhMotion a = read_bvh(motion_file("01_01.bvh")), b = read_bvh(motion_file("131_01.bvh"));
  const BvhPartMap ma = map_bvh_skeleton(a), mb = map_bvh_skeleton(b);
  auto name = [](const BvhMotion& m, const BvhPartMap& map, int part) { return m.joints[static_cast<size_t>(map.joint[part])].name; };
  EXPECT_EQ(name(a, ma, kLeftUpperArm), "LeftArm");
  EXPECT_EQ(name(b, mb, kLeftUpperArm), "LeftShoulder");
  EXPECT_EQ(name(a, ma, kRightForearm), "RightForeArm");
  EXPECT_EQ(name(b, mb, kRightForearm), "RightElbow");
  EXPECT_EQ(name(a, ma, kLeftThigh), "LeftUpLeg");
  EXPECT_EQ(name(b, mb, kLeftThigh), "LeftHip");
  EXPECT_EQ(name(a, ma, kRightFoot), "RightFoot");
  EXPECT_EQ(name(b, mb, kRightFoot), "RightAnkle");
  EXPECT_EQ(name(a, ma, kPelvis), "Hips");
  for (int p = 0; p < kNumParts; ++p) {
    EXPECT_GE(ma.joint[p], 0) << part_name(p);
    EXPECT_GE(mb.joint[p], 0) << part_name(p);
  }
}

TEST(BvhRetarget, CmuMotionsPoseTheBodyAsTheFilesOwnKinematicsMoveIt) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Body body = build_body(model, BodySpec{});
  const Eigen::MatrixXd rest = joint_centres(model.rig, body);
  const std::pair<int, int> bones[] = {{kLeftThigh, kLeftShank},        {kLeftShank, kLeftFoot},       {kRightThigh, kRightShank},
                                       {kRightShank, kRightFoot},       {kLeftUpperArm, kLeftForearm}, {kLeftForearm, kLeftHand},
                                       {kRightUpperArm, kRightForearm}, {kRightForearm, kRightHand}};
  for (const char* file : {"01_01.bvh", "131_01.bvh"}) {
    const BvhMotion m = read_bvh(motion_file(file));
    const BvhPartMap map = map_bvh_skeleton(m);
    const std::vector<PartPose> poses = retarget_bvh(m, map, rest);
    ASSERT_EQ(static_cast<int>(poses.size()), m.num_frames()) << file;
    double worst = 0, lowest = 1e9;
    for (int f = 0; f < m.num_frames(); f += 20) {
      const Eigen::MatrixXd ours = posed_joints(poses[static_cast<size_t>(f)], rest);
      const Eigen::MatrixXd theirs = bvh_joints_in_body_frame(m, map, rest, f);
      // Every limb bone points where the file's does (no limb inverted, left on the left).
      for (const auto& [p, child] : bones) {
        const Eigen::Vector3d d_ours = (ours.row(child - 1) - ours.row(p - 1)).transpose();
        const Eigen::Vector3d d_file = (theirs.row(map.joint[child]) - theirs.row(map.joint[p])).transpose();
        worst = std::max(worst, angle_deg(d_ours, d_file));
      }
      const double ankles = std::min(ours(kLeftFoot - 1, 1), ours(kRightFoot - 1, 1));
      lowest = std::min(lowest, ankles - std::min(rest(kLeftFoot - 1, 1), rest(kRightFoot - 1, 1)));
    }
    EXPECT_LT(worst, 1.0) << file;
    // Feet on the ground: never below our floor (the rest ankles' height), and on it at the file's lowest.
    EXPECT_GT(lowest, -0.005) << file;
    EXPECT_LT(lowest, 0.03) << file;
  }
}

TEST(BvhRetarget, AnUnknownSkeletonNamesWhatIsMissingAndAJointMapFixesIt) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  BvhMotion m = read_bvh(motion_file("01_01.bvh"));
  for (auto& j : m.joints)
    if (j.name == "LeftHand") j.name = "Paw_A";
  try {
    map_bvh_skeleton(m);
    FAIL() << "a skeleton without a left hand was mapped";
  } catch (const InvalidInput& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("left_hand"), std::string::npos) << what;
    EXPECT_NE(what.find("--joint-map"), std::string::npos) << what;
  }
  const BvhPartMap map = map_bvh_skeleton(m, {{"left_wrist", "Paw_A"}});
  EXPECT_EQ(m.joints[static_cast<size_t>(map.joint[kLeftHand])].name, "Paw_A");
  EXPECT_EQ(m.joints[static_cast<size_t>(map.joint[kLeftUpperArm])].name, "LeftArm");  // from the wrist's parents
  EXPECT_THROW(map_bvh_skeleton(m, {{"left_wrist", "Nope"}}), InvalidInput);
  EXPECT_THROW(map_bvh_skeleton(m, {{"left_paw", "Paw_A"}}), InvalidInput);
}
