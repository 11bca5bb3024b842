#include "posekit/segmentation/skeleton_checks.h"

#include <gtest/gtest.h>

#include "posekit/body/parts.h"
#include "posekit/body/subjects.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/segmentation/segmentation.h"
#include "posekit/segmentation/skeleton_embedding.h"
#include "posekit/shape/body_features.h"
#include "posekit/shape/layered_representation.h"
#include "testing/makehuman_fixture.h"

using namespace posekit;

namespace {

bool mentions(const SkeletonCheck& check, const std::string& text) {
  for (const auto& p : check.problems)
    if (p.find(text) != std::string::npos) return true;
  return false;
}

struct Truth {
  TriangleMesh mesh;
  Eigen::VectorXi labels;
  Eigen::MatrixXd joints;
};

Truth truth_of(const MakeHumanModel& model, const BodySpec& spec) {
  const Body b = build_body(model, spec);
  return {b.mesh, triangle_part_labels(b.mesh.F, vertex_part_labels(model)), joint_centres(model.rig, b)};
}

}  // namespace

// The rig's own labels and joints, and posekit's segmentation and feature joints, pass on all 16
// subjects (measured: shoulders from features lie at most 2.2 border radii from the border centre,
// hips from the rig 1.1; left and right limb segments within 5%).
TEST(SkeletonChecks, TheSixteenSubjectsPass) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  for (const auto& s : make_subject_specs(model, 1, 16)) {
    const Truth t = truth_of(model, s.spec);
    const SkeletonCheck truth = check_skeleton(t.mesh.V, t.mesh.F, t.labels, t.joints);
    EXPECT_TRUE(truth.ok()) << s.id << " rig: " << truth.summary();
    const BodyFeatures f = find_body_features(t.mesh.V, t.mesh.F);
    const LayeredRepresentation rep = build_layered_representation(t.mesh.V, t.mesh.F, f);
    const Segmentation seg = segment_body(t.mesh.V, t.mesh.F, rep);
    const Eigen::MatrixXd J = joint_centres_from_features(t.mesh.V, t.mesh.F, seg.triangle_part, rep, f);
    const SkeletonCheck found = check_skeleton(t.mesh.V, t.mesh.F, seg.triangle_part, J);
    EXPECT_TRUE(found.ok()) << s.id << " posekit: " << found.summary();
  }
}

// The real registration of the issue: both hips on the subject's right (x = -0.10 and -0.21 m), the
// upper thighs labelled pelvis, an elbow 8 cm low.
TEST(SkeletonChecks, HipsOnOneSideAndALowElbowAreCaught) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  Truth t = truth_of(model, make_subject_spec(model, 1, 9).spec);  // m02
  const Eigen::MatrixXd C = face_centroids(t.mesh.V, t.mesh.F);
  const int left_hip = find_joint_index("left_hip"), right_hip = find_joint_index("right_hip");
  const double mid_thigh = 0.5 * (t.joints(left_hip, 1) + t.joints(find_joint_index("left_knee"), 1));
  for (Eigen::Index f = 0; f < t.mesh.F.rows(); ++f)
    if ((t.labels[f] == kLeftThigh || t.labels[f] == kRightThigh) && C(f, 1) > mid_thigh) t.labels[f] = kPelvis;
  t.joints(left_hip, 0) = -0.10;
  t.joints(right_hip, 0) = -0.21;
  const int left_elbow = find_joint_index("left_elbow");
  t.joints(left_elbow, 1) -= 0.08;
  const SkeletonCheck check = check_skeleton(t.mesh.V, t.mesh.F, t.labels, t.joints);
  EXPECT_TRUE(mentions(check, "left_hip (joint) lies")) << check.summary();
  EXPECT_TRUE(mentions(check, "on the right side")) << check.summary();
  EXPECT_TRUE(mentions(check, "left and right thigh lengths differ")) << check.summary();
  EXPECT_TRUE(mentions(check, "left and right upper arm lengths differ")) << check.summary();
  EXPECT_FALSE(mentions(check, "right_hip (joint) lies")) << check.summary();  // that one is on its side
  EXPECT_TRUE(mentions(check, "right_hip lies")) << check.summary();           // but far from its border
}

