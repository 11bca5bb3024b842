#include "posekit/io/bvh.h"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "posekit/core/error.h"
#include "testing/temp_dir.h"

using namespace posekit;

namespace {
// A two-bone arm: root at the origin, elbow 1 unit along +X, hand 1 unit further.
const char* kArm =
    "HIERARCHY\n"
    "ROOT shoulder\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
    "  JOINT elbow\n  {\n    OFFSET 10 0 0\n    CHANNELS 3 Xrotation Yrotation Zrotation\n"
    "    End Site\n    {\n      OFFSET 10 0 0\n    }\n  }\n}\n"
    "MOTION\nFrames: 3\nFrame Time: 0.0333333\n"
    "0 0 0 0 0 0 0 0 0\n"
    "1 2 3 90 0 0 0 0 0\n"
    "0 0 0 0 0 0 0 0 90\n";
}  // namespace

TEST(Bvh, ReadsHierarchyChannelsAndAllFrames) {
  test::TempDir dir;
  const BvhMotion m = read_bvh(dir.write("arm.bvh", kArm), Unit::kDecimetre);
  ASSERT_EQ(m.joints.size(), 2u);
  EXPECT_EQ(m.joints[1].parent, 0);
  EXPECT_EQ(m.joints[0].channels.size(), 6u);
  EXPECT_EQ(m.joints[1].first_channel, 6);
  EXPECT_TRUE(m.joints[1].has_end_site);
  EXPECT_NEAR(m.joints[1].offset.x(), 1.0, 1e-12);  // 10 dm
  EXPECT_EQ(m.num_frames(), 3);
  EXPECT_NEAR(m.frame_time, 0.0333333, 1e-9);
  EXPECT_EQ(m.find_joint("elbow"), 1);
  EXPECT_EQ(m.find_joint("knee"), -1);
}

TEST(Bvh, ForwardKinematicsFollowsChannelOrder) {
  test::TempDir dir;
  const BvhMotion m = read_bvh(dir.write("arm.bvh", kArm), Unit::kDecimetre);
  // Frame 1: root moved by (0.1, 0.2, 0.3) m and turned 90 degrees about Z: the elbow goes to +Y.
  const Eigen::MatrixXd P = m.joint_positions(1);
  EXPECT_TRUE(P.row(0).isApprox(Eigen::RowVector3d(0.1, 0.2, 0.3)));
  EXPECT_TRUE(P.row(1).isApprox(Eigen::RowVector3d(0.1, 1.2, 0.3), 1e-12));
  // Channel order ZXY of the root gives R = Rz * Rx * Ry.
  const Eigen::Matrix3d expected = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_TRUE(m.local_rotation(1, 0).isApprox(expected, 1e-12));
  Eigen::MatrixXd frames = m.frames;
  BvhMotion twisted = m;
  twisted.frames.row(0) << 0, 0, 0, 30, 40, 50, 0, 0, 0;
  const Eigen::Matrix3d zxy =
      (Eigen::AngleAxisd(30 * M_PI / 180, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(40 * M_PI / 180, Eigen::Vector3d::UnitX()) *
       Eigen::AngleAxisd(50 * M_PI / 180, Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  EXPECT_TRUE(twisted.local_rotation(0, 0).isApprox(zxy, 1e-12));
}

TEST(Bvh, WriteReadRoundTrip) {
  test::TempDir dir;
  const BvhMotion m = read_bvh(dir.write("arm.bvh", kArm), Unit::kCentimetre);
  write_bvh(dir.file("out.bvh"), m, Unit::kCentimetre);
  const BvhMotion r = read_bvh(dir.file("out.bvh"), Unit::kCentimetre);
  ASSERT_EQ(r.joints.size(), m.joints.size());
  EXPECT_TRUE(r.frames.isApprox(m.frames, 1e-9));
  for (int f = 0; f < m.num_frames(); ++f) EXPECT_TRUE(r.joint_positions(f).isApprox(m.joint_positions(f), 1e-9));
}
