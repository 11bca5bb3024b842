#include "posekit/deformation/pose_synthesis.h"

#include <gtest/gtest.h>

#include "posekit/core/error.h"
#include "posekit/evaluation/pose_evaluation.h"
#include "posekit/io/mesh_io.h"
#include "testing/small_dataset.h"
#include "testing/test_meshes.h"

using namespace posekit;

namespace {

std::shared_ptr<const PoseModel> small_model() {
  static const auto model = std::make_shared<const PoseModel>(train_on_dataset(test::small_dataset().root));
  return model;
}

double method_mean(const std::vector<MethodErrors>& errors, PoseMethod m) {
  for (const auto& e : errors)
    if (e.method == m) return e.all.mean_mm;
  return -1;
}

}  // namespace

TEST(PoseSynthesis, LearnedBeatsBothBaselinesOnTemplateAndSubjects) {
  const auto& ds = test::small_dataset();
  const PoseEvaluation ev = evaluate_poses(ds.root, small_model());
  ASSERT_GT(ev.test_poses, 3);
  ASSERT_EQ(ev.subjects.size(), 2u);
  const double learned = method_mean(ev.template_errors, PoseMethod::kLearned);
  EXPECT_LT(learned, 5.0);
  EXPECT_LT(learned, method_mean(ev.template_errors, PoseMethod::kRigid));
  EXPECT_LT(learned, method_mean(ev.template_errors, PoseMethod::kLbs));
  for (const auto& s : ev.subjects) {
    const double l = method_mean(s.methods, PoseMethod::kLearned);
    EXPECT_LT(l, 10.0) << s.id;
    EXPECT_LT(l, method_mean(s.methods, PoseMethod::kRigid)) << s.id;
    EXPECT_LT(l, method_mean(s.methods, PoseMethod::kLbs)) << s.id;
    EXPECT_GT(s.segmentation_agreement, 0.92) << s.id;
  }
}

TEST(PoseSynthesis, IsAPureFunctionOfModelSubjectAndPose) {
  const auto& ds = test::small_dataset();
  const TriangleMesh subject = read_mesh(ds.root + "/subjects/m01/rest.ply");
  PartPose pose;
  pose.joint_rotation[find_joint_index("left_elbow")] = Eigen::Vector3d(1.0, 0, 0);
  pose.joint_rotation[find_joint_index("right_hip")] = Eigen::Vector3d(-0.6, 0, 0.1);
  const PoseSynthesizer a(small_model(), subject), b(small_model(), subject);
  const Eigen::MatrixXd first = a.pose(pose);
  a.pose(PartPose{});  // an unrelated pose in between changes nothing
  EXPECT_TRUE(a.pose(pose) == first);
  EXPECT_TRUE(b.pose(pose) == first);
  // Zero pose: the rest mesh back (soft anchors and T^Q = I agree).
  EXPECT_LT((a.pose(PartPose{}) - subject.V).rowwise().norm().maxCoeff(), 1e-6);
}

TEST(PoseSynthesis, RejectsBadPosesAndBodies) {
  const auto& ds = test::small_dataset();
  const TriangleMesh subject = read_mesh(ds.root + "/subjects/f01/rest.ply");
  const PoseSynthesizer s(small_model(), subject);
  PartPose nan_pose;
  nan_pose.joint_rotation[4] = Eigen::Vector3d(0, std::nan(""), 0);
  try {
    s.pose(nan_pose);
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("left_elbow"), std::string::npos) << e.what();
  }
  // Two bodies side by side are not one subject.
  TriangleMesh two = subject;
  two.V.conservativeResize(2 * subject.V.rows(), 3);
  two.V.bottomRows(subject.V.rows()) = subject.V.rowwise() + Eigen::RowVector3d(1.5, 0, 0);
  two.F.conservativeResize(2 * subject.F.rows(), 3);
  two.F.bottomRows(subject.F.rows()) = subject.F.array() + static_cast<int>(subject.V.rows());
  EXPECT_THROW(PoseSynthesizer(small_model(), two), Error);
  // Not a body at all.
  EXPECT_THROW(PoseSynthesizer(small_model(), test::icosphere(3)), Error);
  // The template flag on a mesh that is not the template.
  SubjectSetupOptions o;
  o.is_template = true;
  EXPECT_THROW(PoseSynthesizer(small_model(), subject, o), InvalidInput);
}

TEST(PoseEvaluation, RefusesAModelOfAnotherTemplate) {
  const auto& ds = test::small_dataset();
  auto other = std::make_shared<PoseModel>(*small_model());
  other->template_V.col(0) *= 1.1;  // a wider template
  EXPECT_THROW(evaluate_poses(ds.root, other), InvalidInput);
}
