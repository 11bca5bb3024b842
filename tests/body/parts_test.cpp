#include "posekit/body/parts.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

#include "posekit/core/error.h"
#include "posekit/core/mesh_topology.h"
#include "testing/makehuman_fixture.h"

using namespace posekit;

TEST(Parts, TreeIsRootedAtThePelvisWithFifteenJoints) {
  int roots = 0;
  for (int p = 0; p < kNumParts; ++p) {
    if (part_parent(p) < 0) ++roots;
    else EXPECT_LT(part_parent(p), p);
    EXPECT_EQ(mirror_part(mirror_part(p)), p);
  }
  EXPECT_EQ(roots, 1);
  EXPECT_EQ(part_parent(kPelvis), -1);
  EXPECT_EQ(find_joint_index("left_knee"), kLeftShank - 1);
  EXPECT_EQ(find_joint_index("elbow"), -1);
}

TEST(Parts, EveryVertexGetsOneOfSixteenLabelsAndPartsAreConnected) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Eigen::VectorXi labels = vertex_part_labels(model);
  ASSERT_EQ(labels.size(), 13380);
  EXPECT_GE(labels.minCoeff(), 0);
  EXPECT_LT(labels.maxCoeff(), kNumParts);
  const Eigen::VectorXi tri = triangle_part_labels(model.body_F, labels);
  for (int p = 0; p < kNumParts; ++p) {
    std::vector<int> rows;
    for (Eigen::Index f = 0; f < tri.size(); ++f)
      if (tri[f] == p) rows.push_back(static_cast<int>(f));
    ASSERT_FALSE(rows.empty()) << part_name(p);
    Eigen::MatrixXi F(static_cast<Eigen::Index>(rows.size()), 3);
    for (size_t i = 0; i < rows.size(); ++i) F.row(i) = model.body_F.row(rows[i]);
    EXPECT_EQ(connected_components(F, model.num_body_vertices, nullptr), 1) << part_name(p) << " is split";
  }
}

TEST(Parts, LeftAndRightLabelsAreMirrorImages) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Body b = build_body(model, BodySpec{});
  const Eigen::VectorXi labels = vertex_part_labels(model);
  const Eigen::MatrixXd& V = b.mesh.V;
  int mismatched = 0;
  for (Eigen::Index v = 0; v < V.rows(); ++v) {
    const Eigen::RowVector3d m(-V(v, 0), V(v, 1), V(v, 2));
    Eigen::Index best = 0;
    (V.rowwise() - m).rowwise().squaredNorm().minCoeff(&best);
    if (labels[best] != mirror_part(labels[v])) ++mismatched;
  }
  RecordProperty("mirror_mismatches", mismatched);
  EXPECT_LE(mismatched, 10);
}

TEST(Parts, PartPoseJsonRoundTripsAndRejectsBadInput) {
  test::TempDir dir;
  PartPose p;
  p.joint_rotation[find_joint_index("right_knee")] = Eigen::Vector3d(1.2, 0, 0);
  p.root_translation = Eigen::Vector3d(0, 0.1, 0);
  write_part_pose(dir.file("p.json"), p);
  const PartPose r = read_part_pose(dir.file("p.json"));
  for (int j = 0; j < kNumJoints; ++j) EXPECT_EQ(r.joint_rotation[j], p.joint_rotation[j]);
  EXPECT_EQ(r.root_translation, p.root_translation);
  EXPECT_THROW(part_pose_from_json(R"({"joints": {"left_elbo": [0, 0, 1]}})", "p.json"), InvalidInput);
  EXPECT_THROW(part_pose_from_json(R"({"joints": {"left_elbow": [0, 1]}})", "p.json"), InvalidInput);
  EXPECT_THROW(part_pose_from_json(R"({"joints": {"left_elbow": [0, "x", 1]}})", "p.json"), InvalidInput);
  EXPECT_THROW(part_pose_from_json(R"({"joints": {}, "scale": 2})", "p.json"), InvalidInput);
  // A joint given twice would silently lose the first rotation: refused, naming the joint.
  try {
    part_pose_from_json(R"({"joints": {"left_knee": [1.2, 0, 0], "left_knee": [0, 0, 0]}})", "p.json");
    FAIL() << "duplicate joint accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("'left_knee' appears twice in 'joints'"), std::string::npos) << e.what();
  }
}

TEST(Parts, PartPoseRotatesTheChildPartAboutItsJoint) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Body b = build_body(model, BodySpec{});
  PartPose p;
  p.joint_rotation[find_joint_index("left_knee")] = Eigen::Vector3d(M_PI / 2, 0, 0);  // flex backwards
  const BonePose bones = bone_pose_from_part_pose(model.rig, p);
  const BoneTransforms T = pose_bone_transforms(model.rig, b.bone_heads, bones);
  const auto roots = part_root_bones(model.rig);
  const Eigen::Vector3d knee = b.bone_heads.row(roots[kLeftShank]);
  const Eigen::Vector3d ankle = b.bone_heads.row(roots[kLeftFoot]);
  const Eigen::Vector3d moved = T.R[roots[kLeftFoot]] * ankle + T.t[roots[kLeftFoot]];
  EXPECT_LT((T.R[roots[kLeftShank]] * knee + T.t[roots[kLeftShank]] - knee).norm(), 1e-12);  // knee stays
  EXPECT_NEAR((moved - knee).norm(), (ankle - knee).norm(), 1e-12);
  EXPECT_GT(moved.y(), ankle.y() + 0.3);  // the foot comes up behind
  EXPECT_LT(moved.z(), knee.z() - 0.3);
}
