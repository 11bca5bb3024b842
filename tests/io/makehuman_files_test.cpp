// The real MakeHuman assets (read from the data root, never copied) through the generic readers.
#include <gtest/gtest.h>

#include "posekit/core/mesh_validation.h"
#include "posekit/io/bvh.h"
#include "posekit/io/mesh_io.h"
#include "testing/temp_dir.h"

using namespace posekit;

class MakeHumanFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = test::test_data_root();
    if (root_.empty()) GTEST_FAIL() << "POSEKIT_DATA does not point at the MakeHuman assets";
  }
  std::string root_;
};

TEST_F(MakeHumanFiles, BaseMeshBodyGroupHas13380VerticesInMetres) {
  const TriangleMesh base = read_mesh(root_ + "/3dobjs/base.obj", {Unit::kDecimetre});
  EXPECT_EQ(base.num_vertices(), 19158);
  const TriangleMesh body = extract_group(base, "body");
  EXPECT_EQ(body.num_vertices(), 13380);
  EXPECT_EQ(body.num_faces(), 2 * 13378);  // quads split in two
  const MeshReport r = validate_mesh(body);
  EXPECT_TRUE(r.usable());
  EXPECT_EQ(r.components, 1);
  const double stature = body.V.col(1).maxCoeff() - body.V.col(1).minCoeff();
  EXPECT_GT(stature, 1.5);
  EXPECT_LT(stature, 2.0);
  // Helper groups are kept as groups.
  EXPECT_GT(base.group_names.size(), 100u);
}

TEST_F(MakeHumanFiles, BenchmarkPoseHas163JointsAndOneFrame) {
  const BvhMotion m = read_bvh(root_ + "/poses/benchmark.bvh", Unit::kDecimetre);
  EXPECT_EQ(m.joints.size(), 163u);
  EXPECT_EQ(m.num_frames(), 1);
  EXPECT_GE(m.find_joint("lowerarm01.L"), 0);
  const Eigen::MatrixXd P = m.joint_positions(0);
  EXPECT_TRUE(P.allFinite());
}

TEST_F(MakeHumanFiles, WalkMotionReadsAllFrames) {
  const BvhMotion m = read_bvh(root_ + "/animations/walks/walk1.bvh", Unit::kCentimetre);
  EXPECT_GT(m.num_frames(), 10);
  EXPECT_EQ(m.frames.cols(), m.joints.back().first_channel + static_cast<int>(m.joints.back().channels.size()));
}