TEST(SkeletonChecks, SwallowedSplitAndMissingPartsAreCaught) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Truth t = truth_of(model, make_subject_spec(model, 1, 2).spec);  // f03
  const Eigen::MatrixXd C = face_centroids(t.mesh.V, t.mesh.F);
  // The left shank swallows the lower two thirds of the left thigh.
  Eigen::VectorXi swallowed = t.labels;
  const double knee = t.joints(find_joint_index("left_knee"), 1), hip = t.joints(find_joint_index("left_hip"), 1);
  for (Eigen::Index f = 0; f < C.rows(); ++f)
    if (t.labels[f] == kLeftThigh && C(f, 1) < knee + 0.66 * (hip - knee)) swallowed[f] = kLeftShank;
  SkeletonCheck check = check_skeleton(t.mesh.V, t.mesh.F, swallowed, t.joints);
  EXPECT_TRUE(mentions(check, "left_thigh and right_thigh differ in area")) << check.summary();
  EXPECT_TRUE(mentions(check, "left_shank and right_shank differ in area")) << check.summary();
  // A band across the left forearm labelled upper arm: the upper arm in two pieces, the forearm too.
  Eigen::VectorXi split = t.labels;
  const Eigen::RowVector3d elbow = t.joints.row(find_joint_index("left_elbow")), wrist = t.joints.row(find_joint_index("left_wrist"));
  const Eigen::RowVector3d axis = (wrist - elbow).normalized();
  const double length = (wrist - elbow).norm();
  for (Eigen::Index f = 0; f < C.rows(); ++f) {
    const double along = (C.row(f) - elbow).dot(axis) / length;
    if (t.labels[f] == kLeftForearm && along > 0.45 && along < 0.6) split[f] = kLeftUpperArm;
  }
  check = check_skeleton(t.mesh.V, t.mesh.F, split, t.joints);
  EXPECT_TRUE(mentions(check, "left_upper_arm is in ")) << check.summary();
  EXPECT_TRUE(mentions(check, "left_forearm is in 2 pieces")) << check.summary();
  // The left hand labelled forearm: no hand, and the wrist joins nothing.
  Eigen::VectorXi handless = t.labels;
  for (Eigen::Index f = 0; f < C.rows(); ++f)
    if (handless[f] == kLeftHand) handless[f] = kLeftForearm;
  check = check_skeleton(t.mesh.V, t.mesh.F, handless, t.joints);
  EXPECT_TRUE(mentions(check, "no triangle is labelled left_hand")) << check.summary();
  EXPECT_THROW(check_skeleton(t.mesh.V, t.mesh.F, t.labels.head(10), t.joints), InvalidInput);
}

// The prior's limb joints are kept within the tolerance of the body's own, replaced beyond it; the
// hips are always the body's, and so are the elbow and wrist of a cut hand (the prior's slid up
// the shortened arm by up to 3.4 cm on the robustness set and stayed within the 3 cm tolerance).
TEST(SkeletonEmbedding, ReconcileTakesTheBodysHipsCutArmsAndFarLimbJoints) {
  const Eigen::MatrixXd prior = Eigen::MatrixXd::Zero(kNumJoints, 3);
  BodyFeatures f;
  for (int side : {kLeft, kRight}) {
    f.elbow[side] = f.wrist[side] = f.knee[side] = f.ankle[side] = f.hip[side] = Eigen::Vector3d(0.02, 0, 0);
  }
  f.ankle[kRight] = Eigen::Vector3d(0, 0.05, 0);
  f.hand_cut[kRight] = true;
  std::vector<std::string> notes;
  const Eigen::MatrixXd J = reconcile_limb_joints(prior, f, 0.03, &notes);
  auto row = [&](const char* name) -> Eigen::Vector3d { return J.row(find_joint_index(name)).transpose(); };
  EXPECT_EQ(row("left_elbow"), Eigen::Vector3d::Zero());  // 2 cm: the prior's kept
  EXPECT_EQ(row("left_wrist"), Eigen::Vector3d::Zero());
  EXPECT_EQ(row("left_knee"), Eigen::Vector3d::Zero());
  EXPECT_EQ(row("right_elbow"), f.elbow[kRight]);  // the hand is cut
  EXPECT_EQ(row("right_wrist"), f.wrist[kRight]);
  EXPECT_EQ(row("left_hip"), f.hip[kLeft]);
  EXPECT_EQ(row("right_ankle"), f.ankle[kRight]);  // 5 cm: replaced, with a note
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("right_ankle"), std::string::npos);
  EXPECT_EQ(row("upper_back"), Eigen::Vector3d::Zero());
  EXPECT_THROW(reconcile_limb_joints(Eigen::MatrixXd::Zero(3, 3), f), InvalidInput);
}
