#include "posekit/body/parts.h"
#include "posekit/body/anatomical_driving.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numeric>

#include "posekit/core/error.h"
#include "posekit/core/mesh_topology.h"
#include "posekit/core/point_grid.h"
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
  const PointGrid grid(V);
  int mismatched = 0;
  for (Eigen::Index v = 0; v < V.rows(); ++v) {
    double sq_distance = 0;
    const int best = grid.nearest(Eigen::Vector3d(-V(v, 0), V(v, 1), V(v, 2)), &sq_distance);
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

TEST(AnatomicalDriving, SpreadsEachJointOverItsChainAndEndsWhereThePoseSays) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Body body = build_body(model, BodySpec{});
  const Rig& rig = model.rig;
  PartPose pose;
  pose.root_rotation = Eigen::Vector3d(0, 0.3, 0);
  pose.joint(find_joint_index("left_shoulder")) = 120 * M_PI / 180 * Eigen::Vector3d::UnitZ();
  pose.joint(find_joint_index("lower_back")) = Eigen::Vector3d(0.5, 0.2, 0.1);
  pose.joint(find_joint_index("upper_back")) = Eigen::Vector3d(0.1, 0.4, 0);
  pose.joint(find_joint_index("neck")) = Eigen::Vector3d(0.2, 0.6, 0.1);
  pose.joint(find_joint_index("right_wrist")) = Eigen::Vector3d(0.3, 0.9, 0.2);
  pose.joint(find_joint_index("right_hip")) = Eigen::Vector3d(-1.0, 0.4, 0);
  for (const AnatomicalDriving& d : {AnatomicalDriving{}, AnatomicalDriving::alternative()}) {
    const BonePose bones = anatomical_bone_pose(rig, body, pose, d);
    std::vector<Eigen::Matrix3d> world(static_cast<size_t>(rig.num_bones()));
    for (int b = 0; b < rig.num_bones(); ++b) {
      const int p = rig.parent[static_cast<size_t>(b)];
      world[static_cast<size_t>(b)] = p < 0 ? bones.local[static_cast<size_t>(b)]
                                            : Eigen::Matrix3d(world[static_cast<size_t>(p)] * bones.local[static_cast<size_t>(b)]);
    }
    // The last bone of every chain is where the one-bone-per-part rig puts its part.
    const BonePose rigid = bone_pose_from_part_pose(rig, pose);
    std::vector<Eigen::Matrix3d> rigid_world(world.size());
    for (int b = 0; b < rig.num_bones(); ++b) {
      const int p = rig.parent[static_cast<size_t>(b)];
      rigid_world[static_cast<size_t>(b)] =
          p < 0 ? rigid.local[static_cast<size_t>(b)]
                : Eigen::Matrix3d(rigid_world[static_cast<size_t>(p)] * rigid.local[static_cast<size_t>(b)]);
    }
    for (const char* name : {"spine03", "spine01", "head", "upperarm02.L", "lowerarm02.L", "wrist.R", "upperleg02.R", "foot.R"}) {
      const size_t b = static_cast<size_t>(rig.find_bone(name));
      EXPECT_LT((world[b] - rigid_world[b]).norm(), 1e-9) << d.name << " " << name;
    }
    // Inside the chains the bones share the motion: the clavicle takes its share of the 120 degree raise.
    const double clavicle = Eigen::AngleAxisd(world[static_cast<size_t>(rig.find_bone("clavicle.L"))] *
                                              world[static_cast<size_t>(rig.find_bone("spine01"))].transpose())
                                .angle();
    EXPECT_NEAR(clavicle * 180 / M_PI, 120 * d.girdle_share * d.clavicle_share, 1.0) << d.name;
    const double lumbar_first = Eigen::AngleAxisd(bones.local[static_cast<size_t>(rig.find_bone("spine05"))]).angle();
    EXPECT_GT(lumbar_first, 0.05) << d.name;
    EXPECT_LT(lumbar_first, 0.8 * pose.joint_rotation[0].norm()) << d.name;
  }
  // The rest pose moves nothing.
  const BonePose rest = anatomical_bone_pose(rig, body, PartPose{}, AnatomicalDriving{});
  for (const auto& R : rest.local) EXPECT_LT((R - Eigen::Matrix3d::Identity()).norm(), 1e-12);
}
